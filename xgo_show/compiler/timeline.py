"""A compiled schedule read back as a timeline a choreographer can read: curves, cues, music grid.

:func:`build_timeline` decodes every performer's frames (what goes on the wire, not what the
routine asked for) into value curves grouped by physical unit, preset actions and settings as
labelled events carrying their source ``file:line``, LED colour runs, and the show's bar/beat
grid and sections. Both the PNG plot (:mod:`xgo_show.compiler.plot`) and the HTML timeline
(:mod:`xgo_show.compiler.timeline_html`) draw from it, so they always agree.

Curves start at show start: an XGO register from its documented initial value, an xArm servo
from where its first move goes (the arm's position before the show is not known), drawn as
``known=False`` up to that move.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from xgo_show.compiler.layout import ACTION_REGISTER
from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.compiler.state import describe_frame, format_value
from xgo_show.diagnostics import Origin
from xgo_show.families import get_family
from xgo_show.profiles.model import Encoding, Profile
from xgo_show.profiles.registry import get_profile
from xgo_show.profiles.xarm import SERVO_NAMES, position_to_degrees

__all__ = [
    "Curve",
    "Event",
    "Lane",
    "PerformerTimeline",
    "Timeline",
    "build_timeline",
    "xarm_timeline",
    "xgo_timeline",
]

_MAX_BEAT_LINES = 600  # beyond this many beats, the grid shows bars only


@dataclass(frozen=True)
class Curve:
    """One register's (or servo's) value over the show, as corner points from t = 0.

    ``ramp`` False: the value steps at each point (sampled XGO registers); True: it moves in a
    straight line between points (an xArm servo over its ServoMove time). ``known_from``: before
    this time the value is an assumption (an xArm servo before its first move). ``sources``:
    per point, the cue that set it as (cue, "file:line"); ("", "") for the initial value.
    """

    name: str
    unit: str
    times: tuple[float, ...]
    values: tuple[float, ...]
    ramp: bool = False
    known_from: float = 0.0
    sources: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Event:
    """Something that happens at ``start`` and lasts until ``end`` (= start for an instant)."""

    start: float
    end: float
    kind: str  # "action", "setting", "move" (an xArm ServoMove) or "colour"
    text: str
    source: str = ""  # "file:line" of the cue, "" when unknown
    cue: str = ""  # the cue as messages name it, e.g. "rex: action dance (phrase intro)"
    lane: str = ""  # colour events: the LED register
    colour: tuple[int, int, int] | None = None


@dataclass(frozen=True)
class Lane:
    """The curves sharing one physical unit: drawn on one axis."""

    unit: str
    curves: tuple[Curve, ...]


@dataclass(frozen=True)
class PerformerTimeline:
    name: str
    model: str
    title: str
    lanes: tuple[Lane, ...]
    events: tuple[Event, ...]  # actions and settings, by start
    colours: tuple[Event, ...]  # LED colour runs, by register then start


@dataclass(frozen=True)
class Timeline:
    """The whole show: performers, and the music grid when the show has a tempo."""

    name: str
    duration: float
    performers: tuple[PerformerTimeline, ...]
    bars: tuple[tuple[float, int], ...] = ()  # (seconds, bar number) of each bar line
    beats: tuple[float, ...] = ()  # seconds of each beat that is not a bar line
    sections: tuple[tuple[str, float, float], ...] = ()  # (name, start, end)
    tempo_text: str = ""  # e.g. "120 bpm, 4/4"
    notes: tuple[str, ...] = field(default=())


def _source(origin: Origin | None) -> tuple[str, str]:
    """(``file:line``, cue) of a frame's origin."""
    if origin is None:
        return "", ""
    return f"{origin.file}:{origin.line}", origin.cue


_NONE = ("", "")


def build_timeline(schedule: Schedule) -> Timeline:
    """Read ``schedule`` back into a :class:`Timeline` (pure: no drawing, no files)."""
    end = max(schedule.duration, 1e-3)
    performers = tuple(
        get_family(profile).timeline(profile, p, end)
        for p, profile in ((p, get_profile(p.model)) for p in schedule.performers)
    )
    bars: list[tuple[float, int]] = []
    beats: list[float] = []
    tempo = schedule.tempo()
    tempo_text = ""
    if tempo is not None:
        first = tempo.segments[0]
        tempo_text = f"{first.bpm:g} bpm, {first.beats_per_bar}/4"
        if len(tempo.segments) > 1:
            tempo_text += f" (+{len(tempo.segments) - 1} tempo change(s))"
        total = tempo.beats(end)
        show_beats = total <= _MAX_BEAT_LINES
        b = 0
        while b <= total + 1e-9:
            t = tempo.seconds(b)
            bar, beat = tempo.bar_beat(t)
            if abs(beat - 1.0) < 1e-6:
                bars.append((t, bar))
            elif show_beats:
                beats.append(t)
            b += 1
    starts = [s.start for s in schedule.sections]
    sections = tuple(
        (s.name, s.start, starts[i + 1] if i + 1 < len(starts) else end)
        for i, s in enumerate(schedule.sections)
    )
    return Timeline(schedule.name, end, performers, tuple(bars), tuple(beats), sections,
                    tempo_text)


