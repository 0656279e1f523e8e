"""End-of-show report, error statistics, progress line and run log."""

from __future__ import annotations

import io
import json

import pytest

from xgo_show.choreo.timebase import Segment, TempoMap
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.executor import ExecutorState, Progress
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.report import (
    PerformerReport,
    ProgressPrinter,
    error_stats,
    format_report,
    percentile,
)
from xgo_show.runtime.runlog import RunLog, read_log
from xgo_show.runtime.show_runner import ShowProgress
from xgo_show.sim import create_robot
from xgo_show.transports.sim import SimTransport


def test_percentiles_interpolate() -> None:
    assert percentile([3.0, 1.0, 2.0], 0.5) == 2.0
    assert percentile([0.0, 10.0], 0.95) == pytest.approx(9.5)
    stats = error_stats([0.001, 0.002, -0.001])
    assert stats.count == 3 and stats.max == pytest.approx(2.0) and stats.p50 == pytest.approx(1.0)
    assert error_stats([]).format() == "no frames sent"


def _progress(
    t: float, state: ExecutorState = ExecutorState.RUNNING, cue: str = "rex: walk"
) -> ShowProgress:
    rex = Progress("rex", state, t, 3, 10, cue, "vx=10")
    return ShowProgress(t, 20.0, (rex,), {"rex": {"battery": 87.0}})


def test_progress_line_shows_time_bar_beat_cue_and_battery() -> None:
    printer = ProgressPrinter(tempo=TempoMap.constant(120, 4), out=io.StringIO(), tty=False)
    # 5.25 s at 120 bpm = beat 10 (0-based) = bar 3, beat 3.
    assert printer.line(_progress(5.25)) == "   5.2/20.0s | bar 3:3 | rex: walk (battery 87%)"
    paused = printer.line(_progress(5.25, ExecutorState.PAUSED))
    assert "rex: walk [paused]" in paused


def test_progress_line_shows_the_xarm_battery_in_volts() -> None:
    printer = ProgressPrinter(out=io.StringIO(), tty=False)
    arm = Progress("arm", ExecutorState.RUNNING, 1.0, 3, 10, "arm: pose", "ServoMove")
    line = printer.line(ShowProgress(1.0, 20.0, (arm,), {"arm": {"battery_v": 7.6}}))
    assert line.endswith("arm: pose (battery 7.60 V)")


def test_progress_line_leaves_out_where_phrases_were_called() -> None:
    printer = ProgressPrinter(out=io.StringIO(), tty=False)
    line = printer.line(_progress(1.0, cue="rex: move roll (phrase sway at shows/a b.yaml:275)"))
    assert "rex: move roll (phrase sway) (battery" in line
    line = printer.line(_progress(1.0, cue="rex: periodic roll (phrase unison at line 28)"))
    assert "rex: periodic roll (phrase unison) (battery" in line


def test_progress_bars_follow_tempo_changes() -> None:
    # Two 4/4 bars at 120 bpm (4 s), then 3/4 at 60 bpm: 8.5 s is 4.5 s into bar 3 -> bar 4:2.
    tempo = TempoMap([Segment(1, 120, 4), Segment(3, 60, 3)])
    printer = ProgressPrinter(tempo=tempo, out=io.StringIO(), tty=False)
    assert "| bar 4:2 |" in printer.line(_progress(8.5))
    assert "| bar 2:4 |" in printer.line(_progress(3.9))


def test_progress_prints_plain_lines_now_and_then_off_a_terminal() -> None:
    out = io.StringIO()
    printer = ProgressPrinter(out=out, tty=False, plain_every=2.0)
    for k in range(21):
        printer(_progress(k * 0.25))
    assert len(out.getvalue().splitlines()) == 3  # at 0, 2 and 4 s
    tty_out = io.StringIO()
    live = ProgressPrinter(out=tty_out, tty=True)
    live(_progress(1.0))
    live(_progress(1.25))
    live.finish()
    assert tty_out.getvalue().count("\r") == 2 and tty_out.getvalue().endswith("\n")


def test_report_and_log_of_a_completed_run(perf, sched, tmp_path) -> None:
    clock = FakeClock()
    schedule = sched(perf("rex", "mini", count=6), perf("rita", "rider", count=4))
    links = {
        p.name: SimTransport(create_robot(p.model), clock=clock.now, sleep=clock.advance)
        for p in schedule.performers
    }
    for link in links.values():
        link.open()
    log_path = tmp_path / "run.jsonl"
    with RunLog(log_path) as log:
        runner = local_runner(schedule, links, clock=FakeClock(), telemetry=False)
        log.attach(runner.events)
        result = runner.run(handle_signals=False)
    assert result.completed
    text = format_report(result)
    assert text.splitlines()[0] == "show completed"
    assert "rex (mini): finished; 6/6 frames" in text
    assert "rita (rider): finished; 4/4 frames" in text
    assert "rested: vx=0" in text
    records = read_log(log_path)
    frames = [r for r in records if r["kind"] == "frame" and r["send"] == "frame"]
    assert len(frames) == 10
    assert all(r["planned"] is not None and r["actual"] is not None for r in frames)
    rex = schedule.performer("rex")
    assert [r["bytes"] for r in frames if r["performer"] == "rex"] == [
        f.data.hex() for f in rex.frames
    ]
    events = [r["event"] for r in records if r["kind"] == "event"]
    assert events == ["start", "end"]
    json.dumps(records)


def test_a_send_time_error_above_target_is_flagged() -> None:
    on_time = error_stats([0.0001] * 1000)  # 0.1 ms
    assert on_time.over_target() == ""
    late = error_stats([0.0001] * 985 + [0.003] * 15)  # p99 and p99.9 at 3 ms
    assert late.over_target() == "ABOVE TARGET: p99 3.000 ms > 0.5 ms, p99.9 3.000 ms > 2 ms"
    assert "ABOVE" not in late.format()  # other figures (benchmarks) format plainly
    report = PerformerReport("rex", "mini", "finished", 1000, 1000, 9000, 0, late, {}, "ok", None)
    assert report.format().splitlines()[1] == (
        f"  send-time error: {late.format()}  ABOVE TARGET: p99 3.000 ms > 0.5 ms, "
        "p99.9 3.000 ms > 2 ms")
    assert "ABOVE" not in PerformerReport("rex", "mini", "finished", 1000, 1000, 9000, 0,
                                          on_time, {}, "ok", None).format()
