"""The live view in a real terminal: tmux at 80 and 120 columns, read with capture-pane.

Rows fit the width, one per performer, and the final view (``--fast``) is the same on every
run: each performer finished, the show's end and last bar, the cue in effect there."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from xgo_show.choreo import load_show
from xgo_show.cli.live import CueTimeline
from xgo_show.compiler import compile_show

ROOT = Path(__file__).resolve().parents[2]
SHOW = ROOT / "choreographies" / "duet_mini_lite_mirror.yaml"


def _screen(width: int) -> list[str]:
    """Run dry-run --fast in a tmux window ``width`` columns wide; the live view's lines."""
    session = f"xgo-live-{uuid.uuid4().hex[:8]}"
    done = Path(f"/tmp/{session}.done")
    command = (f"{sys.executable} -m xgo_show dry-run {SHOW} --fast; touch {done}; sleep 30")
    # A tmux server of this test's own (-S): on the shared default server, another suite's
    # kill-session of the last session stops the server while this one connects to it.
    socket = Path(f"/tmp/{session}.tmux")
    tmux = ["tmux", "-S", str(socket)]
    subprocess.run([*tmux, "new-session", "-d", "-s", session, "-x", str(width), "-y", "50",
                    command], check=True)
    try:
        deadline = time.monotonic() + 60
        while not done.exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        assert done.exists(), "dry-run did not finish"
        text = subprocess.run([*tmux, "capture-pane", "-p", "-J", "-S", "-200", "-t", session],
                              check=True, capture_output=True, text=True).stdout
    finally:
        subprocess.run([*tmux, "kill-server"], check=False)
        done.unlink(missing_ok=True)
        socket.unlink(missing_ok=True)
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("running "))
    end = next(i for i, line in enumerate(lines) if line.startswith("show completed"))
    return lines[start + 1 : end]


@pytest.mark.skipif(shutil.which("tmux") is None, reason="needs tmux (a real terminal)")
@pytest.mark.parametrize(("width", "again"), [(80, True), (120, False)])
def test_the_live_view_fits_the_terminal_and_ends_the_same_every_time(
    width: int, again: bool
) -> None:
    first = _screen(width)
    assert first[0].split() == ["60.0", "/", "60.0", "s", "bar", "25:1"]
    assert first[1].split()[:2] == ["performer", "state"] and "cue in effect" in first[1]
    rows = first[2:]
    assert [r.split()[:2] for r in rows] == [["mira", "finished"], ["lumo", "finished"]]
    assert all(len(line) <= width for line in first)
    if again:
        assert _screen(width) == first  # the final state does not vary between runs


def test_the_cue_in_effect_comes_from_the_schedule_not_the_last_frame() -> None:
    schedule = compile_show(load_show(ROOT / "choreographies" / "hello_mini.yaml"))
    timeline = CueTimeline(schedule.performers[0], 1 / schedule.control_rate)
    assert timeline.at(0.3) == "move body_z"  # a move under way between two samples
    assert timeline.at(-1.0) == ""
    labels = {timeline.at(t / 10) for t in range(0, int(schedule.duration * 10))}
    assert any(label.startswith("action") for label in labels), labels
