"""The show runtime: paced execution of compiled schedules, safety, telemetry, reports.

- :class:`PerformerExecutor` plays ONE performer's schedule over ONE transport from a start
  time on an injected :class:`Clock`. It knows nothing of local ports, so a relay on another
  host (e.g. behind an Eclipse Zenoh router) runs it unchanged in front of its own serial port::

      ex = PerformerExecutor(performer_schedule, transport, clock=MonotonicClock())
      ex.start(start_at, offset=0.0)   # or ex.run(...) in the calling thread
      ...
      ex.safe_stop("operator")         # from any thread; drops pending frames first

  The coordinator only needs ``start``/``pause``/``resume``/``abort``/``safe_stop``, the
  ``on_fault`` callback and ``progress``; a relay forwards those calls and callbacks.
- :class:`ShowRunner` runs every performer from one shared start and applies the failure
  policy (``halt_all``/``continue``); any fault, SIGINT/SIGTERM or exception ends in a safe stop
  of every performer.
- :mod:`~xgo_show.runtime.preflight` checks robots before anything moves;
  :mod:`~xgo_show.runtime.report` and :mod:`~xgo_show.runtime.runlog` say what happened.
"""

from __future__ import annotations

from xgo_show.runtime.clock import Clock, FakeClock, MonotonicClock
from xgo_show.runtime.executor import (
    ExecutorState,
    PerformerExecutor,
    Progress,
    SafeStopResult,
    SendRecord,
)
from xgo_show.runtime.preflight import PreflightError, PreflightReport, preflight
from xgo_show.runtime.report import format_report
from xgo_show.runtime.runlog import RunLog, read_log
from xgo_show.runtime.safety import UnsafeScheduleError, check_unsafe, stop_frames
from xgo_show.runtime.show_runner import ShowProgress, ShowResult, ShowRunner
from xgo_show.runtime.telemetry import TelemetryPoller

__all__ = [
    "Clock",
    "ExecutorState",
    "FakeClock",
    "MonotonicClock",
    "PerformerExecutor",
    "PreflightError",
    "PreflightReport",
    "Progress",
    "RunLog",
    "SafeStopResult",
    "SendRecord",
    "ShowProgress",
    "ShowResult",
    "ShowRunner",
    "TelemetryPoller",
    "UnsafeScheduleError",
    "check_unsafe",
    "format_report",
    "preflight",
    "read_log",
    "stop_frames",
]
