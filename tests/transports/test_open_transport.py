"""open_transport: one URL per scheme, wrappers, and the errors a user can cause."""

from __future__ import annotations

import io
import logging

import pytest

from xgo_show.errors import ProfileError, TransportError
from xgo_show.transports import (
    DEFAULT_BAUDRATE,
    open_transport,
    register_scheme,
    split_wrappers,
)
from xgo_show.transports.base import Transport
from xgo_show.transports.hexlog import HexLogTransport
from xgo_show.transports.serial_port import SerialTransport
from xgo_show.transports.sim import SimTransport
from xgo_show.wire.xgo import XgoDecoder, read_frame


@pytest.mark.parametrize(
    "url",
    [
        "/dev/ttyUSB0",
        "COM3",
        "loop://",
        "socket://127.0.0.1:9",
        "rfc2217://127.0.0.1:9",
        "spy://loop://",
    ],
)
def test_pyserial_urls_and_paths_give_a_serial_transport(url: str) -> None:
    link = open_transport(url)
    assert isinstance(link, SerialTransport)
    assert link.url == url
    assert link.baudrate == DEFAULT_BAUDRATE == 115200
    assert not link.is_open  # not opened until asked


@pytest.mark.parametrize("model", ["mini", "lite", "rider", "xarm"])
def test_sim_urls_give_a_simulated_robot(model: str) -> None:
    link = open_transport(f"sim:{model}")
    assert isinstance(link, SimTransport)
    assert link.robot.model == model
    assert link.url == f"sim:{model}"


@pytest.mark.parametrize("url", ["hid:", "hid:0123ABC", "hex+hid:"])
def test_hid_urls_give_the_usb_hid_transport(url: str) -> None:
    from xgo_show.transports.hid import HidTransport

    link = open_transport(url)
    inner = link.inner if isinstance(link, HexLogTransport) else link
    assert isinstance(inner, HidTransport)
    assert inner.url == url.removeprefix("hex+")
    assert not link.is_open


def test_sim_without_model_or_unknown_model() -> None:
    with pytest.raises(TransportError, match="name a model"):
        open_transport("sim:")
    with pytest.raises(ProfileError, match="unknown robot model 'robodog'"):
        open_transport("sim:robodog")


def test_hex_and_log_wrappers_wrap_the_inner_transport() -> None:
    for prefix in ("hex", "log"):
        link = open_transport(f"{prefix}+loop://", baudrate=9600)
        assert isinstance(link, HexLogTransport)
        assert isinstance(link.inner, SerialTransport)
        assert link.inner.baudrate == 9600
        assert link.url == "hex+loop://"
    assert split_wrappers("hex+log+sim:mini") == (["hex", "log"], "sim:mini")
    assert split_wrappers("/dev/tty+1") == ([], "/dev/tty+1")


def test_wrapper_options_without_a_wrapper_are_refused() -> None:
    with pytest.raises(TransportError, match="need a hex\\+ wrapper"):
        open_transport("loop://", stream=io.StringIO())


def test_empty_url() -> None:
    with pytest.raises(TransportError, match="no port given"):
        open_transport("  ")


def test_hex_wrapper_logs_bytes_both_ways_to_a_stream() -> None:
    out = io.StringIO()
    with open_transport("hex+loop://", stream=out) as link:
        link.write(b"\x55\x00\xaa")
        assert link.read(16, timeout=1.0) == b"\x55\x00\xaa"
        assert link.read(16, timeout=0) == b""  # empty reads are not logged
    assert out.getvalue().splitlines() == ["loop:// > 55 00 aa", "loop:// < 55 00 aa"]


def test_hex_wrapper_logs_to_a_logger(caplog: pytest.LogCaptureFixture) -> None:
    with (
        caplog.at_level(logging.DEBUG, logger="xgo_show.traffic"),
        open_transport("log+sim:mini") as link,
    ):
        link.write(read_frame(0x01, 1))
        assert link.read(64, timeout=1.0)
    lines = [r.getMessage() for r in caplog.records if r.name == "xgo_show.traffic"]
    assert lines[0] == "sim:mini > " + read_frame(0x01, 1).hex(" ")
    assert lines[1].startswith("sim:mini < 55 00 09 12 01 ")


def test_sim_transport_answers_a_firmware_read() -> None:
    with open_transport("sim:mini") as link:
        link.write(read_frame(0x07, 10))
        decoder = XgoDecoder()
        frames = decoder.feed(link.read(64, timeout=1.0))
    assert len(frames) == 1
    assert frames[0].is_reply and frames[0].address == 0x07
    assert frames[0].data.rstrip(b"\0").decode("ascii").startswith("M-")
    assert link.robot.received[0].data == read_frame(0x07, 10)


def test_sim_transport_on_a_fake_clock_never_sleeps_for_real() -> None:
    now = [100.0]

    def advance(dt: float) -> None:
        now[0] += dt

    with open_transport("sim:lite", clock=lambda: now[0], sleep=advance) as link:
        assert link.read(64, timeout=5.0) == b""  # five fake seconds of silence
        assert now[0] >= 105.0
        link.write(read_frame(0x07, 10))
        assert link.read(64, timeout=5.0).startswith(b"\x55\x00")
        assert link.robot.received[0].t == pytest.approx(105.0, abs=0.01)


def test_sim_transport_closed_is_an_error() -> None:
    link = open_transport("sim:mini")
    with pytest.raises(TransportError, match="sim:mini is not open"):
        link.write(b"x")


def test_register_scheme_adds_a_transport() -> None:
    made: list[tuple[str, int]] = []

    def factory(url: str, *, baudrate: int) -> Transport:
        made.append((url, baudrate))
        return SerialTransport("loop://", baudrate=baudrate)

    register_scheme("testloop", factory)
    link = open_transport("testloop:anything", baudrate=9600)
    assert isinstance(link, SerialTransport)
    assert made == [("testloop:anything", 9600)]
