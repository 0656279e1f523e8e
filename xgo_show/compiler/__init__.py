"""The compiler: a pure, deterministic function from a validated routine to paced frame schedules.

- :func:`compile_show` turns a :class:`~xgo_show.choreo.resolved.ResolvedShow` into a
  :class:`~xgo_show.compiler.schedule.Schedule`; :func:`compile_diagnostics` finds the same
  errors and warnings without keeping the frames (what `validate` needs);
- :func:`save_schedule` / :func:`load_schedule` write and read the versioned JSON artifact;
- :func:`describe_frame`, :func:`state_at`, :func:`frames_to_reach` read schedules back;
- :func:`plot_schedule` draws one (needs the optional ``plot`` extra, matplotlib).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from xgo_show.compiler.artifact import load_schedule, save_schedule
    from xgo_show.compiler.build import compile_diagnostics, compile_show
    from xgo_show.compiler.schedule import (
        SCHEDULE_VERSION,
        PerformerSchedule,
        Schedule,
        ScheduledFrame,
    )
    from xgo_show.compiler.state import describe_frame, frames_to_reach, state_at

__all__ = [
    "SCHEDULE_VERSION",
    "PerformerSchedule",
    "Schedule",
    "ScheduledFrame",
    "compile_diagnostics",
    "compile_show",
    "describe_frame",
    "frames_to_reach",
    "load_schedule",
    "plot_schedule",
    "save_schedule",
    "state_at",
]

# Where each public name lives. They are imported on first use: ``validate`` needs the
# compiler's walk, not the schedule file's reader and writer (a fifth of its start-up).
_HOMES = {
    "SCHEDULE_VERSION": "schedule", "PerformerSchedule": "schedule", "Schedule": "schedule",
    "ScheduledFrame": "schedule", "compile_diagnostics": "build", "compile_show": "build",
    "describe_frame": "state", "frames_to_reach": "state", "state_at": "state",
    "load_schedule": "artifact", "save_schedule": "artifact",
}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(f"xgo_show.compiler.{home}"), name)


def plot_schedule(schedule: Schedule, path: str | Path) -> Path:
    """Draw ``schedule`` at ``path``: an interactive page when it ends in ``.html``
    (:mod:`xgo_show.compiler.timeline_html`, no dependency), else a PNG
    (:mod:`xgo_show.compiler.plot`, needs matplotlib)."""
    if Path(path).suffix.lower() in (".html", ".htm"):
        from xgo_show.compiler.timeline_html import write_timeline_html

        return write_timeline_html(schedule, path)
    from xgo_show.compiler.plot import plot_schedule as _plot

    return _plot(schedule, path)
