"""PtyServer: real pseudo-terminals, real pyserial clients, real frames."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import serial

from xgo_show.errors import TransportError
from xgo_show.sim import PtyServer, create_robot
from xgo_show.wire.xgo import XgoDecoder, XgoFrame, read_frame, reply_frame, write_frame


def read_frames(port: serial.Serial, count: int, timeout: float = 2.0) -> list[XgoFrame]:
    decoder = XgoDecoder()
    got: list[XgoFrame] = []
    deadline = time.monotonic() + timeout
    while len(got) < count and time.monotonic() < deadline:
        got += decoder.feed(port.read(max(1, port.in_waiting)))
    return got


Wait = Callable[[Callable[[], bool]], None]


def test_pyserial_client_reads_and_writes(wait: Wait) -> None:
    robot = create_robot("mini")
    with PtyServer(robot) as server, serial.Serial(server.path, 115200, timeout=0.2) as port:
        port.write(read_frame(0x07, 10))
        (reply,) = read_frames(port, 1)
        assert reply.encode() == reply_frame(0x07, b"M-1.4.1\0\0\0")
        port.write(write_frame(0x30, b"\xff"))
        wait(lambda: server.snapshot()["raw"]["vx"] == "ff")
        snap = server.snapshot()
        assert snap["frames_received"] == 2
        assert snap["dropped_bytes"] == 0
    assert not server.running


def test_no_echo_and_binary_safe(wait: Wait) -> None:
    # Bytes a cooked terminal would mangle: 0x03 (^C), 0x0D (CR), 0x11/0x13 (XON/XOFF), 0x7F.
    data = bytes([0x03, 0x0D, 0x0A, 0x11, 0x13, 0x7F, 0x04])
    robot = create_robot("rider")
    with PtyServer(robot) as server, serial.Serial(server.path, 115200, timeout=0.2) as port:
        port.write(write_frame(0x69, data[:3] + data[3:6], write_type=0x01))
        wait(lambda: server.snapshot()["frames_received"] == 1)
        assert server.snapshot()["registers"]["led1"] == list(data[:3])
        assert server.snapshot()["registers"]["led2"] == list(data[3:6])
        assert port.read(64) == b""  # nothing echoed back


def test_clients_can_close_and_reconnect() -> None:
    robot = create_robot("lite")
    with PtyServer(robot) as server:
        for _ in range(3):
            with serial.Serial(server.path, 115200, timeout=0.2) as port:
                port.write(read_frame(0x01, 1))
                (reply,) = read_frames(port, 1)
                assert reply.data == b"\x64"
        assert server.running
        assert server.snapshot()["frames_received"] == 3


def test_rider_feedback_reaches_the_client() -> None:
    robot = create_robot("rider")
    with PtyServer(robot) as server, serial.Serial(server.path, 115200, timeout=0.2) as port:
        port.write(write_frame(0x08, b"\x01", write_type=0x01))
        got = read_frames(port, 20)
        assert {f.address for f in got} >= {0x01, 0x65}
        port.write(write_frame(0x08, b"\x00", write_type=0x01))


def test_record_file_has_one_json_line_per_frame(tmp_path: Path, wait: Wait) -> None:
    record = tmp_path / "frames.jsonl"
    robot = create_robot("mini")
    with (
        PtyServer(robot, record=record) as server,
        serial.Serial(server.path, 115200, timeout=0.2) as port,
    ):
        port.write(write_frame(0x30, b"\x90") + write_frame(0x01, b"\x00"))
        wait(lambda: server.snapshot()["frames_received"] == 2)
    lines = [json.loads(line) for line in record.read_text().splitlines()]
    assert [line["hex"] for line in lines] == [
        write_frame(0x30, b"\x90").hex(),
        write_frame(0x01, b"\x00").hex(),
    ]
    assert [line["accepted"] for line in lines] == [True, False]
    assert "read-only" in lines[1]["reason"]
    assert isinstance(lines[0]["t"], float)


def test_close_releases_the_terminal_and_path_needs_start() -> None:
    server = PtyServer(create_robot("mini"))
    with pytest.raises(TransportError):
        _ = server.path
    server.start()
    path = server.path
    assert os.path.exists(path)
    server.close()
    server.close()  # twice is fine
    assert not server.running
    with pytest.raises(serial.SerialException):
        serial.Serial(path, 115200, timeout=0.1).close()


def test_unwritable_record_file_is_a_transport_error(tmp_path: Path) -> None:
    with pytest.raises(TransportError, match="record file"):
        PtyServer(create_robot("mini"), record=tmp_path / "missing" / "x.jsonl").start()
