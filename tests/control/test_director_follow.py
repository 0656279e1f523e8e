"""``--follow`` with a show that waits for triggers, through the real CLI: the desk's OSC cues
go through the director (its waits are kept: a /resume cannot release one), the triggers come
from the script; MIDI timecode is refused with the reason and what to use instead."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from pythonosc.udp_client import SimpleUDPClient

from tests.children import read_until
from tests.control.conftest import ROUTINE
from xgo_show.cli.main import main


def test_the_desk_steers_a_triggered_show_and_its_waits_are_released_by_triggers(
    tmp_path: Path,
) -> None:
    # Sections: a; b at 0.6 waits for 'go'; c at 1.2 waits for 'encore' 0.3 s, else d.
    show = tmp_path / "triggered.yaml"
    show.write_text(ROUTINE, encoding="utf-8")
    script = tmp_path / "script.yaml"
    script.write_text("triggers:\n  - {trigger: go, after: 1.0}\n"
                      "  - {trigger: encore, after: 0.1}\n", encoding="utf-8")
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "dry-run", str(show), "--follow", "osc:127.0.0.1:0",
         "--triggers", str(script), "--no-telemetry"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    seen: list[str] = []
    try:
        line = read_until(proc, r"listening for OSC cues on 127\.0\.0\.1:\d+", seen)
        port = int(re.search(r":(\d+) ", line).group(1))  # type: ignore[union-attr]
        desk = SimpleUDPClient("127.0.0.1", port)
        desk.send_message("/go", [])
        read_until(proc, r"running 'Triggered test'", seen)
        started = time.monotonic()  # the show starts 0.1 s after /go: about now
        time.sleep(0.2)
        desk.send_message("/pause", [])  # in section a, far from b's wait
        time.sleep(0.5)
        desk.send_message("/resume", [])
        # Section a ends 0.6 s of show after the start, 0.5 s later for the pause: the show
        # holds at b from about 1.2 s to 2.2 s ('go' 1 s into the hold). A /resume from the
        # desk in the middle of it must not release the wait.
        time.sleep(max(0.0, started + 1.7 - time.monotonic()))
        desk.send_message("/resume", [])
        refused = read_until(proc, r"^osc: /resume refused", seen)
        assert "the show waits for trigger 'go' (section 'b'): fire it, or seek" in refused
        go = read_until(proc, r"^trigger 'go' at", seen)
        assert "released section 'b'" in go  # the show was still holding when 'go' came
        encore = read_until(proc, r"^trigger 'encore' at", seen)
        assert "released section 'c'" in encore
        read_until(proc, r"^show completed", seen)
        elapsed = time.monotonic() - started
        assert proc.wait(10) == 0
    finally:
        proc.kill()
        proc.wait()
    # The triggers' times (from the show's start): 'go' 1 s into the hold at b (0.6 s of show
    # + 0.5 s of pause), 'encore' 0.1 s into the hold at c (0.6 s of section b later).
    t_go = float(re.search(r"at (\d+\.\d+) s", go).group(1))  # type: ignore[union-attr]
    t_encore = float(re.search(r"at (\d+\.\d+) s", encore).group(1))  # type: ignore[union-attr]
    assert 2.0 < t_go < 2.4, seen
    assert 0.65 < t_encore - t_go < 0.8, seen
    # 2.4 s of show + 0.5 s of pause + 1.1 s of holds (+ the report's margin)
    assert 3.9 < elapsed < 7.0, seen


def test_a_triggered_show_cannot_chase_midi_timecode(
    triggered_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    script = triggered_path.parent / "go.yaml"
    script.write_text("triggers:\n  - {trigger: go, after: 0}\n", encoding="utf-8")
    assert main(["dry-run", str(triggered_path), "--follow", "mtc:desk", "--triggers",
                 str(script)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err, err
    assert "--follow mtc:desk: this show waits for trigger(s) go, encore" in err
    assert "a hold at a wait would be taken for a timecode jump" in err
    assert "--follow osc:PORT" in err and "xgo-show trigger NAME" in err
