"""The run log: which record each runtime event becomes, what is kept, what reaches the disk."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

from xgo_show.errors import FileAccessError
from xgo_show.runtime.events import (
    EventBus,
    FaultRaised,
    FrameSent,
    PreflightDone,
    ProgressTick,
    RunnerFailed,
    SafeStopped,
    ShowEnded,
    ShowPaused,
    ShowResumed,
    ShowSought,
    ShowStarted,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState, SafeStopResult
from xgo_show.runtime.runlog import RunLog, read_log


class _Report:
    """A pre-flight report as the run log sees it: only its record."""

    def as_record(self) -> dict[str, object]:
        return {"ok": True, "realtime": "SCHED_FIFO", "rows": []}


def _fields(record: dict[str, Any]) -> dict[str, Any]:
    """A record without its write time."""
    return {k: v for k, v in record.items() if k != "mono"}


def _one(event: object) -> dict[str, Any]:
    log = RunLog(None)
    log.on_event(event)  # type: ignore[arg-type]
    assert len(log.records) == 1
    return _fields(log.records[0])


def test_a_scheduled_frame_is_logged_with_its_planned_and_actual_show_times() -> None:
    sent = FrameSent(10.0, "rex", "frame", 7, 9.9999, b"\x55\x00\xaa", "vx=10",
                     1.23456789, 1.2350004)
    assert _one(sent) == {"kind": "frame", "performer": "rex", "send": "frame", "index": 7,
                          "planned": 1.234568, "actual": 1.235, "bytes": "5500aa"}


def test_a_frame_the_schedule_does_not_hold_has_no_planned_time() -> None:
    sent = FrameSent(10.0, "rex", "read", None, None, b"\x01", "read battery", None, 2.0000004)
    assert _one(sent) == {"kind": "frame", "performer": "rex", "send": "read", "index": None,
                          "planned": None, "actual": 2.0, "bytes": "01"}


def test_telemetry_and_state_changes_are_logged_with_their_clock_time() -> None:
    assert _one(TelemetryRead(5.5, "rex", "battery", 81.0)) == {
        "kind": "telemetry", "performer": "rex", "name": "battery", "value": 81.0, "t": 5.5}
    changed = StateChanged(105.12345678, "rex", ExecutorState.PAUSED, 3.25000049)
    assert _one(changed) == {"kind": "state", "performer": "rex", "state": "paused",
                             "show_time": 3.25, "t": 105.123457}


def test_a_fault_and_the_safe_stop_it_caused_are_events() -> None:
    assert _one(FaultRaised(7.12345678, "rex", "port closed")) == {
        "kind": "event", "event": "fault", "performer": "rex", "reason": "port closed",
        "t": 7.123457}
    stop = SafeStopResult("rex", "fault", False, ("rest", "stand"), "write failed", 0.0123456)
    assert _one(SafeStopped(7.2, "rex", stop)) == {
        "kind": "event", "event": "safe_stop", "performer": "rex", "reason": "fault",
        "ok": False, "frames": ["rest", "stand"], "error": "write failed", "elapsed_ms": 12.346}


def test_the_show_events_are_logged_with_their_times() -> None:
    assert _one(PreflightDone(1.0, _Report(), forced=True)) == {
        "kind": "event", "event": "preflight", "forced": True, "ok": True,
        "realtime": "SCHED_FIFO", "rows": []}
    started = ShowStarted(2.0, "demo", 4.5, 100.12345678, ("rex", "arm"), "continue", 20.0)
    assert _one(started) == {"kind": "event", "event": "start", "show": "demo", "offset": 4.5,
                             "start_at": 100.123457, "performers": ["rex", "arm"],
                             "on_failure": "continue", "battery_floor": 20.0}
    assert _one(ShowPaused(3.0, 1.23456789)) == {"kind": "event", "event": "pause",
                                                 "show_time": 1.234568}
    assert _one(ShowResumed(4.0, 1.23456789)) == {"kind": "event", "event": "resume",
                                                  "show_time": 1.234568}
    assert _one(ShowSought(5.0, 9.87654321, 110.50000049)) == {
        "kind": "event", "event": "seek", "show_time": 9.876543, "at": 110.5}
    assert _one(RunnerFailed(6.0, "boom", "RuntimeError")) == {
        "kind": "event", "event": "exception", "error": "boom", "type": "RuntimeError"}


def test_the_end_names_faults_states_and_the_stop_latency() -> None:
    ended = ShowEnded(9.0, False, "fault", {"rex": "port closed"}, {"rex": "stopped"},
                      0.04212345)
    assert _one(ended) == {"kind": "event", "event": "end", "completed": False,
                           "reason": "fault", "faults": {"rex": "port closed"},
                           "states": {"rex": "stopped"}, "stop_latency_ms": 42.123}
    assert _one(ShowEnded(9.0, True, "completed"))["stop_latency_ms"] is None


def test_progress_ticks_are_not_logged() -> None:
    log = RunLog(None)
    log.on_event(ProgressTick(1.0, None))
    assert log.records == []


def test_attached_it_logs_what_the_bus_publishes_until_detached() -> None:
    bus, log = EventBus(), RunLog(None)
    with log.attach(bus):
        bus.publish(ShowPaused(3.0, 1.0))
    bus.publish(ShowResumed(4.0, 1.0))
    assert [r["event"] for r in log.records] == ["pause"]


def test_every_record_carries_the_monotonic_time_it_was_written() -> None:
    log = RunLog(None)
    before = time.monotonic()
    log.write("sim", performer="rex")
    after = time.monotonic()
    mono = log.records[0]["mono"]
    assert before - 1e-6 <= mono <= after + 1e-6 and round(mono, 6) == mono


def test_a_records_monotonic_time_is_rounded_to_the_microsecond(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # Exact values: a real clock's reading has a seventh digit of 0 one time in ten, when any
    # rounding from the sixth on looks the same.
    from types import SimpleNamespace

    import xgo_show.runtime.runlog as runlog

    log = RunLog(None)
    for now, mono in ((12.3456789, 12.345679), (7.0000004, 7.0), (3.1415926535, 3.141593)):
        monkeypatch.setattr(runlog, "time", SimpleNamespace(monotonic=lambda now=now: now))
        log.write("sim")
        assert log.records[-1]["mono"] == mono


def test_events_filters_the_event_records_by_name() -> None:
    log = RunLog(None)
    log.event("start", show="demo")
    log.write("frame", performer="rex")
    log.event("pause", show_time=1.0)
    log.event("end", completed=True)
    assert [r["event"] for r in log.events()] == ["start", "pause", "end"]
    assert [_fields(r) for r in log.events("pause")] == [
        {"kind": "event", "event": "pause", "show_time": 1.0}]


def test_a_file_log_keeps_nothing_in_memory_unless_asked(tmp_path: Path) -> None:
    with RunLog(tmp_path / "a.jsonl") as log:
        log.write("sim", performer="rex")
        assert log.records == []
    with RunLog(tmp_path / "b.jsonl", keep=True) as kept:
        kept.write("sim", performer="rex")
        assert [_fields(r) for r in kept.records] == [{"kind": "sim", "performer": "rex"}]
    memory = RunLog(None, keep=False)
    memory.write("sim", performer="rex")
    assert memory.records == []


def test_a_log_that_writes_nowhere_makes_no_record(monkeypatch: pytest.MonkeyPatch) -> None:
    import xgo_show.runtime.runlog as runlog

    made: list[object] = []
    monkeypatch.setattr(runlog.json, "dumps", lambda record, **kw: made.append(record) or "{}")
    bus = EventBus()
    nowhere = RunLog(None, keep=False)
    nowhere.attach(bus)
    bus.publish(FrameSent(1.0, "rex", "frame", 0, 1.0, b"\x01", "", 0.0, 0.0, None))
    nowhere.event("fault", performer="rex")
    assert made == [] and nowhere.records == []
    kept = RunLog(None)  # the same events, kept: made
    kept.attach(bus)
    bus.publish(FrameSent(1.0, "rex", "frame", 0, 1.0, b"\x01", "", 0.0, 0.0, None))
    assert len(made) == 1 and [r["kind"] for r in kept.records] == ["frame"]


def test_a_closed_file_log_makes_no_record(tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    import xgo_show.runtime.runlog as runlog

    bus, log = EventBus(), RunLog(tmp_path / "run.jsonl")
    log.attach(bus)
    log.event("fault", performer="rex")
    log.close()
    made: list[object] = []
    monkeypatch.setattr(runlog.json, "dumps", lambda record, **kw: made.append(record) or "{}")
    bus.publish(FrameSent(1.0, "rex", "frame", 0, 1.0, b"\x01", "", 0.0, 0.0, None))
    log.write("sim", performer="rex")
    assert made == [] and log.records == []
    assert [r["kind"] for r in read_log(tmp_path / "run.jsonl")] == ["event"]

def test_events_reach_the_disk_at_once_frames_when_closed(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    log = RunLog(path)
    log.write("frame", performer="rex", bytes=b"\x01")  # not JSON: written as its str()
    assert path.read_text(encoding="utf-8") == ""  # buffered
    log.event("fault", performer="rex", reason="port closed")
    # The fault flushes what led to it: both lines are on disk before the log is closed.
    assert [(r["kind"], r.get("bytes")) for r in read_log(path)] == [
        ("frame", "b'\\x01'"), ("event", None)]
    log.write("frame", performer="rex", index=1)
    log.close()
    log.close()  # twice is harmless
    lines = path.read_text(encoding="utf-8").splitlines()
    assert len(lines) == 3 and json.loads(lines[2])["index"] == 1


def test_read_log_skips_blank_lines(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    path.write_text('{"kind": "sim"}\n\n  \n{"kind": "event"}\n', encoding="utf-8")
    assert read_log(path) == [{"kind": "sim"}, {"kind": "event"}]


def test_a_log_that_cannot_be_written_is_a_clear_error(tmp_path: Path) -> None:
    where = tmp_path / "missing" / "run.jsonl"
    with pytest.raises(FileAccessError, match=f"cannot write the run log {where}: "):
        RunLog(where)
