"""What a schedule must satisfy to be run: the semantic checks of a schedule from outside.

A schedule read from a file (hand-edited, shared, or received by a relay) has the right types
once the artifact reader is done with it, but can still describe something impossible: a
negative tempo, a NaN control rate, two entries for one performer, a frame after the end, or a
label that would clear the operator's terminal. :func:`check_schedule` checks a typed
:class:`Schedule` once, whatever encoding it was read from, so every command (and the relay)
refuses the same things with the same one-line messages.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from xgo_show.choreo.timebase import Segment, TempoMap
from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.errors import ScheduleError
from xgo_show.limits import (
    MAX_BARS,
    MAX_BEATS_PER_BAR,
    MAX_BPM,
    MAX_CONTROL_RATE,
    MAX_MUSIC_OFFSET,
    MAX_PERFORMERS,
    MAX_SHOW_SECONDS,
    MIN_BPM,
    MIN_CONTROL_RATE,
    MIN_MUSIC_OFFSET,
)
from xgo_show.text import control_characters

__all__ = [
    "MAX_BARS",
    "MAX_BAUD",
    "MAX_CONTROL_RATE",
    "MAX_FRAME_BYTES",
    "MAX_PERFORMERS",
    "MAX_SHOW_SECONDS",
    "check_schedule",
    "schedule_problems",
]

#: The fastest serial link any profile uses is 115200 baud; 10 Mbaud leaves room for others.
MAX_BAUD = 10_000_000
#: The largest frame either protocol sends is some 60 bytes.
MAX_FRAME_BYTES = 1024
# Rates, tempi, bars and offsets: the same ranges as a routine's (xgo_show.limits).
_NAME_CHARS = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-")


def _finite(value: float, low: float, high: float) -> bool:
    return math.isfinite(value) and low <= value <= high


def _text(where: str, value: str) -> Iterator[str]:
    bad = control_characters(value)
    if bad is not None:
        yield f"{where}: holds the control character {bad} (text must be printable)"


def _tempo(s: Schedule) -> Iterator[str]:
    if s.bpm is not None and not _finite(s.bpm, MIN_BPM, MAX_BPM):
        yield f"show.bpm: {s.bpm!r} is not a tempo ({MIN_BPM:g} to {MAX_BPM:g} bpm)"
    if not 1 <= s.beats_per_bar <= MAX_BEATS_PER_BAR:
        yield (f"show.beats_per_bar: {s.beats_per_bar} is not a meter "
               f"(1 to {MAX_BEATS_PER_BAR} beats per bar)")
    for i, (bar, bpm, per_bar) in enumerate(s.tempo_map):
        where = f"show.tempo_map[{i}]"
        if not 1 <= bar <= MAX_BARS:
            yield f"{where}: bar {bar} is outside 1..{MAX_BARS:,}"
            return
        if not _finite(bpm, MIN_BPM, MAX_BPM):
            yield f"{where}: bpm {bpm!r} is not a tempo ({MIN_BPM:g} to {MAX_BPM:g} bpm)"
            return
        if not 1 <= per_bar <= MAX_BEATS_PER_BAR:
            yield f"{where}: {per_bar} beats per bar is not a meter (1 to {MAX_BEATS_PER_BAR})"
            return
    if s.tempo_map:
        try:
            TempoMap([Segment(*row) for row in s.tempo_map])
        except ValueError as exc:
            yield f"show.tempo_map: {exc}"


def _performer(i: int, p: PerformerSchedule) -> Iterator[str]:
    where = f"performers[{i}]"
    if not p.name or not set(p.name) <= _NAME_CHARS or p.name[0] in "0123456789-":
        yield (f"{where}.name: {p.name!r} is not a performer name (letters, digits, '_' and "
               "'-', starting with a letter or '_')")
    if p.port is not None:
        yield from _text(f"{where}.port", p.port)
    link = p.link
    if not 1 <= link.baud <= MAX_BAUD:
        yield f"{where}.link.baud: {link.baud} is outside 1..{MAX_BAUD:,}"
    if not 5 <= link.bits_per_byte <= 16:
        yield f"{where}.link.bits_per_byte: {link.bits_per_byte} is outside 5..16"
    if not _finite(link.gap, 0.0, 1.0):
        yield f"{where}.link.gap_us: {link.gap * 1e6:.0f} us is outside 0..1 s"
    if not _finite(p.end, 0.0, MAX_SHOW_SECONDS):
        yield f"{where}.end_us: {p.end:.6f} s is outside 0..{MAX_SHOW_SECONDS:.0f} s"
        return
    last = 0.0
    for j, f in enumerate(p.frames):
        fw = f"{where}.frames[{j}]"
        if not _finite(f.t, last, p.end):
            if not math.isfinite(f.t) or f.t < last:
                yield f"{fw}.t_us: frames must be in time order from 0 (at {f.t:.6f} s)"
            else:
                yield (f"{fw}.t_us: the frame at {f.t:.6f} s is after the performer's end "
                       f"({p.end:.6f} s)")
            return
        last = f.t
        if not _finite(f.duration, 0.0, MAX_SHOW_SECONDS):
            yield f"{fw}.duration_us: {f.duration:.6f} s is outside 0..{MAX_SHOW_SECONDS:.0f} s"
            return
        if not 1 <= len(f.data) <= MAX_FRAME_BYTES:
            yield f"{fw}.hex: {len(f.data)} bytes (a frame is 1 to {MAX_FRAME_BYTES} bytes)"
            return


def schedule_problems(schedule: Schedule) -> list[str]:
    """Every reason ``schedule`` cannot be run, as ``field: problem`` texts (empty: fine)."""
    s = schedule
    out: list[str] = []
    out += _text("show.name", s.name)
    out += _text("show.source", s.source)
    if not _finite(s.control_rate, MIN_CONTROL_RATE, MAX_CONTROL_RATE):
        out.append(f"show.control_rate: {s.control_rate!r} Hz is outside "
                   f"{MIN_CONTROL_RATE:g}..{MAX_CONTROL_RATE:g}")
    if s.on_failure not in ("halt_all", "continue"):
        out.append(f"show.on_failure: unknown policy {s.on_failure!r}")
    if not 0 <= s.battery_floor <= 100:
        out.append(f"show.battery_floor: {s.battery_floor} is not a percentage (0 to 100)")
    out += _tempo(s)
    if not s.performers:
        out.append("performers: the schedule has no performer")
    if len(s.performers) > MAX_PERFORMERS:
        out.append(f"performers: {len(s.performers)} performers; a show runs at most "
                   f"{MAX_PERFORMERS}")
    seen: dict[str, int] = {}
    for i, p in enumerate(s.performers):
        if p.name in seen:
            out.append(f"performers[{i}].name: performer {p.name!r} again (first at "
                       f"performers[{seen[p.name]}]): one entry per performer")
        seen.setdefault(p.name, i)
        out += _performer(i, p)
    if s.music is not None:
        out += _text("show.music.file", s.music.file)
        out += _text("show.music.path", s.music.path)
        if not _finite(s.music.offset, MIN_MUSIC_OFFSET, MAX_MUSIC_OFFSET):
            out.append(f"show.music.offset: {s.music.offset!r} s is outside "
                       f"{MIN_MUSIC_OFFSET:.0f}..{MAX_MUSIC_OFFSET:.0f} s")
    for k, sec in enumerate(s.sections):
        out += _text(f"show.sections[{k}].name", sec.name)
        if not _finite(sec.start, 0.0, MAX_SHOW_SECONDS):
            out.append(f"show.sections[{k}].start_us: {sec.start:.6f} s is outside "
                       f"0..{MAX_SHOW_SECONDS:.0f} s")
        if sec.wait is not None:
            out += _text(f"show.sections[{k}].wait.trigger", sec.wait.trigger)
            out += _text(f"show.sections[{k}].wait.else", sec.wait.otherwise)
            if sec.wait.timeout is not None and not _finite(sec.wait.timeout, 0.0,
                                                            MAX_SHOW_SECONDS):
                out.append(f"show.sections[{k}].wait.timeout_us: {sec.wait.timeout:.6f} s is "
                           f"outside 0..{MAX_SHOW_SECONDS:.0f} s")
    origins = {f.origin for p in s.performers for f in p.frames if f.origin is not None}
    origins |= {sec.origin for sec in s.sections if sec.origin is not None}
    origins |= {d.origin for d in s.warnings if d.origin is not None}
    for o in sorted(origins, key=lambda o: (o.file, o.line, o.column, o.cue)):
        if o.line < 0 or o.column < 0:  # 0:0 is a cue made in Python, not read from a file
            out.append(f"origins: {o.file}:{o.line}:{o.column} is not a place in a file "
                       "(lines and columns count from 1)")
        out += _text("origins.file", o.file)
        out += _text("origins.cue", o.cue)
    for k, d in enumerate(s.warnings):
        out += _text(f"warnings[{k}].message", d.message)
        out += _text(f"warnings[{k}].path", d.path)
    return out


def check_schedule(schedule: Schedule, *, name: str = "<schedule>") -> None:
    """Raise :class:`ScheduleError` (``name: field: problem``, and how many more) when
    ``schedule`` cannot be run; see :func:`schedule_problems`."""
    problems = schedule_problems(schedule)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise ScheduleError(f"{name}: {problems[0]}{more}")
