"""``dry-run --follow osc:...`` in its own process, driven by OSC over real UDP: the show
waits for /go, pauses and resumes on cue, and a bad cue is one line, not a crash."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from pythonosc.udp_client import SimpleUDPClient

from tests.children import read_until
from xgo_show.cli.main import main
from xgo_show.timecode.follow import parse_timecode

ROUTINE = """\
show: cued
tempo: {bpm: 120}
performers: {rex: {model: mini}}
tracks:
  rex:
    - {move: {body_z: 90}, at: '1.1', beats: 2}
    - {move: {body_z: 100}, at: '1.3', beats: 2}
"""


def test_the_desk_starts_pauses_and_resumes_the_show(tmp_path: Path) -> None:
    show = tmp_path / "cued.yaml"
    show.write_text(ROUTINE, encoding="utf-8")
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "dry-run", str(show), "--follow", "osc:127.0.0.1:0",
         "--no-telemetry"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    try:
        line = read_until(proc, r"listening for OSC cues on 127\.0\.0\.1:\d+")
        port = int(re.search(r":(\d+) ", line).group(1))  # type: ignore[union-attr]
        desk = SimpleUDPClient("127.0.0.1", port)
        desk.send_message("/seek", 1.0)  # before /go: said and ignored
        read_until(proc, r"osc: /seek before /go: ignored")
        started = time.monotonic()
        desk.send_message("/go", [])
        read_until(proc, r"running 'cued'")
        time.sleep(0.5)
        desk.send_message("/pause", [])
        time.sleep(1.0)
        desk.send_message("/jump", [])
        read_until(proc, r"osc: unknown OSC address '/jump'")
        desk.send_message("/resume", [])
        read_until(proc, r"^show completed")
        elapsed = time.monotonic() - started
        assert proc.wait(10) == 0
    finally:
        proc.kill()
        proc.wait()
    # 2 s of show + the 1 s pause (+ start-up and the final report's margin)
    assert 2.8 < elapsed < 6.0


def test_follow_options_are_checked(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    show = tmp_path / "cued.yaml"
    show.write_text(ROUTINE, encoding="utf-8")
    for args, says in [
        (["--follow", "osc:nine"], "write osc:[HOST:]PORT"),
        (["--follow", "smpte:1"], "write osc:[HOST:]PORT or mtc:MIDI-PORT"),
        (["--follow", "osc:0", "--fast"], "--follow needs real time"),
        (["--timecode-origin", "1:00"], "give HH:MM:SS:FF or seconds"),
    ]:
        assert main(["dry-run", str(show), *args]) == 2
        err = capsys.readouterr().err.strip()
        assert says in err and "\n" not in err, err
    assert parse_timecode("01:00:00:15") == 3600.5
    assert parse_timecode("12.5") == 12.5
