"""Routines a behaviour builds in memory: one phrase of a routine, or one ``set:``/``led:`` cue.

Each is a routine document (show, performers, tracks) checked and compiled exactly as a file
is (:func:`~xgo_show.choreo.loader.check_document`), so a phrase or a setting a robot cannot
take is an error when the behaviour loads. A phrase's document keeps its routine file's
positions: an error inside the phrase's cues points at its line there.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from xgo_show.choreo.source import Document, read_yaml
from xgo_show.compiler.schedule import Schedule
from xgo_show.diagnostics import Diagnostic
from xgo_show.errors import XgoShowError

__all__ = ["compile_cue", "compile_phrase"]

# What a phrase played on its own leaves out of its routine: the tracks (replaced), and what
# is timed against them (sections, the soundtrack).
_DROPPED = ("tracks", "sections", "music")


def compile_phrase(
    routine: Path, phrase: str, args: Mapping[str, Any] | None, performers: tuple[str, ...]
) -> tuple[Schedule | None, list[str]]:
    """Phrase ``phrase`` of the routine file ``routine`` as a routine of its own for
    ``performers`` (with parameter values ``args``): the schedule, or the problems found."""
    doc, diags = read_yaml(routine, str(routine))
    if diags or not isinstance(doc.data, dict):
        return None, [d.format() for d in diags] or [f"{routine}: not a routine"]
    phrases = doc.data.get("phrases")
    if not isinstance(phrases, dict) or phrase not in phrases:
        known = ", ".join(phrases) if isinstance(phrases, dict) and phrases else "none"
        return None, [f"routine has no phrase {phrase!r} (its phrases: {known})"]
    block: dict[str, Any] = {"phrase": phrase}
    if args:
        block["with"] = dict(args)
    data = {k: v for k, v in doc.data.items() if k not in _DROPPED}
    data["tracks"] = {p: [block] for p in performers}
    schedule, diags, error = _compile(Document(doc.file, data, doc.marks, doc.key_marks))
    return schedule, [d.format() for d in diags] + error


def compile_cue(
    file: str, kind: str, value: Mapping[str, Any], models: Mapping[str, str]
) -> tuple[Schedule | None, list[str]]:
    """One ``kind`` cue (``set`` or ``led``) for each performer of ``models`` (name ->
    model), as a routine: the schedule, or the problems found."""
    data = {
        "show": f"{kind} cue",
        "performers": {p: {"model": m} for p, m in models.items()},
        "tracks": {p: [{kind: dict(value)}] for p in models},
    }
    schedule, diags, error = _compile(Document(file, data))
    out = []
    for d in diags:  # "tracks.rex[0].led.led9" -> "rex: led.led9" (the cue is the action)
        performer, _, rest = d.path.removeprefix("tracks.").partition("[0].")
        out.append(f"{performer}: {rest}: {d.message}" if rest else d.message)
    return schedule, out + error


def _compile(doc: Document) -> tuple[Schedule | None, list[Diagnostic], list[str]]:
    """The schedule, or the loader's errors, or the compiler's (one line)."""
    from xgo_show.choreo.loader import check_document
    from xgo_show.compiler import compile_show

    show, diags = check_document(doc)
    if show is None:
        return None, [d for d in diags if d.is_error], []
    try:
        return compile_show(show), [], []
    except XgoShowError as exc:
        return None, [], [" ".join(str(exc).split())]