def xgo_timeline(profile: Profile, performer: PerformerSchedule, end: float) -> PerformerTimeline:
    """An XGO performer's curves (by unit), actions, settings and LED colour runs."""
    points: dict[str, list[tuple[float, float, tuple[str, str]]]] = {}
    events: list[Event] = []
    colours: list[Event] = []
    open_colour: dict[str, tuple[float, tuple[int, int, int], Origin | None]] = {}
    encodings = {r.name: r.encoding for r in profile.registers}
    for frame in performer.frames:
        source, cue = _source(frame.origin)
        for name, value in describe_frame(profile, frame.data):
            if name == ACTION_REGISTER:
                text = _action_text(profile, value)
                events.append(Event(frame.t, frame.t + frame.duration, "action", text,
                                    source, cue))
            elif encodings.get(name) is Encoding.RGB and isinstance(value, tuple):
                rgb = (int(value[0]), int(value[1]), int(value[2]))
                previous = open_colour.get(name)
                if previous is not None and previous[1] == rgb:
                    continue  # a resend of the colour already shown
                if previous is not None:
                    colours.append(_colour_run(name, previous, frame.t))
                open_colour[name] = (frame.t, rgb, frame.origin)
            elif isinstance(value, float):
                points.setdefault(name, []).append((frame.t, value, (cue, source)))
            else:
                text = f"{name}={format_value(profile, name, value)}"
                events.append(Event(frame.t, frame.t, "setting", text, source, cue))
    for name, run in open_colour.items():
        colours.append(_colour_run(name, run, end))
    curves: dict[str, list[Curve]] = {}
    for name, pts in points.items():
        reg = profile.register(name)
        initial = reg.decode_value(reg.initial) if reg.initial is not None else None
        first = float(initial) if isinstance(initial, float) else pts[0][1]
        times = [0.0, *(p[0] for p in pts), end]
        values = [first, *(p[1] for p in pts), pts[-1][1]]
        if min(values) == max(values):
            continue  # never changes (a register only re-sent to bridge a gap)
        unit = reg.unit or "value"
        curves.setdefault(unit, []).append(Curve(
            name, unit, tuple(times), tuple(values),
            known_from=0.0 if isinstance(initial, float) else pts[0][0],
            sources=(_NONE, *(p[2] for p in pts), pts[-1][2]),
        ))
    lanes = _lanes(profile, curves)
    colours.sort(key=lambda e: (e.lane, e.start))
    return PerformerTimeline(performer.name, performer.model, profile.title, lanes,
                             tuple(sorted(events, key=lambda e: e.start)), tuple(colours))


def _lanes(profile: Profile, curves: dict[str, list[Curve]]) -> tuple[Lane, ...]:
    """Lanes in the order of the first register of each unit; curves by register address."""
    address = {r.name: r.address for r in profile.registers}
    ordered = sorted(curves.items(), key=lambda kv: min(address[c.name] for c in kv[1]))
    return tuple(
        Lane(unit, tuple(sorted(group, key=lambda c: address[c.name])))
        for unit, group in ordered
    )


def _action_text(profile: Profile, value: object) -> str:
    for act in profile.actions:
        if act.id == value:
            return f"{act.name} (action {act.id})"
    return f"action {value}"


def _colour_run(
    name: str, run: tuple[float, tuple[int, int, int], Origin | None], stop: float
) -> Event:
    start, rgb, origin = run
    source, cue = _source(origin)
    text = f"{name} #{rgb[0]:02X}{rgb[1]:02X}{rgb[2]:02X}"
    return Event(start, stop, "colour", text, source, cue, lane=name, colour=rgb)


def xarm_timeline(
    profile: Profile, performer: PerformerSchedule, end: float
) -> PerformerTimeline:
    """An xArm performer: each servo's angle, named, ramping over each ServoMove."""
    tracks: dict[int, list[tuple[float, float, tuple[str, str]]]] = {}
    events: list[Event] = []
    for frame in performer.frames:
        fields = dict(describe_frame(profile, frame.data))
        move = float(fields.pop("time_ms", 0)) / 1000  # type: ignore[arg-type]
        source, cue = _source(frame.origin)
        moved = []
        for key, pos in fields.items():
            servo = int(key.removeprefix("servo_"))
            degrees = position_to_degrees(int(pos))  # type: ignore[call-overload]
            pts = tracks.setdefault(servo, [])
            if pts:
                pts.append((frame.t, pts[-1][1], (cue, source)))
            pts.append((frame.t + move, degrees, (cue, source)))
            moved.append(_servo_name(servo))
        events.append(Event(frame.t, frame.t + move, "move", "move " + ", ".join(moved),
                            source, cue))
    curves = []
    for servo in sorted(tracks):
        pts = tracks[servo]
        known = pts[0][0]
        times = [0.0, *(p[0] for p in pts), end]
        values = [pts[0][1], *(p[1] for p in pts), pts[-1][1]]
        curves.append(Curve(_servo_name(servo), "deg", tuple(times), tuple(values), ramp=True,
                            known_from=known, sources=(_NONE, *(p[2] for p in pts), _NONE)))
    lanes = (Lane("deg", tuple(curves)),) if curves else ()
    return PerformerTimeline(performer.name, performer.model, profile.title, lanes,
                             tuple(events), ())


def _servo_name(servo: int) -> str:
    name = SERVO_NAMES.get(servo)
    return f"{servo} {name}" if name else f"servo {servo}"
