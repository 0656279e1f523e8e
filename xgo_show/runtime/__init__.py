"""The show runtime: launch stages, performers, typed events, safety, telemetry, reports.

- :class:`Launch` runs the stages of a show: open every port (or relay), pre-flight, arm, run.
  Each stage returns a typed result; nothing moves before :meth:`Launch.run`.
- A :class:`Performer` plays one robot's part from a start time; :class:`PerformerExecutor` is
  the local one (one schedule over one transport, on an injected :class:`Clock`), and a robot
  behind a relay on another host is a proxy implementing the same protocol.
- :class:`ShowRunner` starts every performer from one shared start and applies the failure
  policy (``halt_all``/``continue``); any fault, SIGINT/SIGTERM or exception ends in a safe stop
  of every performer.
- Everything that happens is published as a frozen event on an :class:`EventBus`
  (:mod:`~xgo_show.runtime.events`): the run log, the report, the progress display, a relay and
  a behaviour engine subscribe to it.
- :mod:`~xgo_show.runtime.preflight` checks robots before anything moves;
  :mod:`~xgo_show.runtime.report` and :mod:`~xgo_show.runtime.runlog` say what happened.
"""

from __future__ import annotations

from xgo_show.runtime.clock import Clock, FakeClock, MonotonicClock
from xgo_show.runtime.events import (
    Event,
    EventBus,
    EventChannel,
    FaultRaised,
    FrameSent,
    PreflightDone,
    ProgressTick,
    SafeStopped,
    ShowEnded,
    ShowPaused,
    ShowResumed,
    ShowSought,
    ShowStarted,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import (
    ExecutorState,
    PerformerExecutor,
    Progress,
    SafeStopResult,
)
from xgo_show.runtime.launch import Endpoint, Launch, LocalPorts, register_endpoint
from xgo_show.runtime.performer import Performer
from xgo_show.runtime.preflight import PreflightError, PreflightReport, preflight
from xgo_show.runtime.report import ProgressPrinter, format_report
from xgo_show.runtime.runlog import RunLog, read_log
from xgo_show.runtime.safety import UnsafeScheduleError, check_unsafe, stop_frames
from xgo_show.runtime.show_runner import ShowProgress, ShowResult, ShowRunner
from xgo_show.runtime.stats import SendStats
from xgo_show.runtime.telemetry import TelemetryPoller

__all__ = [
    "Clock",
    "Endpoint",
    "Event",
    "EventBus",
    "EventChannel",
    "ExecutorState",
    "FakeClock",
    "FaultRaised",
    "FrameSent",
    "Launch",
    "LocalPorts",
    "MonotonicClock",
    "Performer",
    "PerformerExecutor",
    "PreflightDone",
    "PreflightError",
    "PreflightReport",
    "Progress",
    "ProgressPrinter",
    "ProgressTick",
    "RunLog",
    "SafeStopResult",
    "SafeStopped",
    "SendStats",
    "ShowEnded",
    "ShowPaused",
    "ShowProgress",
    "ShowResult",
    "ShowResumed",
    "ShowRunner",
    "ShowSought",
    "ShowStarted",
    "StateChanged",
    "TelemetryPoller",
    "TelemetryRead",
    "UnsafeScheduleError",
    "check_unsafe",
    "format_report",
    "preflight",
    "read_log",
    "register_endpoint",
    "stop_frames",
]
