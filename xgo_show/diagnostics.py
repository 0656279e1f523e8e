"""Where things came from and what is wrong with them: shared by loader, compiler and runtime."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from xgo_show.text import printable

__all__ = ["MAX_EACH_KIND", "Diagnostic", "Origin", "Severity", "at_most_each_kind", "once_each"]

Severity = Literal["error", "warning"]


@dataclass(frozen=True)
class Origin:
    """A place in a choreography file, and the cue it belongs to (for messages and transcripts)."""

    file: str
    line: int
    column: int
    cue: str = ""

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}:{self.column}"
        return f"{where} ({self.cue})" if self.cue else where


@dataclass(frozen=True)
class Diagnostic:
    """One problem found in a routine: an error fails validation, a warning does not."""

    severity: Severity
    message: str
    origin: Origin | None = None
    path: str = ""  # field path inside the document, e.g. "tracks.rex[3].to.body_z"
    unlisted: int = 0  # more problems of this kind, summed up in this one (at_most_each_kind)

    def format(self) -> str:
        """``file:line:col: severity: path: message``, one printable line (any control
        character from a file name or quoted text is written as an escape)."""
        o = self.origin
        where = f"{o.file}:{o.line}:{o.column}: " if o else ""
        path = f"{self.path}: " if self.path else ""
        return printable(f"{where}{self.severity}: {path}{self.message}")

    @property
    def is_error(self) -> bool:
        return self.severity == "error"

    @property
    def count(self) -> int:
        """The problems this diagnostic stands for: itself and those it sums up."""
        return 1 + self.unlisted


# A measurement in a message ("needs at least 0.59 s", "planned at 3.250 s"): the same problem
# met again in a later repeat differs only in these.
_MEASURE = re.compile(r"\d+\.\d+")


def once_each(diags: Iterable[Diagnostic]) -> list[Diagnostic]:
    """Each distinct problem once, at its place, in the order first met.

    A cue inside a repeat (or a phrase played by several tracks or several times, or an anchor
    merged into several cues) is checked and compiled each time it is used: the same problem
    at the same line:col, differing at most in its measurements, is one diagnostic: the first
    one met, with every path that reached it and the count appended.
    """
    groups: dict[tuple[object, ...], list[Diagnostic]] = {}
    for d in diags:
        o = d.origin
        key = (d.severity, o and (o.file, o.line, o.column), _MEASURE.sub("#", d.message))
        groups.setdefault(key, []).append(d)
    out = []
    for group in groups.values():
        first = group[0]
        plays = len(group)
        if plays > 1:
            shown = "" if all(d.message == first.message for d in group) else "; the first is shown"
            paths = list(dict.fromkeys(d.path for d in group if d.path))
            more = f" and {len(paths) - 3} more" if len(paths) > 3 else ""
            first = dataclasses.replace(
                first, path=", ".join(paths[:3]) + more, message=(
                    f"{first.message} (met {plays} times: this text is used again by a repeat, "
                    f"phrase, include or alias{shown})"))
        out.append(first)
    return out


#: Problems of one kind listed in full; more are summed up in one line. Thousands of the same
#: mistake (a generated file, a find-and-replace gone wrong) are fixed the same way, and a
#: screenful of them would hide every other kind.
MAX_EACH_KIND = 20

# What makes two messages the same kind: the text with names, quoted values and numbers taken
# out, up to the first ';' (a did-you-mean or a listing differs from name to name).
_NAMES = re.compile(r"'[^']*'|\"[^\"]*\"|-?\d+(?:\.\d+)?(?:e-?\d+)?|\b\w+_\w+\b")


def _kind(d: Diagnostic) -> tuple[str, str]:
    return d.severity, _NAMES.sub("#", d.message.split(";")[0])


def at_most_each_kind(diags: Iterable[Diagnostic], limit: int = MAX_EACH_KIND) -> list[Diagnostic]:
    """The first ``limit`` diagnostics of each kind (the same message but for names and
    numbers), in order; the rest of a kind become one diagnostic at the first one left out,
    saying how many more there are."""
    out: list[Diagnostic] = []
    counts: dict[tuple[str, str], int] = {}
    summary: dict[tuple[str, str], int] = {}  # kind -> index in out of its summary line
    for d in diags:
        kind = _kind(d)
        n = counts[kind] = counts.get(kind, 0) + 1
        if n <= limit:
            out.append(d)
        elif n == limit + 1:
            summary[kind] = len(out)
            out.append(d)
    for kind, i in summary.items():
        more = counts[kind] - limit
        if more > 1:
            out[i] = dataclasses.replace(out[i], unlisted=more - 1, message=(
                f"{out[i].message} (and {more - 1:,} more like it, not listed)"))
    return out
