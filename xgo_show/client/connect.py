"""Open a URL and get the right robot client, identifying the model when not given."""

from __future__ import annotations

from typing import Any

from xgo_show.client.base import DEFAULT_TIMEOUT, ClientBase
from xgo_show.client.xgo import XgoClient
from xgo_show.errors import ProfileError, TransportTimeout
from xgo_show.families import get_family
from xgo_show.profiles import get_profile, model_from_firmware
from xgo_show.transports import open_transport, split_wrappers
from xgo_show.transports.base import Transport

__all__ = ["model_hint", "open_client"]


def open_client(
    url: str,
    model: str | None = None,
    *,
    timeout: float = DEFAULT_TIMEOUT,
    baudrate: int | None = None,
    **options: Any,
) -> ClientBase[Any]:
    """Open ``url`` and return a client for the robot on it (close it, or use ``with``).

    ``model`` ("mini", "lite", "rider", "xarm") selects the profile, and its family the
    client (:class:`XarmClient` for the xArm, :class:`XgoClient` for XGO robots). When it is
    None the URL may name it (``sim:<model>``; ``hid:`` is always the xArm), and otherwise the
    robot's firmware string (register 0x07) does, which only XGO robots have: give
    ``model="xarm"`` for an arm on a serial port. The baud rate defaults to the model's link
    rate (115200 for XGO, 9600 for the xArm). ``options`` go to
    :func:`~xgo_show.transports.open_transport`.

    Raises :class:`~xgo_show.errors.TransportError` (cannot open, no reply),
    :class:`~xgo_show.errors.ProtocolError` (garbage) or
    :class:`~xgo_show.errors.ProfileError` (unknown model or firmware).
    """
    if model is None:
        model = model_hint(url)
    profile = get_profile(model) if model is not None else None
    if baudrate is None and profile is not None:
        baudrate = profile.link.baud
    transport = open_transport(url, baudrate=baudrate, **options)
    transport.open()
    try:
        if profile is None:
            profile = get_profile(_identify(transport, url, timeout))
        return get_family(profile).client(transport, profile, timeout=timeout)
    except BaseException:
        transport.close()
        raise


def model_hint(url: str) -> str | None:
    """The model a URL names (wrappers allowed): ``sim:<model>``, ``hid:`` = xArm; else None."""
    scheme, colon, rest = split_wrappers(url)[1].partition(":")
    if colon and scheme == "sim":
        return rest.strip().lower() or None
    if colon and scheme == "hid":
        return "xarm"
    return None


def _identify(transport: Transport, url: str, timeout: float) -> str:
    # Any XGO profile will do for reading the firmware register: it is 0x07 on every model
    # (the vendor's auto-detection reads it too).
    reader = XgoClient(transport, get_profile("mini"), timeout=timeout)
    try:
        firmware = reader.firmware()
    except TransportTimeout as exc:
        # Only XGO robots have a firmware register; an xArm stays silent.
        raise TransportTimeout(f"{exc} (for an xArm, give the model xarm)") from exc
    found = model_from_firmware(firmware)
    if found is None:
        raise ProfileError(
            f"{url} reports firmware {firmware!r}, which names no supported XGO model; "
            "give the model (mini, lite or rider)"
        )
    return found
