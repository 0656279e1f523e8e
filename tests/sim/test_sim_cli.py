"""``xgo-show simulate`` as a subprocess: path on the first line, pyserial talks, SIGINT stops."""

from __future__ import annotations

import contextlib
import json
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial

from xgo_show.cli.main import main
from xgo_show.wire.xarm import XarmDecoder, XarmPacket, battery_mv, get_battery_voltage
from xgo_show.wire.xgo import XgoDecoder, read_frame, write_frame


@contextlib.contextmanager
def simulate(*args: str) -> Iterator[subprocess.Popen[str]]:
    """``xgo-show simulate ARGS`` as a subprocess, killed on the way out if still running."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "simulate", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def ask(port: serial.Serial, request: bytes) -> bytes:
    port.write(request)
    decoder = XgoDecoder()
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline:
        for frame in decoder.feed(port.read(max(1, port.in_waiting))):
            return frame.data
    raise AssertionError("no reply")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_simulate_serves_a_pty_until_signalled(sig: signal.Signals, tmp_path: Path) -> None:
    record = tmp_path / "rec.jsonl"
    with simulate("--model", "mini", "--pty", "--battery", "42", "--record", str(record)) as proc:
        assert proc.stdout is not None
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/")
        with serial.Serial(path, 115200, timeout=0.2) as port:
            assert ask(port, read_frame(0x07, 10)) == b"M-1.4.1\0\0\0"
            assert ask(port, read_frame(0x01, 1)) == bytes([42])
            port.write(write_frame(0x30, b"\x90"))
            # Frames are handled in order: once this is answered, the write has landed.
            assert ask(port, read_frame(0x30, 1)) == b"\x90"
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    summary = err.strip().splitlines()[-1]
    assert summary.startswith("xgo-show simulate: mini on /dev/")
    assert "4 frames received (0 rejected)" in summary
    assert len(record.read_text().splitlines()) == 4
    assert json.loads(record.read_text().splitlines()[2])["hex"] == write_frame(0x30, b"\x90").hex()


def test_unknown_model_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--model", "max", "--pty"])
    assert exc.value.code == 2
    assert "invalid choice: 'max'" in capsys.readouterr().err


def test_bad_battery_is_a_one_line_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--model", "rider", "--battery", "150"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("xgo-show: error: battery = 150 %")
    assert "Traceback" not in err


def test_help_mentions_the_first_line() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "xgo_show", "simulate", "--help"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "first line" in out
    assert "--record FILE" in out


def test_simulate_xarm() -> None:
    with simulate("--model", "xarm", "--pty") as proc:
        assert proc.stdout is not None
        path = proc.stdout.readline().strip()
        with serial.Serial(path, 9600, timeout=0.2) as port:
            port.write(get_battery_voltage())
            decoder = XarmDecoder()
            deadline = time.monotonic() + 3.0
            got: list[XarmPacket] = []
            while not got and time.monotonic() < deadline:
                got = decoder.feed(port.read(max(1, port.in_waiting)))
        assert battery_mv(got[0]) == 7600
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    assert "xarm on /dev/" in err
    assert "battery 7600 mV" in err


def test_battery_option_is_not_for_the_xarm(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--model", "xarm", "--battery", "50"]) == 2
    assert "millivolts" in capsys.readouterr().err
