"""Where things came from and what is wrong with them: shared by loader, compiler and runtime."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from xgo_show.text import printable

__all__ = ["Diagnostic", "Origin", "Severity", "merge_repeats"]

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


def merge_repeats(diags: list[Diagnostic]) -> list[Diagnostic]:
    """Say each finding once: diagnostics with the same severity, message and place (a phrase
    played by several tracks, or several times) become one naming every track's path."""
    merged: dict[tuple[object, ...], list[Diagnostic]] = {}
    for d in diags:
        o = d.origin
        key = (d.severity, d.message, o and (o.file, o.line, o.column))
        merged.setdefault(key, []).append(d)
    out = []
    for group in merged.values():
        paths = list(dict.fromkeys(d.path for d in group if d.path))
        out.append(Diagnostic(group[0].severity, group[0].message, group[0].origin,
                              ", ".join(paths)))
    return out
