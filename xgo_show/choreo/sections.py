"""Sections and waits: a show as a sequence of parts released by triggers.

A section is a named time range of the one compiled schedule: it starts at ``start`` (seconds
of show time) and lasts until the next section starts (the last one until the show's end). A
section may carry a :class:`Wait`: when the show reaches the section's start, every robot holds
there (at rest, in the posture the show gives it at that moment) until the trigger named by the
wait arrives; then the section plays. With a ``timeout``, the wait ends on its own after that
many seconds and ``otherwise`` says what happens: jump to a named section, ``continue`` (play
the section as if triggered) or ``end`` (skip to the show's end: the robots take its final
posture and the show completes).

These are plain values shared by the loader (which builds them from ``sections:``), the compiler
(which stores them in the schedule) and the runtime (which holds and releases the show): no
pydantic, no I/O.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass

from xgo_show.choreo.timebase import TempoMap
from xgo_show.diagnostics import Origin

__all__ = [
    "CONTINUE",
    "ELSE_KEYWORDS",
    "END",
    "Section",
    "Wait",
    "format_sections",
    "section_at",
    "section_named",
    "trigger_names",
]

CONTINUE = "continue"  # after a timeout: play the section as if triggered
END = "end"  # after a timeout: skip to the show's end (its final posture; the show completes)
ELSE_KEYWORDS = (CONTINUE, END)


@dataclass(frozen=True)
class Wait:
    """Hold at a section's start until ``trigger``; after ``timeout`` s (if any), ``otherwise``."""

    trigger: str
    timeout: float | None = None
    otherwise: str = CONTINUE  # a section name, CONTINUE or END


@dataclass(frozen=True)
class Section:
    """A named part of the show from ``start`` (seconds of show time) to the next section."""

    name: str
    start: float
    wait: Wait | None = None
    origin: Origin | None = None


def section_at(sections: Sequence[Section], show_time: float) -> Section | None:
    """The section playing at ``show_time`` (None before the first one, or without any).

    ``sections`` are sorted by start, as the loader and the schedule keep them.
    """
    starts = [s.start for s in sections]
    i = bisect.bisect_right(starts, show_time + 1e-9) - 1
    return sections[i] if i >= 0 else None


def section_named(sections: Sequence[Section], name: str) -> Section | None:
    """The section called ``name``, or None."""
    return next((s for s in sections if s.name == name), None)


def trigger_names(sections: Sequence[Section]) -> tuple[str, ...]:
    """Every trigger some section waits for, in show order, each once."""
    seen: dict[str, None] = {}
    for s in sections:
        if s.wait is not None:
            seen.setdefault(s.wait.trigger, None)
    return tuple(seen)


def format_sections(
    sections: Sequence[Section], tempo: TempoMap | None = None, *, end: float | None = None
) -> str:
    """A table of the sections (start, bar.beat with a tempo, length, wait) and the triggers.

    Empty text for a show without sections (it runs straight through).
    """
    if not sections:
        return ""
    lines = ["section          start      bar.beat  length    waits for"]
    for i, sec in enumerate(sections):
        stop = sections[i + 1].start if i + 1 < len(sections) else end
        length = f"{stop - sec.start:7.3f} s" if stop is not None else "      —  "
        where = "—"
        if tempo is not None:
            bar, beat = tempo.bar_beat(sec.start)
            where = f"{bar}.{beat:g}"
        wait = "—"
        if sec.wait is not None:
            wait = f"trigger {sec.wait.trigger!r}"
            if sec.wait.timeout is not None:
                wait += f", after {sec.wait.timeout:g} s: {sec.wait.otherwise}"
        lines.append(f"{sec.name:<16} {sec.start:7.3f} s  {where:<9} {length}  {wait}")
    names = trigger_names(sections)
    lines.append(f"triggers: {', '.join(names) if names else 'none'}")
    return "\n".join(lines) + "\n"
