"""USB-HID transport for the xArm.

No xArm is attached here, so the one fake is at the lowest boundary: a stand-in for hidapi's
``hid`` module whose ``device()`` returns :class:`FakeDevice` (same method names, arguments and
return values as ``hid.device``: ``open(vid, pid[, serial])``, ``write(bytes) -> int``,
``read(max_length, timeout_ms) -> list[int]``). Everything above it is the real transport and
the real xArm codec.
"""

from __future__ import annotations

import sys
import time
import types
from collections.abc import Iterator

import pytest

from xgo_show.errors import TransportError
from xgo_show.transports import open_transport
from xgo_show.transports.hid import PRODUCT_ID, VENDOR_ID, HidTransport, open_hid
from xgo_show.wire.xarm import (
    XarmDecoder,
    battery_mv,
    battery_reply,
    get_battery_voltage,
    group_stop,
    offsets_reply,
    positions,
    positions_reply,
    servo_move,
)


class FakeDevice:
    """Behaves like ``hid.device()`` with an xArm on the other end."""

    def __init__(self, present: set[str | None]) -> None:
        self.present = present  # serial numbers that can be opened (None = "any")
        self.opened: tuple[object, ...] | None = None
        self.nonblocking: int | None = None
        self.written: list[bytes] = []
        self.inbox: list[bytes] = []  # input reports the arm has sent
        self.read_calls: list[tuple[int, int]] = []
        self.write_result: int | None = None
        self.closed = False

    def open(
        self, vendor_id: int = 0, product_id: int = 0, serial_number: str | None = None
    ) -> None:
        if (vendor_id, product_id) != (VENDOR_ID, PRODUCT_ID) or serial_number not in self.present:
            raise OSError("open failed")
        self.opened = (vendor_id, product_id, serial_number)

    def set_nonblocking(self, value: int) -> int:
        self.nonblocking = value
        return 0

    def write(self, buff: bytes) -> int:
        if self.opened is None or self.closed:
            raise ValueError("not open")
        self.written.append(bytes(buff))
        return len(buff) if self.write_result is None else self.write_result

    def read(self, max_length: int, timeout_ms: int = 0) -> list[int]:
        self.read_calls.append((max_length, timeout_ms))
        if not self.inbox:
            time.sleep(timeout_ms / 1000)  # nothing arrives: hid_read_timeout waits it out
            return []
        return list(self.inbox.pop(0)[:max_length])

    def error(self) -> str:
        return "hid_write: broken pipe"

    def close(self) -> None:
        self.closed = True

    def arm_sends(self, *packets: bytes) -> None:
        """Queue one 64-byte input report per packet (zero padding, as the arm sends them)."""
        for packet in packets:
            self.inbox.append(packet.ljust(64, b"\x00"))


@pytest.fixture
def fake_hid(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[FakeDevice]]:
    """Install a fake ``hid`` module; yields the devices it hands out."""
    devices: list[FakeDevice] = []
    present: set[str | None] = {None, "ABC123"}

    def device() -> FakeDevice:
        dev = FakeDevice(present)
        devices.append(dev)
        return dev

    module = types.ModuleType("hid")
    module.device = device  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "hid", module)
    yield devices


@pytest.fixture
def link(fake_hid: list[FakeDevice]) -> Iterator[tuple[HidTransport, FakeDevice]]:
    transport = open_hid("hid:")
    transport.open()
    yield transport, fake_hid[0]
    transport.close()


# --- Opening -------------------------------------------------------------------------------------


def test_missing_hidapi_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "hid", None)  # makes "import hid" fail
    transport = open_hid("hid:")  # creating it needs no hidapi
    with pytest.raises(TransportError) as err:
        transport.open()
    assert str(err.value) == "USB-HID needs the optional extra: pip install 'xgo-show[hid]'"
    assert not transport.is_open


def test_a_foreign_hid_module_is_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "hid", types.ModuleType("hid"))  # no device()
    with pytest.raises(TransportError, match="not hidapi's"):
        open_hid("hid:").open()


def test_open_first_arm(fake_hid: list[FakeDevice]) -> None:
    with open_hid("hid:") as transport:
        assert transport.is_open
        dev = fake_hid[0]
        assert dev.opened == (0x0483, 0x5750, None)
        assert dev.nonblocking == 1
    assert dev.closed
    assert not transport.is_open


def test_open_by_serial_number(fake_hid: list[FakeDevice]) -> None:
    transport = open_hid("hid:ABC123")
    assert isinstance(transport, HidTransport)
    assert transport.serial_number == "ABC123"
    with transport:
        assert fake_hid[0].opened == (0x0483, 0x5750, "ABC123")


def test_open_failure_names_the_url_and_device(fake_hid: list[FakeDevice]) -> None:
    with pytest.raises(TransportError) as err:
        open_hid("hid:NOPE").open()
    message = str(err.value)
    assert message.startswith("hid:NOPE: cannot open the xArm (USB 0483:5750 serial NOPE)")
    assert "open failed" in message and "udev" in message


def test_open_transport_registry_picks_hid(fake_hid: list[FakeDevice]) -> None:
    transport = open_transport("hid:ABC123", baudrate=9600)
    assert isinstance(transport, HidTransport)
    assert not transport.is_open  # comes back unopened
    assert repr(transport) == "<HidTransport hid:ABC123>"


def test_options_are_rejected() -> None:
    with pytest.raises(TransportError, match="USB-HID takes no options; got write_timeout"):
        open_hid("hid:", baudrate=9600, write_timeout=1.0)


def test_not_a_hid_url() -> None:
    with pytest.raises(TransportError, match="not a USB-HID URL"):
        HidTransport("/dev/ttyUSB0")


