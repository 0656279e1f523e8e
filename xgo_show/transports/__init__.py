"""Transports: byte links to robots, opened from URL strings.

:func:`open_transport` picks the transport by the URL's scheme, the way pyserial's
``serial_for_url`` and flockwave-conn do:

- ``/dev/ttyUSB0``, ``COM3``, ``loop://``, ``socket://host:port``, ``rfc2217://...``,
  ``spy://...``: any port or URL pyserial opens ->
  :class:`~xgo_show.transports.serial_port.SerialTransport`;
- ``sim:mini``, ``sim:lite``, ``sim:rider``, ``sim:xarm``: a simulated robot in this process ->
  :class:`~xgo_show.transports.sim.SimTransport`;
- ``hid:...``: the xArm over USB-HID (:mod:`xgo_show.transports.hid`);
- ``hex+<url>`` (alias ``log+<url>``): :class:`~xgo_show.transports.hexlog.HexLogTransport`
  around the transport for ``<url>``, logging traffic as hex lines.

The transport comes back *not yet opened*; use it as a context manager::

    with open_transport("/dev/ttyUSB0", baudrate=115200) as link:
        link.write(frame)
        reply = link.read(64, timeout=0.5)

Scheme modules are imported only when used, so ``hid:`` needs ``hidapi`` only when asked for.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from xgo_show.errors import TransportError
from xgo_show.transports.base import Transport

__all__ = [
    "DEFAULT_BAUDRATE",
    "Transport",
    "open_transport",
    "register_scheme",
    "register_wrapper",
    "split_wrappers",
]

#: Baud rate used when the caller gives none (the XGO robots' rate; the xArm's is 9600 and comes
#: from its profile's :class:`~xgo_show.profiles.model.Link`).
DEFAULT_BAUDRATE = 115200

#: ``factory(url, *, baudrate, **options) -> Transport`` for a whole URL.
SchemeFactory = Callable[..., Transport]
#: ``factory(inner, **options) -> Transport`` wrapping another transport.
WrapperFactory = Callable[..., Transport]

# scheme -> "module:attribute", imported on first use (or the factory itself once registered).
_SCHEMES: dict[str, str | SchemeFactory] = {
    "sim": "xgo_show.transports.sim:open_sim",
    "hid": "xgo_show.transports.hid:open_hid",
}
_WRAPPERS: dict[str, str | WrapperFactory] = {
    "hex": "xgo_show.transports.hexlog:HexLogTransport",
    "log": "xgo_show.transports.hexlog:HexLogTransport",
}
_SERIAL = "xgo_show.transports.serial_port:open_serial"


def register_scheme(scheme: str, factory: SchemeFactory) -> None:
    """Make ``scheme:...`` URLs open with ``factory(url, *, baudrate, **options)``."""
    _SCHEMES[scheme] = factory


def register_wrapper(name: str, factory: WrapperFactory) -> None:
    """Make ``name+<url>`` wrap the transport for ``<url>`` with ``factory(inner, **options)``."""
    _WRAPPERS[name] = factory


def split_wrappers(url: str) -> tuple[list[str], str]:
    """Split ``hex+sim:mini`` into ``(["hex"], "sim:mini")`` (outermost wrapper first)."""
    wrappers: list[str] = []
    while True:
        head, plus, rest = url.partition("+")
        if not plus or head not in _WRAPPERS or not rest:
            return wrappers, url
        wrappers.append(head)
        url = rest


def open_transport(url: str, *, baudrate: int | None = None, **options: Any) -> Transport:
    """Create the transport for ``url`` (not yet opened; use it as a context manager).

    ``baudrate`` defaults to :data:`DEFAULT_BAUDRATE`; callers pass the profile's
    ``link.baud`` (9600 for the xArm). Other keyword options go to the transport: pyserial
    settings such as ``write_timeout`` or ``exclusive`` for serial ports, ``clock``/``sleep``
    for ``sim:``, ``stream``/``logger`` for the ``hex+`` wrapper.
    """
    url = url.strip()
    if not url:
        raise TransportError("no port given: expected a device path or URL such as /dev/ttyUSB0")
    wrappers, inner_url = split_wrappers(url)
    wrapper_options = {k: options.pop(k) for k in ("stream", "logger") if k in options}
    if wrapper_options and not wrappers:
        raise TransportError(f"{url}: options {sorted(wrapper_options)} need a hex+ wrapper")
    transport = _factory_for(inner_url)(
        inner_url, baudrate=DEFAULT_BAUDRATE if baudrate is None else baudrate, **options
    )
    for name in reversed(wrappers):
        transport = _resolve(_WRAPPERS[name])(transport, **wrapper_options)
    return transport


def _factory_for(url: str) -> SchemeFactory:
    # pyserial URLs ("loop://", "socket://...") and paths go to pyserial; our own schemes are
    # written "name:rest" without slashes, so Windows "COM3" and POSIX paths never match one.
    scheme, colon, _ = url.partition(":")
    if colon and "://" not in url and scheme in _SCHEMES:
        return _resolve(_SCHEMES[scheme])
    return _resolve(_SERIAL)


def _resolve(entry: str | Callable[..., Transport]) -> Callable[..., Transport]:
    if not isinstance(entry, str):
        return entry
    module_name, _, attr = entry.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        # A missing optional third-party package (hidapi for hid:) is the user's to install;
        # a missing module of our own is a bug and stays an ImportError.
        if exc.name is None or exc.name.split(".")[0] == "xgo_show":
            raise
        raise TransportError(
            f"this transport needs the Python package {exc.name!r}, which is not installed"
        ) from exc
    factory: Callable[..., Transport] = getattr(module, attr)
    return factory
