"""Keep the well-formed parts of a routine that failed structural (pydantic) validation.

One malformed cue must not hide the semantic problems of every other cue: ``xgo-show
validate`` lists everything in one run. :func:`salvage_show` takes the parsed data, drops or
neutralises what pydantic rejected (a bad cue becomes ``{rest: 0}`` so that the list indices,
and so every ``file:line:col``, stay put; a bad timing field, or a field the cue does not
have, e.g. a misspelt ``duraton``, is dropped from its cue) and
validates again until the rest is a :class:`ShowFile`. What was lost is recorded, so the
resolver and the checks stay quiet about what they can no longer know (times after a broken
cue, phrases that failed to load, a tempo that did not parse).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

from pydantic import ValidationError

from xgo_show.choreo.model import ShowFile
from xgo_show.choreo.source import Loc
from xgo_show.choreo.validation import data_loc

__all__ = ["TIMING_FIELDS", "Salvage", "salvage_show"]

# Cue fields that only say when or how fast: a cue without them still names what it does.
TIMING_FIELDS = frozenset({"at", "after", "duration", "beats", "bars", "fade", "interrupt",
                           "limits"})
_LENGTH_FIELDS = frozenset({"duration", "beats", "bars"})
_NEUTRAL: dict[str, object] = {"rest": 0}  # a cue that does nothing and takes no time
_MAX_ROUNDS = 64  # each round goes one level deeper into nested repeats at most


@dataclass
class Salvage:
    """A routine's well-formed remainder and what was taken out of it."""

    show: ShowFile
    tempo_broken: bool = False  # bar/beat times cannot be placed: say nothing about them
    phrases_incomplete: bool = False  # an include list or the phrases mapping was dropped
    broken_phrases: set[str] = field(default_factory=set)  # phrases dropped for errors
    untimed: set[str] = field(default_factory=set)  # performers whose track lost timing
    # Cues (their places in the routine) whose duration, beats or bars was dropped: the
    # resolver does not also say they need a length.
    lost_length: set[Loc] = field(default_factory=set)


def salvage_show(data: dict[str, object]) -> Salvage | None:
    """The well-formed part of ``data`` (a routine mapping that failed validation), or None
    when nothing checkable is left (no valid performers or tracks)."""
    work = copy.deepcopy(data)
    info = Salvage(show=ShowFile.model_construct())
    for _ in range(_MAX_ROUNDS):
        try:
            info.show = ShowFile.model_validate(work)
        except ValidationError as exc:
            found = [(data_loc(work, e["loc"]), e["type"]) for e in exc.errors(include_url=False)]
        else:
            return info
        progress = False
        for loc, kind in found:
            progress = _prune(work, loc, info, unknown=kind == "extra_forbidden") or progress
        if not progress:
            return None
    return None


def _pop(mapping: object, key: str | int | None) -> bool:
    """Delete ``mapping[key]`` when ``mapping`` is a mapping that holds it; whether it did."""
    if isinstance(mapping, dict) and key in mapping:
        del mapping[key]
        return True
    return False


def _prune(work: dict[str, object], loc: Loc, info: Salvage, *, unknown: bool = False) -> bool:
    """Remove what the error at ``loc`` is about (``unknown``: a field that is not allowed
    there); whether anything changed."""
    if not loc:
        return False
    head = loc[0]
    sub = work.get(head) if isinstance(head, str) else None
    entry = loc[1] if len(loc) >= 2 else None  # which setting, performer or phrase
    if head == "show":
        if work.get("show") == "?":
            return False
        work["show"] = "?"  # the name is only shown in reports, never when there are errors
        return True
    if head == "tempo":
        info.tempo_broken = True
        return _pop(work, "tempo")
    if head == "settings":
        return _pop(sub, entry) or _pop(work, "settings")
    if head == "performers":
        if not _pop(sub, entry):
            return False  # no performers, nothing to check the tracks against
        _pop(work.get("tracks"), entry)  # its robot is unknown: its cues cannot be checked
        return True
    if head == "include":
        info.phrases_incomplete = True
        return _pop(work, "include")
    if head == "phrases":
        if _pop(sub, entry):
            info.broken_phrases.add(str(entry))
            return True
        info.phrases_incomplete = True
        return _pop(work, "phrases")
    if head == "tracks":
        return _prune_track(work, loc, info, unknown)
    if head == "sections":
        # A broken wait loses only itself (its section still starts where it says, so the
        # other sections and their waits are still checked); anything else, all sections.
        section = sub[entry] if isinstance(sub, list) and isinstance(entry, int) else None
        if len(loc) > 2 and loc[2] == "wait" and _pop(section, "wait"):
            return True
        return _pop(work, "sections")
    return _pop(work, head)  # an unknown top-level field


def _prune_track(work: dict[str, object], loc: Loc, info: Salvage, unknown: bool) -> bool:
    tracks = work.get("tracks")
    if len(loc) < 2 or not isinstance(tracks, dict) or loc[1] not in tracks:
        return False
    name = loc[1]
    track = tracks[name]
    if len(loc) == 2 or not isinstance(track, list) or not isinstance(loc[2], int):
        del tracks[name]
        return True
    # The innermost cue the error is in: a repeat's cues are cues too.
    parent: list[object] = track
    cue_loc: Loc = loc[:3]
    k = 3
    while True:
        at = int(cue_loc[-1])
        cue = parent[at] if 0 <= at < len(parent) else None
        if not (isinstance(cue, dict) and k + 1 < len(loc) and loc[k] == "cues"
                and isinstance(loc[k + 1], int) and isinstance(cue.get("cues"), list)):
            break
        parent = cue["cues"]
        cue_loc = loc[:k + 2]
        k += 2
    index = int(cue_loc[-1])
    if not 0 <= index < len(parent):
        return False
    cue = parent[index]
    info.untimed.add(str(name))
    what = loc[len(cue_loc)] if len(loc) > len(cue_loc) else None
    if isinstance(cue, dict) and what in TIMING_FIELDS and what in cue:
        del cue[what]
        if what in _LENGTH_FIELDS:
            info.lost_length.add(cue_loc)
        return True
    if unknown and isinstance(cue, dict) and len(loc) == len(cue_loc) + 1 and what in cue:
        # A field the cue does not have: the rest of the cue is still checked. It may have
        # been meant as its length ('duraton'), so a missing length is not reported too.
        del cue[what]
        info.lost_length.add(cue_loc)
        return True
    if cue == _NEUTRAL:
        return False
    parent[index] = dict(_NEUTRAL)
    return True
