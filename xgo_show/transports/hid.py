"""The xArm over USB-HID (USB vendor 0x0483, product 0x5750), through the optional ``hidapi``.

URLs: ``hid:`` opens the first xArm found; ``hid:SERIAL`` the one with that USB serial number.
Install the extra first: ``pip install 'xgo-show[hid]'`` (the ``hid`` module of ``hidapi``).

Each xArm packet (:mod:`xgo_show.wire.xarm`) rides alone in one 64-byte report; the seed
notes that "a message never exceeds the maximum report length"::

    output report, 65 bytes written              input report, 64 bytes read
    +----+---------------------+-----------+     +---------------------+-------------+
    | 00 | 55 55 len cmd ...   | 00 ... 00 |     | 55 55 len cmd ...   | padding ... |
    +----+---------------------+-----------+     +---------------------+-------------+
     report id 0 (the arm      padded to 64       the arm's packet       cut off using
     uses no numbered reports)                                           the length byte

:meth:`HidTransport.write` splits its data into whole packets by their length bytes (one report
each); :meth:`HidTransport.read` returns only the packet bytes of each report, so an
:class:`~xgo_show.wire.xarm.XarmDecoder` on top sees the same byte stream as over serial.
"""

from __future__ import annotations

import contextlib
import math
import time
from typing import Any

from xgo_show.errors import TransportError
from xgo_show.transports.base import Transport
from xgo_show.wire.xarm import HEADER

__all__ = ["PRODUCT_ID", "REPORT_SIZE", "VENDOR_ID", "HidTransport", "open_hid"]

VENDOR_ID = 0x0483
PRODUCT_ID = 0x5750
#: Payload bytes of one report (the written report has one more: the report id).
REPORT_SIZE = 64

_MISSING = "USB-HID needs the optional extra: pip install 'xgo-show[hid]'"


class HidTransport(Transport):
    """A byte link to an xArm over USB-HID; ``url`` is ``hid:`` or ``hid:SERIALNUMBER``."""

    def __init__(self, url: str) -> None:
        super().__init__(url)
        scheme, colon, serial = url.partition(":")
        if scheme != "hid" or not colon:
            raise TransportError(f"{url}: not a USB-HID URL; expected hid: or hid:SERIALNUMBER")
        self.serial_number: str | None = serial.strip() or None
        self._device: Any = None
        self._pending = bytearray()

    def open(self) -> None:
        if self._device is not None:
            return
        try:
            import hid
        except ImportError as exc:
            raise TransportError(_MISSING) from exc
        which = f"USB {VENDOR_ID:04x}:{PRODUCT_ID:04x}" + (
            f" serial {self.serial_number}" if self.serial_number else ""
        )
        if not hasattr(hid, "device"):
            # Another package also installs a module named "hid", with a different API.
            raise TransportError(
                f"{self.url}: the installed 'hid' module is not hidapi's; {_MISSING}"
            )
        device = hid.device()
        try:
            if self.serial_number:
                device.open(VENDOR_ID, PRODUCT_ID, self.serial_number)
            else:
                device.open(VENDOR_ID, PRODUCT_ID)
            # Reads then wait only as long as read()'s timeout says (0 = return at once).
            device.set_nonblocking(1)
        except (OSError, ValueError) as exc:
            raise TransportError(
                f"{self.url}: cannot open the xArm ({which}): {exc or type(exc).__name__}; "
                "is it plugged in and switched on, and may this user open it (udev rule)?"
            ) from exc
        self._device = device
        self._pending.clear()

    def close(self) -> None:
        device, self._device = self._device, None
        self._pending.clear()
        if device is not None:
            # Closing a device that has gone away is not an error worth raising.
            with contextlib.suppress(OSError, ValueError):
                device.close()

    @property
    def is_open(self) -> bool:
        return self._device is not None

    def write(self, data: bytes) -> None:
        """Send ``data``, which must be whole xArm packets, one report per packet."""
        device = self._require_open()
        for packet in _split_packets(self.url, bytes(data)):
            report = b"\x00" + packet.ljust(REPORT_SIZE, b"\x00")
            try:
                written = device.write(report)
            except (OSError, ValueError) as exc:
                raise TransportError(f"{self.url}: USB-HID write failed: {exc}") from exc
            if written is not None and written < 0:
                raise TransportError(f"{self.url}: USB-HID write failed: {_device_error(device)}")

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        """Packet bytes from the reports that arrive within ``timeout`` s (padding removed)."""
        device = self._require_open()
        if not self._pending:
            wait = max(0.0, timeout)
            deadline = time.monotonic() + wait
            while True:
                report = self._read_report(device, wait)
                if report:
                    self._pending += _strip_padding(report)
                wait = deadline - time.monotonic()
                # Go round again only for a report that held nothing (all padding).
                if self._pending or not report or wait <= 0:
                    break
            # Take whatever else has already arrived, without waiting.
            while self._pending and len(self._pending) < size:
                report = self._read_report(device, 0.0)
                if not report:
                    break
                self._pending += _strip_padding(report)
        out = bytes(self._pending[:size])
        del self._pending[:size]
        return out

    def _read_report(self, device: Any, seconds: float) -> bytes:
        # hidapi: timeout_ms > 0 waits that long; 0 returns at once on a non-blocking device.
        timeout_ms = math.ceil(seconds * 1000) if seconds > 0 else 0
        try:
            report = device.read(REPORT_SIZE, timeout_ms)
        except (OSError, ValueError) as exc:
            raise TransportError(f"{self.url}: USB-HID read failed: {exc}") from exc
        return bytes(report)

    def _require_open(self) -> Any:
        if self._device is None:
            raise TransportError(f"{self.url}: the USB-HID link is not open")
        return self._device