def test_close_twice_and_open_twice(fake_hid: list[FakeDevice]) -> None:
    transport = open_hid("hid:")
    transport.open()
    transport.open()  # already open: no second device
    assert len(fake_hid) == 1
    transport.close()
    transport.close()
    assert fake_hid[0].closed


def test_use_when_closed_is_an_error(fake_hid: list[FakeDevice]) -> None:
    transport = open_hid("hid:")
    with pytest.raises(TransportError, match="hid:: the USB-HID link is not open"):
        transport.write(group_stop())
    with pytest.raises(TransportError, match="not open"):
        transport.read()


# --- Writing --------------------------------------------------------------------------------------


def test_write_one_packet_per_65_byte_report(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    move = servo_move(1000, {1: 500, 2: 300})
    transport.write(group_stop() + move)
    assert dev.written == [
        b"\x00" + bytes.fromhex("55 55 02 07") + bytes(60),
        b"\x00" + move + bytes(64 - len(move)),
    ]
    assert all(len(report) == 65 for report in dev.written)


def test_write_largest_packet_that_fits(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    move = servo_move(0, {i: 0 for i in range(1, 21)})  # 4 + 3 + 60 = 67 bytes: too big
    with pytest.raises(TransportError, match="67 bytes does not fit one 64-byte USB-HID report"):
        transport.write(move)
    fits = servo_move(0, {i: 0 for i in range(1, 20)})  # 64 bytes exactly
    transport.write(fits)
    assert dev.written == [b"\x00" + fits]


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"\x01\x02", "byte 0 of the data does not start one: 01 02"),
        (group_stop() + b"\x55", "byte 4 of the data does not start one: 55"),
        (servo_move(0, {1: 0})[:-1], "the data ends inside an xArm packet"),
        (b"\x55\x55\x01\x07", "packet at byte 0 has length 1 < 2"),
    ],
)
def test_write_rejects_what_is_not_whole_packets(
    link: tuple[HidTransport, FakeDevice], data: bytes, message: str
) -> None:
    transport, dev = link
    with pytest.raises(TransportError, match=message):
        transport.write(data)
    assert dev.written == []  # nothing half-sent


def test_write_failure_is_a_transport_error(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    dev.write_result = -1
    with pytest.raises(TransportError, match="hid:: USB-HID write failed: hid_write: broken pipe"):
        transport.write(group_stop())
    dev.closed = True  # hidapi raises ValueError on a closed device
    with pytest.raises(TransportError, match="write failed: not open"):
        transport.write(group_stop())


# --- Reading --------------------------------------------------------------------------------------


def test_read_strips_report_padding(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    dev.arm_sends(battery_reply(7400))
    assert transport.read(timeout=0.5) == battery_reply(7400)


def test_read_timeout_is_passed_to_hidapi(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    assert transport.read(timeout=0.05) == b""
    assert dev.read_calls == [(64, 50)]  # hidapi waits, in ms; nothing more is asked


def test_report_of_padding_only_waits_on(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    dev.inbox.append(bytes(64))
    dev.arm_sends(battery_reply(7400))
    assert transport.read(timeout=5.0) == battery_reply(7400)
    (_, first), (_, second), (_, last) = dev.read_calls
    assert first == 5000 and 0 < second <= 5000  # the second wait is what is left
    assert last == 0  # then only what has already arrived


def test_read_without_timeout_does_not_wait(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    assert transport.read() == b""
    assert dev.read_calls == [(64, 0)]


def test_read_collects_reports_already_there(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    dev.arm_sends(battery_reply(7400), positions_reply({1: 500}))
    assert transport.read(timeout=0.1) == battery_reply(7400) + positions_reply({1: 500})
    assert dev.read_calls[1:] == [(64, 0), (64, 0)]  # the rest without waiting


def test_read_size_keeps_the_rest_for_later(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    reply = positions_reply({1: 500, 2: 600})
    dev.arm_sends(reply)
    assert transport.read(4) == reply[:4]
    assert transport.read(100) == reply[4:]
    assert transport.read() == b""


def test_report_holding_two_packets(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    dev.inbox.append((battery_reply(7000) + offsets_reply({3: -2})).ljust(64, b"\x00"))
    assert transport.read() == battery_reply(7000) + offsets_reply({3: -2})


def test_report_that_is_not_a_packet_is_passed_on_for_the_decoder(
    link: tuple[HidTransport, FakeDevice],
) -> None:
    transport, dev = link
    dev.inbox.append(b"\x13\x37".ljust(64, b"\x00"))
    dev.arm_sends(battery_reply(7400))
    decoder = XarmDecoder()
    packets = decoder.feed(transport.read())
    assert [battery_mv(p) for p in packets] == [7400]
    assert decoder.discarded == 2  # the junk, not its padding


def test_read_failure_is_a_transport_error(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link

    def broken(max_length: int, timeout_ms: int = 0) -> list[int]:
        raise OSError("read error")

    dev.read = broken  # type: ignore[method-assign]
    with pytest.raises(TransportError, match="hid:: USB-HID read failed: read error"):
        transport.read(timeout=0.1)


def test_request_and_reply_through_the_decoder(link: tuple[HidTransport, FakeDevice]) -> None:
    transport, dev = link
    transport.write(get_battery_voltage())
    assert dev.written[0][:5] == b"\x00\x55\x55\x02\x0f"
    dev.arm_sends(battery_reply(7400), positions_reply({1: 123, 6: 1000}))
    decoder = XarmDecoder()
    packets = decoder.feed(transport.read(timeout=0.5))
    assert battery_mv(packets[0]) == 7400
    assert positions(packets[1]) == {1: 123, 6: 1000}
    assert decoder.discarded == 0
