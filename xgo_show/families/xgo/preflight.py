"""Reading an XGO robot's identity and health: the pre-flight check and ``xgo-show probe``.

Pre-flight: the firmware string names the model, the battery is above the floor.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from xgo_show.errors import XgoShowError
from xgo_show.profiles import Profile, get_profile, model_from_firmware
from xgo_show.transports.base import Transport

if TYPE_CHECKING:
    from xgo_show.client.xgo import XgoClient
    from xgo_show.runtime.preflight import PreflightRow

__all__ = ["check_robot", "probe_rows"]


def check_robot(
    row: PreflightRow, transport: Transport, profile: Profile, floor: float, timeout: float
) -> None:
    """Read the firmware and battery registers; a wrong model or a low battery is a problem."""
    from xgo_show.client import XgoClient

    client = XgoClient(transport, profile, timeout=timeout)
    try:
        row.firmware = client.firmware()
        row.detected = model_from_firmware(row.firmware)
        if row.detected != profile.model:
            seen = row.detected or "an unknown model"
            row.problems.append(f"firmware {row.firmware!r} is {seen}, not {profile.model}")
        row.battery = float(client.battery())
        if row.battery < floor:
            row.problems.append(f"battery {row.battery:.0f}% is below the floor of {floor:g}%")
    except XgoShowError as exc:
        row.problems.append(str(exc))


def probe_rows(client: XgoClient, *, given: str | None) -> list[tuple[str, str]]:
    """``xgo-show probe``: port, model (and how it was found), firmware, battery, status."""
    firmware = client.firmware()
    named = model_from_firmware(firmware)
    if given is None:
        how = "from the URL" if named is None or named != client.model else "from firmware"
        model = f"{client.model} ({how})"
    elif named is not None and named != given:
        model = f"{given} (given; the firmware names a {named})"
        # Read the rest with the robot's own table: the given model's may not match its
        # registers (a Rider has no Mini status register), and a probe should still report.
        from xgo_show.client.xgo import XgoClient

        client = XgoClient(client.transport, get_profile(named), timeout=client.timeout)
    else:
        model = given
    status_reg = client.profile.register("status")
    status_raw = client.read("status")
    status = status_reg.decode_value(status_raw)
    status_text = f"0x{status_raw[0]:02X}"
    if isinstance(status, str):
        status_text = f"{status} ({status_text})"
    return [
        ("port", client.transport.url),
        ("model", model),
        ("firmware", firmware),
        ("battery", f"{client.battery()} %"),
        ("status", status_text),
    ]
