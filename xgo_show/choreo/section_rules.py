"""Sections of a routine: from ``sections:`` to :class:`Section` values, and their checks.

:func:`resolve_sections` places each section in show time and checks the list itself (order,
names, ``else:`` targets, the show's end); :func:`check_waits` checks the cues against the waits:
no cue may run across a wait, because the robots hold still while the show waits (a move would
freeze half-way, a preset action would be cut). Every problem is a diagnostic at the place
written, like every other check of the loader.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from xgo_show.choreo.model import Position, ShowFile
from xgo_show.choreo.resolved import ActionCue
from xgo_show.choreo.sections import CONTINUE, ELSE_KEYWORDS, Section, Wait
from xgo_show.choreo.source import Document, Loc
from xgo_show.choreo.validation import did_you_mean
from xgo_show.diagnostics import Diagnostic

if TYPE_CHECKING:
    from xgo_show.choreo.resolve import Resolution

__all__ = ["check_waits", "resolve_sections"]

_EPS = 1e-6

Place = Callable[[Position, Loc], "float | None"]


@dataclass
class _Report:
    doc: Document
    diags: list[Diagnostic]

    def error(self, loc: Loc, message: str) -> None:
        self.diags.append(
            Diagnostic("error", message, self.doc.origin(loc), self.doc.path(loc))
        )


def resolve_sections(
    show: ShowFile, doc: Document, place: Place, show_end: float | None, diags: list[Diagnostic]
) -> tuple[Section, ...]:
    """The routine's sections in show time; problems are appended to ``diags``.

    ``place`` turns a position into seconds from the show's start (None when it cannot:
    the problem is reported by it); ``show_end`` is the show's end when known.
    """
    report = _Report(doc, diags)
    names = [s.name for s in show.sections]
    out: list[Section] = []
    seen: dict[str, int] = {}
    previous: Section | None = None
    for i, model in enumerate(show.sections):
        loc: Loc = ("sections", i)
        if model.name in ELSE_KEYWORDS:
            report.error((*loc, "name"), f"{model.name!r} is a keyword of else:; name the "
                         "section otherwise")
        elif model.name in seen:
            report.error((*loc, "name"), f"a second section named {model.name!r} (the first is "
                         f"sections[{seen[model.name]}]); section names are unique")
        seen.setdefault(model.name, i)
        if model.at is None:
            if i > 0:
                report.error(loc, "give 'at': where this section starts (only the first "
                             "section starts at 0 by default)")
                continue
            start: float | None = 0.0
        else:
            start = place(model.at, (*loc, "at"))
        if start is None:
            continue
        if previous is not None and start <= previous.start + _EPS:
            report.error((*loc, "at"), f"starts at {start:.3f} s, not after section "
                         f"{previous.name!r} ({previous.start:.3f} s): list sections in show "
                         "order")
            continue
        if show_end is not None and start > show_end + _EPS:
            report.error((*loc, "at"), f"starts at {start:.3f} s, after the show's end "
                         f"({show_end:.3f} s)")
            continue
        wait = None
        if model.wait is not None:
            otherwise = model.wait.else_ or CONTINUE
            if otherwise not in ELSE_KEYWORDS and otherwise not in names:
                hint = did_you_mean(otherwise, [*names, *ELSE_KEYWORDS])
                report.error((*loc, "wait", "else"), f"no section named {otherwise!r}{hint} "
                             f"(else: takes a section name, {CONTINUE} or end)")
            elif otherwise == model.name:
                report.error((*loc, "wait", "else"), f"else: {otherwise} comes back to this "
                             "same wait: leave out 'timeout' to wait until the trigger comes")
            wait = Wait(model.wait.trigger, model.wait.timeout, otherwise)
        section = Section(model.name, start, wait, doc.origin(loc, model.name))
        out.append(section)
        previous = section
    return tuple(out)


def check_waits(res: Resolution) -> list[Diagnostic]:
    """A cue that runs across a wait (the robots hold still there) is an error."""
    show = res.show
    if show is None:
        return []
    waits = [s for s in show.sections if s.wait is not None and s.start > 0]
    if not waits:
        return []
    diags: list[Diagnostic] = []
    reported: set[tuple[int, str]] = set()
    for track in show.tracks:
        if track.performer in res.untimed:
            continue
        for cue in track.cues:
            src = res.source(cue)
            busy = cue.start + src.running if isinstance(cue, ActionCue) else src.end
            for section in waits:
                t = section.start
                key = (id(src), section.name)
                if cue.start < t - _EPS < busy - 2 * _EPS and key not in reported:
                    reported.add(key)
                    assert section.wait is not None
                    diags.append(Diagnostic(
                        "error",
                        f"{track.performer}: this cue runs from {cue.start:.3f} s to "
                        f"{busy:.3f} s, across the wait for trigger {section.wait.trigger!r} "
                        f"at {t:.3f} s (section {section.name!r}); the robots hold still while "
                        "the show waits: end the cue by then",
                        src.origin, src.path,
                    ))
    return diags
