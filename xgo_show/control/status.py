"""What the show-control server says about a show: status replies and event payloads.

Plain functions from runtime objects to JSON-able dicts, shared by the status queryable, the
event publisher and the tests; the server does the I/O.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from xgo_show.choreo.sections import section_at, trigger_names
from xgo_show.compiler.schedule import Schedule
from xgo_show.runtime.show_runner import ShowProgress

__all__ = ["place", "robots_status", "show_summary", "wall_time"]


def wall_time() -> float:
    """Now as Unix seconds (what every event carries as ``time``)."""
    return round(time.time(), 6)


def place(schedule: Schedule, show_time: float) -> dict[str, Any]:
    """Show time, bar and beat (with a tempo) and the section playing there."""
    out: dict[str, Any] = {"show_time": round(show_time, 6)}
    tempo = schedule.tempo()
    if tempo is not None:
        bar, beat = tempo.bar_beat(max(0.0, show_time))
        out["bar"] = bar
        out["beat"] = round(beat, 3)
    section = section_at(schedule.sections, show_time)
    out["section"] = section.name if section is not None else None
    return out


def show_summary(schedule: Schedule, source: str) -> dict[str, Any]:
    """What is loaded: name, source, duration, performers, sections and triggers."""
    return {
        "name": schedule.name,
        "source": source,
        "duration": round(schedule.duration, 6),
        "performers": [{"name": p.name, "model": p.model} for p in schedule.performers],
        "sections": [
            {
                "name": s.name,
                "start": round(s.start, 6),
                "wait": None if s.wait is None else {
                    "trigger": s.wait.trigger,
                    "timeout": s.wait.timeout,
                    "else": s.wait.otherwise,
                },
            }
            for s in schedule.sections
        ],
        "triggers": list(trigger_names(schedule.sections)),
    }


def robots_status(
    progress: ShowProgress | None, faults: Mapping[str, str]
) -> dict[str, dict[str, Any]]:
    """Per robot: state, show time, cue, frames sent, latest readings, fault."""
    out: dict[str, dict[str, Any]] = {}
    if progress is None:
        return out
    for p in progress.performers:
        readings = dict(progress.telemetry.get(p.performer, {}))
        out[p.performer] = {
            "state": p.state.value,
            "show_time": round(p.show_time, 6),
            "cue": p.cue,
            "frames_sent": p.sent,
            "frames_total": p.total,
            "battery": readings.get("battery"),
            "readings": readings,
            "fault": faults.get(p.performer),
        }
    return out
