"""End-of-show report, error statistics, progress line and run log."""

from __future__ import annotations

import io
import json
from types import SimpleNamespace
from typing import Any

import pytest

from xgo_show.choreo.timebase import Segment, TempoMap
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import FrameSent, ProgressTick, ShowPaused
from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.report import (
    PerformerReport,
    ProgressPrinter,
    build_report,
    error_stats,
    format_report,
    percentile,
)
from xgo_show.runtime.runlog import RunLog, read_log
from xgo_show.runtime.show_runner import ShowProgress, ShowResult
from xgo_show.runtime.stats import SendStats
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


def _performer(name: str = "rex", model: str = "mini", *, stop: SafeStopResult | None = None,
               fault: str | None = None, readings: dict[str, float] | None = None) -> Any:
    """A performer as the report reads it: only what it asks for."""
    progress = Progress(name, ExecutorState.STOPPED, 3.0, 4, 10, f"{name}: walk", "vx=10")
    return SimpleNamespace(model=model, state=ExecutorState.STOPPED, progress=progress,
                           stop_result=stop, readings=readings or {}, fault=fault)


def _sent(stats: SendStats, kind: str, data: bytes, note: str = "", *, t: float = 1.0,
          planned: float | None = None) -> None:
    stats.on_event(FrameSent(t, "rex", kind, 0, planned, data, note, None, 0.0))


def test_a_report_names_every_telemetry_value_in_its_unit_and_the_fault() -> None:
    report = PerformerReport(
        "rex", "mini", "failed", 4, 10, 36, 2, error_stats([]),
        {"imu_roll": 1.26, "battery": 87.4, "temp": 3.5, "battery_v": 7.614},
        "safe stop (fault) ok in 1.0 ms: rest", "port closed")
    assert report.format().splitlines() == [
        "rex (mini): failed; 4/10 frames, 36 bytes sent, 2 telemetry reads",
        "  send-time error: no frames sent",
        "  telemetry: battery 87%, battery 7.61 V, imu_roll 1.3 deg, temp 3.5",
        "  fault: port closed",
        "  end: safe stop (fault) ok in 1.0 ms: rest",
    ]
    quiet = PerformerReport("rex", "mini", "finished", 1, 1, 9, 0, error_stats([]), {},
                            "show over", None)
    assert [line.split(":")[0] for line in quiet.format().splitlines()] == [
        "rex (mini)", "  send-time error", "  end"]


def test_the_soundtrack_reports_only_how_it_ended() -> None:
    music = PerformerReport("music", "music", "finished", 0, 0, 0, 0, error_stats([]), {},
                            "show over", None)
    assert music.format() == "music: finished; show over"


def test_the_ending_says_what_the_safe_stop_sent_and_how_long_it_took() -> None:
    ok = SafeStopResult("rex", "fault", True, ("rest", "stand"), "", 0.01234)
    failed = SafeStopResult("rex", "SIGINT", False, (), "write failed", 0.0)
    result = ShowResult(False, "SIGINT", {"rex": _performer(), "rita": _performer("rita")},
                        stops={"rex": ok, "rita": failed})
    rex, rita = build_report(result)
    assert rex.ending == "safe stop (fault) ok in 12.3 ms: rest, stand"
    assert rita.ending == "safe stop (SIGINT) FAILED (write failed) in 0.0 ms: nothing sent"


def test_a_stop_the_performer_made_itself_is_its_ending_when_the_show_has_none() -> None:
    own = SafeStopResult("rex", "battery low", True, ("rest",), "", 0.002)
    other = SafeStopResult("rex", "SIGINT", True, ("stand",), "", 0.003)
    alone = build_report(ShowResult(False, "fault", {"rex": _performer(stop=own)}))
    assert alone[0].ending == "safe stop (battery low) ok in 2.0 ms: rest"
    both = build_report(ShowResult(False, "SIGINT", {"rex": _performer(stop=own)},
                                   stops={"rex": other}))
    assert both[0].ending == "safe stop (SIGINT) ok in 3.0 ms: stand"


@pytest.mark.parametrize(("rests", "said"), [(1, "rested"), (2, "rested twice"),
                                             (3, "rested 3 times")])
def test_the_ending_counts_the_rests_and_names_each_rest_frame_once(rests: int,
                                                                    said: str) -> None:
    stats = SendStats()
    for _ in range(rests):
        _sent(stats, "rest", b"\x01", "vx=0")
        _sent(stats, "rest", b"\x02", "vy=0")
    result = ShowResult(True, "completed", {"rex": _performer()}, stats={"rex": stats})
    assert build_report(result)[0].ending == f"show over; {said}: vx=0, vy=0"


