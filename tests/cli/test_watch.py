"""``validate --watch`` in a real process: it validates, waits, validates again when the
routine is saved, and Ctrl-C (SIGINT) ends it with the last run's status."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import IO

GOOD = ("show: w\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
        "    - {move: {pitch: 10}, duration: 1}\n")


def _until(stream: IO[str], text: str, timeout: float = 30.0) -> list[str]:
    lines: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = stream.readline()
        if not line:
            break
        lines.append(line.rstrip("\n"))
        if text in line:
            return lines
    raise AssertionError(f"{text!r} never came; got {lines}")


def test_validate_watch_runs_again_on_save_and_stops_on_ctrl_c(tmp_path: Path) -> None:
    routine = tmp_path / "show.yaml"
    routine.write_text(GOOD)
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show.cli.main", "validate", "--watch", str(routine)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert proc.stdout is not None and proc.stderr is not None
        first = _until(proc.stdout, "-- watching")
        assert f"{routine}: ok: 0 error(s), 0 warning(s)" in first
        routine.write_text(GOOD.replace("pitch: 10", "pitch: 30"))  # out of range
        again = _until(proc.stdout, "-- watching")
        assert any(line.endswith(f"{routine} changed: running again") for line in again)
        assert any("pitch = 30 deg is out of range" in line for line in again)
        assert f"{routine}: FAILED: 1 error(s), 0 warning(s)" in again
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=10) == 1  # the last run failed
        assert "stopped watching" in proc.stderr.read()
    finally:
        proc.kill()
        proc.wait()
