"""The interactive HTML timeline: one self-contained file (no network, no other file) to zoom
and hover.

The page draws the same :class:`~xgo_show.compiler.timeline.Timeline` as the PNG plot, as SVG
drawn by a small inline script: bar numbers and sections on top, per performer one lane per
unit, a lane of cues and the LED strips. Wheel or the buttons zoom around the pointer, drag
pans, a double click shows the whole show again. Hovering a cue, a colour or a curve shows the
cue in effect there with its source ``file:line``, the time and the bar/beat.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

from xgo_show.compiler.schedule import Schedule
from xgo_show.compiler.timeline import Event, PerformerTimeline, Timeline, build_timeline
from xgo_show.errors import FileAccessError

__all__ = ["timeline_data", "timeline_html", "write_timeline_html"]

_PAGE = Path(__file__).with_name("timeline_page.html")


def _r(value: float) -> float:
    """Times and values to 0.1 ms / 3 decimals: a smaller file, no visible difference."""
    return round(value, 4)


def timeline_data(timeline: Timeline) -> dict[str, Any]:
    """The JSON the page draws: short keys, one table of cue sources shared by every item."""
    sources: list[list[str]] = []
    index: dict[tuple[str, str], int] = {}

    def source(cue: str, where: str) -> int:
        if not cue and not where:
            return -1
        key = (cue, where)
        if key not in index:
            index[key] = len(sources)
            sources.append([cue, where])
        return index[key]

    def events(items: tuple[Event, ...]) -> list[list[Any]]:
        return [[_r(e.start), _r(e.end), e.kind, e.text, source(e.cue, e.source), e.lane,
                 list(e.colour) if e.colour else None] for e in items]

    def performer(p: PerformerTimeline) -> dict[str, Any]:
        return {
            "name": p.name, "title": p.title,
            "lanes": [{"unit": lane.unit, "curves": [{
                "name": c.name, "t": [_r(t) for t in c.times],
                "v": [_r(v) for v in c.values], "ramp": c.ramp, "known": _r(c.known_from),
                "src": [source(cue, where) for cue, where in c.sources],
            } for c in lane.curves]} for lane in p.lanes],
            "events": events(p.events),
            "colours": events(p.colours),
        }

    return {
        "name": timeline.name, "duration": _r(timeline.duration), "tempo": timeline.tempo_text,
        "bars": [[_r(t), n] for t, n in timeline.bars], "beats": [_r(t) for t in timeline.beats],
        "sections": [[n, _r(s), _r(e)] for n, s, e in timeline.sections],
        "performers": [performer(p) for p in timeline.performers],
        "sources": sources,
    }


def timeline_html(timeline: Timeline) -> str:
    """The whole page as text: the page template with the timeline's data put in."""
    data = json.dumps(timeline_data(timeline), separators=(",", ":"))
    # Inside <script>, "</" could end the element: JSON allows writing it "<\/".
    data = data.replace("</", "<\\/")
    page = _PAGE.read_text(encoding="utf-8")
    return (page.replace("__TITLE__", html.escape(timeline.name))
                .replace("__DATA__", data))


def write_timeline_html(schedule: Schedule, path: str | Path) -> Path:
    """Write ``schedule``'s interactive timeline to ``path``; returns the path."""
    target = Path(path)
    try:
        target.write_text(timeline_html(build_timeline(schedule)), encoding="utf-8")
    except OSError as exc:
        raise FileAccessError(f"cannot write timeline {target}: {exc.strerror or exc}") from exc
    return target
