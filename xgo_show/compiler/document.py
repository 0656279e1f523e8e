"""The schedule document: a schedule file's JSON part, written and read with every check.

Both file versions (see :mod:`xgo_show.compiler.artifact`) hold the same document::

    {
     "format": "xgo-show-schedule",
     "version": int,
     "show": {"name": str, "source": str, "control_rate": float (Hz),
              "on_failure": "halt_all" | "continue", "battery_floor": int (%),
              "bpm": float | null, "beats_per_bar": int,
              "tempo_map": [[first bar, bpm, beats_per_bar], ...],
              "sections": [{"name": str, "start_us": int, "origin": int | null,
                            "wait": null | {"trigger": str, "timeout_us": int | null,
                                            "else": str}}, ...],
              "music": {"file": str, "path": str, "offset": float}  (optional)},
     "origins": [{"file": str, "line": int, "column": int, "cue": str}, ...],
     "warnings": [{"severity": "warning", "message": str, "origin": int | null,
                   "path": str}, ...],
     "performers": [
      {"name": str, "model": str, "port": str | null,
       "link": {"baud": int, "gap_us": int, "bits_per_byte": int},
       "end_us": int,
       "frames": ...}, ...]
    }

- Every time is an integer number of microseconds from show start (``*_us``): no float
  formatting, and a time read back is exactly the one written.
- ``origin`` fields index the ``origins`` table (first-use order), so a cue's file position is
  stored once, not once per frame; ``null`` means no origin.
- ``sections`` (optional: absent means none) are the show's named parts in time order; a
  ``wait`` holds the show at the section's start until its trigger (see
  :mod:`xgo_show.choreo.sections`; ``else`` is a section name, ``continue`` or ``end``).
- ``frames`` is what the file version makes of them: version 1 lists them in the JSON,
  version 2 counts them and stores them in binary columns after the document.

Reading checks every field's type and range, and every frame's bytes (:func:`frame_problem`);
anything wrong is an :class:`XgoShowError` naming the file and the field.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from xgo_show.choreo.music import Music
from xgo_show.choreo.sections import ELSE_KEYWORDS, Section, Wait
from xgo_show.compiler.schedule import (
    SCHEDULE_VERSION,
    PerformerSchedule,
    Schedule,
    ScheduledFrame,
    to_us,
)
from xgo_show.compiler.schedule_check import check_schedule
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.errors import ProtocolError, ScheduleError, XgoShowError
from xgo_show.families import get_family
from xgo_show.profiles.model import Link, Profile
from xgo_show.profiles.registry import get_profile

__all__ = [
    "FORMAT",
    "FramesReader",
    "OriginOf",
    "OriginRef",
    "Reader",
    "frame_problem",
    "read_document",
    "schedule_document",
    "xarm_frame_problem",
]

FORMAT = "xgo-show-schedule"

#: ``origin -> index`` into the document's origins table (``None`` for no origin)
OriginRef = Callable[[Origin | None], int | None]
#: ``origin field of an object -> Origin``, checked against the table
OriginOf = Callable[[Mapping[str, Any], str], Origin | None]


def schedule_document(
    schedule: Schedule, frames: Callable[[PerformerSchedule, OriginRef], object]
) -> dict[str, Any]:
    """The document of ``schedule``; ``frames(performer, ref)`` gives each performer's
    ``frames`` value (``ref`` files origins in the table)."""
    origins: list[Origin] = []
    index: dict[Origin, int] = {}

    def ref(origin: Origin | None) -> int | None:
        if origin is None:
            return None
        found = index.get(origin)
        if found is None:
            found = index[origin] = len(origins)
            origins.append(origin)
        return found

    warnings = [
        {"severity": d.severity, "message": d.message, "origin": ref(d.origin), "path": d.path}
        for d in schedule.warnings
    ]
    performers = [
        {
            "end_us": to_us(p.end),
            "frames": frames(p, ref),
            "link": {"baud": p.link.baud, "bits_per_byte": p.link.bits_per_byte,
                     "gap_us": to_us(p.link.gap)},
            "model": p.model,
            "name": p.name,
            "port": p.port,
        }
        for p in schedule.performers
    ]
    show: dict[str, object] = {
        "battery_floor": schedule.battery_floor,
        "beats_per_bar": schedule.beats_per_bar,
        "bpm": schedule.bpm,
        "control_rate": schedule.control_rate,
        "name": schedule.name,
        "on_failure": schedule.on_failure,
        "source": schedule.source,
        "tempo_map": [list(row) for row in schedule.tempo_map],
    }
    if schedule.music is not None:
        show["music"] = {"file": schedule.music.file, "path": schedule.music.path,
                         "offset": schedule.music.offset}
    if schedule.sections:
        show["sections"] = [
            {
                "name": sec.name,
                "start_us": to_us(sec.start),
                "origin": ref(sec.origin),
                "wait": None if sec.wait is None else {
                    "trigger": sec.wait.trigger,
                    "timeout_us": None if sec.wait.timeout is None else to_us(sec.wait.timeout),
                    "else": sec.wait.otherwise,
                },
            }
            for sec in schedule.sections
        ]
    return {
        "format": FORMAT,
        "origins": [{"column": o.column, "cue": o.cue, "file": o.file, "line": o.line}
                    for o in origins],
        "performers": performers,
        "show": show,
        "version": schedule.version,
        "warnings": warnings,
    }


class Reader:
    """Typed field access for one file's document; every failure names the file and field."""

    def __init__(self, name: str) -> None:
        self.name = name

    def fail(self, where: str, message: str) -> ScheduleError:
        return ScheduleError(f"{self.name}: {where}: {message}")

    def get(self, obj: Mapping[str, Any], key: str, kind: type | tuple[type, ...], where: str,
            *, optional: bool = False) -> Any:
        if key not in obj:
            raise self.fail(f"{where}.{key}" if where else key, "missing")
        value = obj[key]
        if value is None and optional:
            return None
        if (isinstance(value, bool) and kind is not bool) or not isinstance(value, kind):
            names = kind.__name__ if isinstance(kind, type) else " or ".join(
                k.__name__ for k in kind)
            raise self.fail(f"{where}.{key}" if where else key,
                            f"expected {names}, not {type(value).__name__}")
        return value

    def obj(self, value: Any, where: str) -> Mapping[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected an object, not {type(value).__name__}")
        return value

    def us(self, obj: Mapping[str, Any], key: str, where: str) -> float:
        value = self.get(obj, key, int, where)
        if value < 0:
            raise self.fail(f"{where}.{key}", "must not be negative")
        if value > 2**53:  # past any show (and past what a float holds exactly)
            raise self.fail(f"{where}.{key}", f"{value:.3g} us is far too large")
        return float(value) / 1_000_000


def _tempo_map(r: Reader, show: Mapping[str, Any]) -> tuple[tuple[int, float, int], ...]:
    """``show.tempo_map``: optional (files written before it existed have only ``bpm``)."""
    rows = show.get("tempo_map", [])
    if not isinstance(rows, list):
        raise r.fail("show.tempo_map", f"expected a list, not {type(rows).__name__}")
    out: list[tuple[int, float, int]] = []
    for i, row in enumerate(rows):
        where = f"show.tempo_map[{i}]"
        if (not isinstance(row, list) or len(row) != 3
                or any(isinstance(v, bool) for v in row)
                or not isinstance(row[0], int) or not isinstance(row[1], (int, float))
                or not isinstance(row[2], int)):
            raise r.fail(where, "expected [first bar, bpm, beats_per_bar]")
        out.append((row[0], float(row[1]), row[2]))
    return tuple(out)


def _sections(
    r: Reader, show: Mapping[str, Any], origin: Callable[[Mapping[str, Any], str], Origin | None]
) -> tuple[Section, ...]:
    """``show.sections``: optional (a show without sections, or a file from before them)."""
    rows = show.get("sections", [])
    if not isinstance(rows, list):
        raise r.fail("show.sections", f"expected a list, not {type(rows).__name__}")
    out: list[Section] = []
    for i, raw in enumerate(rows):
        where = f"show.sections[{i}]"
        row = r.obj(raw, where)
        start = r.us(row, "start_us", where)
        if out and start <= out[-1].start:
            raise r.fail(f"{where}.start_us", "sections must be in time order")
        wait = None
        wraw = r.get(row, "wait", dict, where, optional=True)
        if wraw is not None:
            ww = f"{where}.wait"
            timeout = None
            if wraw.get("timeout_us") is not None:
                timeout = r.us(wraw, "timeout_us", ww)
            wait = Wait(r.get(wraw, "trigger", str, ww), timeout, r.get(wraw, "else", str, ww))
        out.append(Section(r.get(row, "name", str, where), start, wait, origin(row, where)))
    names = {s.name for s in out}
    for i, sec in enumerate(out):
        target = sec.wait.otherwise if sec.wait is not None else None
        if target is not None and target not in names and target not in ELSE_KEYWORDS:
            raise r.fail(f"show.sections[{i}].wait.else", f"no section named {target!r}")
    return tuple(out)


# xArm commands that are framed but not interpreted by the typed parser (wire.xarm): their
# framing is checked, their values are not. By name: wire.xarm (16 dataclasses, a hundredth
# of a second to import) is imported when an xArm frame is checked, not by every command
# that writes or reads a schedule.
_UNINTERPRETED = frozenset({"BUS_SERVO_MORO_CTRL", "BUS_SERVO_INFO_WRITE", "BUS_SERVO_INFO_READ"})


def xarm_frame_problem(data: bytes) -> str | None:
    """Why ``data`` is not exactly one valid xArm request packet (None when it is)."""
    from xgo_show.wire import xarm as xarm_wire

    used, packet = xarm_wire.decode_one(data)
    if packet is None or used != len(data):
        return (f"not one valid xArm packet ({len(data)} bytes; expected 55 55, a length and a "
                "known command whose parameters fit it)")
    if packet.is_reply:
        return f"an xArm {packet.command.label} reply, not a request"
    if packet.command.name not in _UNINTERPRETED:
        try:
            xarm_wire.parse_request(packet)
        except ProtocolError as exc:
            return str(exc)
    return None


def frame_problem(profile: Profile, data: bytes) -> str | None:
    """Why ``data`` cannot be a frame of ``profile``'s schedule (None when it can), as its robot
    family says: an XGO frame must be one valid frame (checksum included); an xArm frame one
    request packet of a known command with values in range (:func:`xarm_frame_problem`)."""
    return get_family(profile).frame_problem(data)


#: ``(reader, performer object, its path, its name, its profile, the origins table, the
#: checked look-up of an object's origin field) -> frames``
FramesReader = Callable[
    [Reader, Mapping[str, Any], str, str, Profile, Sequence[Origin], OriginOf],
    list[ScheduledFrame],
]


def read_document(doc: object, name: str, frames: FramesReader) -> Schedule:
    """The schedule a document describes, each performer's frames read by ``frames``.

    ``name`` (the file) starts every error message. The format tag and version are the
    caller's to check (they decide how frames are stored).
    """
    r = Reader(name)
    doc = r.obj(doc, "the document")
    origins_raw = r.get(doc, "origins", list, "")
    origins: list[Origin] = []
    for i, raw in enumerate(origins_raw):
        where = f"origins[{i}]"
        o = r.obj(raw, where)
        origins.append(Origin(
            r.get(o, "file", str, where), r.get(o, "line", int, where),
            r.get(o, "column", int, where), r.get(o, "cue", str, where),
        ))

    def origin(obj: Mapping[str, Any], where: str) -> Origin | None:
        idx = r.get(obj, "origin", int, where, optional=True)
        if idx is None:
            return None
        if not 0 <= idx < len(origins):
            raise r.fail(f"{where}.origin", f"no origin #{idx} (the table has {len(origins)})")
        found: Origin = origins[idx]
        return found

    show = r.obj(r.get(doc, "show", dict, ""), "show")
    warnings: list[Diagnostic] = []
    for i, raw in enumerate(r.get(doc, "warnings", list, "")):
        where = f"warnings[{i}]"
        w = r.obj(raw, where)
        severity = r.get(w, "severity", str, where)
        if severity not in ("error", "warning"):
            raise r.fail(f"{where}.severity", f"unknown severity {severity!r}")
        warnings.append(Diagnostic(
            "error" if severity == "error" else "warning", r.get(w, "message", str, where),
            origin(w, where), r.get(w, "path", str, where),
        ))
    performers: list[PerformerSchedule] = []
    for i, raw in enumerate(r.get(doc, "performers", list, "")):
        where = f"performers[{i}]"
        p = r.obj(raw, where)
        model = r.get(p, "model", str, where)
        try:
            profile = get_profile(model)
        except XgoShowError as exc:
            raise r.fail(f"{where}.model", str(exc)) from exc
        link_raw = r.obj(r.get(p, "link", dict, where), f"{where}.link")
        baud = r.get(link_raw, "baud", int, f"{where}.link")
        if baud <= 0:
            raise r.fail(f"{where}.link.baud", "must be positive")
        link = Link(baud, r.us(link_raw, "gap_us", f"{where}.link"),
                    r.get(link_raw, "bits_per_byte", int, f"{where}.link"))
        perf_name = r.get(p, "name", str, where)
        performers.append(PerformerSchedule(
            name=perf_name, model=profile.model, link=link,
            frames=tuple(frames(r, p, where, perf_name, profile, origins, origin)),
            end=r.us(p, "end_us", where),
            port=r.get(p, "port", str, where, optional=True),
        ))
    on_failure = r.get(show, "on_failure", str, "show")
    if on_failure not in ("halt_all", "continue"):
        raise r.fail("show.on_failure", f"unknown policy {on_failure!r}")
    rate = r.get(show, "control_rate", (int, float), "show")
    if rate <= 0:
        raise r.fail("show.control_rate", "must be positive")
    battery_floor = r.get(show, "battery_floor", int, "show")
    if not 0 <= battery_floor <= 100:
        raise r.fail("show.battery_floor", f"{battery_floor} is not a percentage (0 to 100)")
    bpm = r.get(show, "bpm", (int, float), "show", optional=True)
    tempo_map = _tempo_map(r, show)
    sections = _sections(r, show, origin)
    music = None
    if show.get("music") is not None:
        m = r.obj(show["music"], "show.music")
        music = Music(r.get(m, "file", str, "show.music"), r.get(m, "path", str, "show.music"),
                      float(r.get(m, "offset", (int, float), "show.music")))
    schedule = Schedule(
        name=r.get(show, "name", str, "show"),
        source=r.get(show, "source", str, "show"),
        performers=tuple(performers),
        control_rate=float(rate),
        on_failure=on_failure,
        battery_floor=battery_floor,
        warnings=tuple(warnings),
        version=SCHEDULE_VERSION,
        bpm=None if bpm is None else float(bpm),
        beats_per_bar=r.get(show, "beats_per_bar", int, "show"),
        tempo_map=tempo_map,
        sections=sections,
        music=music,
    )
    check_schedule(schedule, name=name)
    return schedule
