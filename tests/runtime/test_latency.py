"""Per-output latency: ``Early`` moves every clock time it passes on earlier, never a show time."""

from __future__ import annotations

from collections.abc import Mapping

import pytest

from tests.runtime.recording import RecordsCommands
from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult
from xgo_show.runtime.latency import Early
from xgo_show.runtime.performer import Performer


class Recorder(RecordsCommands):
    """A performer that records each call it gets and answers with fixed values."""

    def __init__(self) -> None:
        super().__init__()
        self.name = "rex"
        self.model = "mini"
        self.state = ExecutorState.PAUSED
        self.done = True
        self.fault: str | None = "port closed"
        self.progress = Progress("rex", ExecutorState.PAUSED, 2.5, 3, 10, "rex: walk", "vx=10")
        self.stop_result: SafeStopResult | None = SafeStopResult("rex", "fault", True, ("rest",))
        self.readings: Mapping[str, float] = {"battery": 80.0}
        self.stopped = SafeStopResult("rex", "asked", False, (), "no answer", 0.02)

    def lead_time(self, offset: float) -> float:
        self.calls.append(("lead_time", offset))
        return 0.25

    def start(self, start_at: float, *, offset: float = 0.0) -> None:
        self.calls.append(("start", start_at, offset))

    def safe_stop(self, reason: str, *, timeout: float = 0.1) -> SafeStopResult:
        self.calls.append(("safe_stop", reason, timeout))
        return self.stopped

    def join(self, timeout: float | None = None) -> bool:
        self.calls.append(("join", timeout))
        return False

    def close(self) -> None:
        self.calls.append(("close",))


def _early(seconds: float) -> tuple[Early, Recorder]:
    inner = Recorder()
    performer: Performer = Early(inner, seconds)  # it is a Performer itself
    assert isinstance(performer, Early)
    return performer, inner


def test_every_clock_time_moves_earlier_and_show_times_stay() -> None:
    early, inner = _early(0.040)
    early.start(100.0, offset=12.0)
    early.pause(at=105.0)
    early.resume(at=110.0)
    early.seek(30.0, at=120.0)
    assert inner.calls == [
        ("start", pytest.approx(99.96), 12.0),
        ("pause", pytest.approx(104.96)),
        ("resume", pytest.approx(109.96)),
        ("seek", 30.0, pytest.approx(119.96)),
    ]


def test_now_stays_now() -> None:
    # No clock time (act at once) is passed on as none, not as a time 40 ms ago.
    early, inner = _early(0.040)
    early.pause()
    early.resume()
    early.seek(30.0)
    assert inner.calls == [("pause", None), ("resume", None), ("seek", 30.0, None)]


def test_a_start_without_offset_keeps_the_inner_default() -> None:
    early, inner = _early(0.5)
    early.start(10.0)
    assert inner.calls == [("start", 9.5, 0.0)]


def test_the_lead_grows_by_the_time_it_starts_early_never_shrinks() -> None:
    early, inner = _early(0.040)
    assert early.lead_time(3.0) == pytest.approx(0.29)
    assert inner.calls == [("lead_time", 3.0)]
    # A negative latency (an output that runs early) acts later: no extra lead for that.
    late, _ = _early(-0.040)
    assert late.lead_time(0.0) == 0.25


def test_everything_else_is_the_inner_performers() -> None:
    early, inner = _early(0.040)
    assert (early.name, early.model, early.state) == ("rex", "mini", ExecutorState.PAUSED)
    assert early.done is True and early.fault == "port closed"
    assert early.progress is inner.progress and early.stop_result is inner.stop_result
    assert early.readings is inner.readings
    assert early.safe_stop("asked", timeout=0.3) is inner.stopped
    assert early.join(1.5) is False
    early.abort()
    early.close()
    assert inner.calls == [("safe_stop", "asked", 0.3), ("join", 1.5), ("abort",), ("close",)]
    inner.done, inner.fault = False, None
    assert early.done is False and early.fault is None


def test_a_safe_stop_keeps_the_inner_default_timeout() -> None:
    early, inner = _early(0.040)
    early.safe_stop("fault")
    early.join()
    assert inner.calls == [("safe_stop", "fault", 0.1), ("join", None)]