def test_a_report_counts_from_the_send_stats_or_else_from_the_progress() -> None:
    stats = SendStats()
    _sent(stats, "frame", b"\x01\x02\x03", t=1.0015, planned=1.0)
    _sent(stats, "frame", b"\x04", t=2.0005, planned=2.0)
    _sent(stats, "read", b"\x05\x06")
    counted = ShowResult(True, "completed", {"rex": _performer(readings={"battery": 80.0},
                                                               fault="low")},
                         stats={"rex": stats})
    rex = build_report(counted)[0]
    assert (rex.name, rex.model, rex.state) == ("rex", "mini", "stopped")
    assert (rex.frames_sent, rex.frames_total, rex.bytes_sent, rex.reads) == (2, 10, 6, 1)
    assert rex.errors.count == 2 and rex.errors.max == pytest.approx(1.5, abs=0.01)
    assert rex.telemetry == {"battery": 80.0} and rex.fault == "low"
    assert rex.ending == "show over"
    # Without send stats (a relayed robot's): its progress, and nothing else to count.
    bare = build_report(ShowResult(True, "completed", {"rex": _performer()}))[0]
    assert (bare.frames_sent, bare.frames_total, bare.bytes_sent, bare.reads) == (4, 10, 0, 0)
    assert bare.errors == error_stats([]) and bare.ending == "show over"
    assert bare.telemetry == {} and bare.fault is None


def test_the_report_heads_with_how_the_show_ended_and_the_stop_latency() -> None:
    stopped = ShowResult(False, "SIGINT", {"rex": _performer()}, stop_latency=0.08888)
    lines = format_report(stopped).splitlines()
    assert lines[0] == ("show stopped: SIGINT; safe stop finished 88.9 ms after the request "
                        "(target 100 ms)")
    assert lines[1].startswith("rex (mini): stopped; 4/10 frames")
    assert format_report(ShowResult(True, "completed")) == "show completed"


class _Out(io.StringIO):
    """A stream that counts its flushes and may say it is a terminal."""

    def __init__(self, tty: bool = False) -> None:
        super().__init__()
        self.tty, self.flushes = tty, 0

    def isatty(self) -> bool:
        return self.tty

    def flush(self) -> None:
        self.flushes += 1
        super().flush()


def test_plain_lines_go_out_every_two_seconds_from_the_start_each_flushed() -> None:
    out = _Out()
    printer = ProgressPrinter(out=out)  # not a terminal: plain lines
    for k in range(9):
        printer(_progress(k * 0.5))
    assert out.getvalue().splitlines() == [printer.line(_progress(t)) for t in (0.0, 2.0, 4.0)]
    assert out.flushes == 3  # each line reaches a pipe's reader at once
    printer.finish()  # nothing to end off a terminal
    assert out.getvalue().count("\n") == 3


def test_on_a_terminal_the_line_is_rewritten_in_place_and_ended_once() -> None:
    out = _Out(tty=True)
    printer = ProgressPrinter(out=out)  # the stream says it is a terminal
    long, short = _progress(1.0, cue="rex: a long cue"), _progress(1.25, cue="rex: x")
    printer(long)
    printer(short)
    first, second = printer.line(long), printer.line(short)
    # The shorter line is padded to cover what the longer one left on screen.
    assert out.getvalue() == "\r" + first + "\r" + second + " " * (len(first) - len(second))
    assert out.flushes == 2
    printer.finish()
    assert out.getvalue().endswith(" \n")
    idle = _Out(tty=True)
    ProgressPrinter(out=idle).finish()  # nothing drawn: nothing to end
    assert idle.getvalue() == ""


def test_a_progress_line_on_a_beat_shows_that_beat_and_a_dash_without_a_cue() -> None:
    printer = ProgressPrinter(tempo=TempoMap.constant(120, 4), out=io.StringIO(), tty=False)
    # 5.0 s at 120 bpm is exactly beat 11 (1-based): bar 3, beat 3.
    rex = Progress("rex", ExecutorState.RUNNING, 5.0, 3, 10, "", "")
    assert printer.line(ShowProgress(5.0, 20.0, (rex,), {})) == "   5.0/20.0s | bar 3:3 | rex: -"


def test_the_printer_draws_progress_ticks_from_the_bus_and_nothing_else() -> None:
    out = io.StringIO()
    printer = ProgressPrinter(out=out, tty=False)
    printer.on_event(ShowPaused(1.0, 0.5))
    assert out.getvalue() == ""
    printer.on_event(ProgressTick(1.0, _progress(0.0)))
    assert out.getvalue() == printer.line(_progress(0.0)) + "\n"