def _split_packets(url: str, data: bytes) -> list[bytes]:
    packets: list[bytes] = []
    pos = 0
    while pos < len(data):
        if data[pos : pos + 2] != HEADER or pos + 3 > len(data):
            raise TransportError(
                f"{url}: USB-HID carries whole xArm packets (55 55 length command ...); "
                f"byte {pos} of the data does not start one: {data[pos : pos + 8].hex(' ')}"
            )
        size = data[pos + 2] + 2
        if size > REPORT_SIZE:
            raise TransportError(
                f"{url}: an xArm packet of {size} bytes does not fit one {REPORT_SIZE}-byte "
                "USB-HID report"
            )
        if size < 4:
            raise TransportError(f"{url}: the xArm packet at byte {pos} has length {size - 2} < 2")
        if pos + size > len(data):
            raise TransportError(f"{url}: the data ends inside an xArm packet (byte {pos})")
        packets.append(data[pos : pos + size])
        pos += size
    return packets


def _strip_padding(report: bytes) -> bytes:
    """The packet bytes of one input report: each packet's length byte says where it ends."""
    out = bytearray()
    pos = 0
    while pos + 3 <= len(report) and report[pos : pos + 2] == HEADER and report[pos + 2] >= 2:
        size = report[pos + 2] + 2
        out += report[pos : pos + size]
        pos += size
    if pos == 0:
        # Not a packet: hand it on (minus zero padding) so the decoder counts it as discarded.
        return report.rstrip(b"\x00")
    return bytes(out)


def _device_error(device: Any) -> str:
    try:
        message = device.error()
    except (OSError, ValueError, AttributeError):
        message = None
    return str(message) if message else "the device refused the report"


def open_hid(url: str, *, baudrate: int | None = None, **options: Any) -> HidTransport:
    """Scheme factory for ``hid:`` URLs (``baudrate`` is ignored: USB has none)."""
    if options:
        raise TransportError(f"{url}: USB-HID takes no options; got {', '.join(sorted(options))}")
    return HidTransport(url)
