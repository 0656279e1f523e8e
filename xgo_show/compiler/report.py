"""Plain-text views of a schedule: per-performer totals and a frame-by-frame transcript.

Both are deterministic (fixed-width numbers, times to the microsecond from integer microseconds),
so a transcript can be kept under version control and diffed in review.
"""

from __future__ import annotations

from dataclasses import dataclass

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, to_us
from xgo_show.compiler.state import link_use

__all__ = ["PerformerTotals", "totals", "totals_table", "transcript"]


@dataclass(frozen=True)
class PerformerTotals:
    """What one performer's part costs on its link."""

    name: str
    model: str
    frames: int
    bytes: int
    link_use: float  # fraction of the part's duration the link spends sending
    duration: float
    warnings: int


def _warnings_for(schedule: Schedule, performer: PerformerSchedule) -> int:
    prefix = f"tracks.{performer.name}"
    return sum(
        1
        for d in schedule.warnings
        if d.path == prefix or d.path.startswith((prefix + ".", prefix + "["))
    )


def totals(schedule: Schedule) -> list[PerformerTotals]:
    """One :class:`PerformerTotals` per performer, in schedule order."""
    return [
        PerformerTotals(
            name=p.name,
            model=p.model,
            frames=len(p.frames),
            bytes=p.total_bytes,
            link_use=link_use(p.link, p.frames, p.end),
            duration=p.end,
            warnings=_warnings_for(schedule, p),
        )
        for p in schedule.performers
    ]


def _us_text(seconds: float) -> str:
    us = to_us(seconds)
    return f"{us // 1_000_000}.{us % 1_000_000:06d}"


def totals_table(schedule: Schedule) -> str:
    """The totals as an aligned text table, with a header line."""
    rows = [("performer", "model", "frames", "bytes", "link use", "duration", "warnings")]
    for t in totals(schedule):
        rows.append((
            t.name, t.model, str(t.frames), str(t.bytes), f"{t.link_use * 100:.1f} %",
            f"{t.duration:.3f} s", str(t.warnings),
        ))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = []
    for row in rows:
        cells = [
            c.ljust(w) if i < 2 else c.rjust(w)
            for i, (c, w) in enumerate(zip(row, widths, strict=True))
        ]
        lines.append("  ".join(cells).rstrip())
    return "\n".join(lines) + "\n"


def transcript(schedule: Schedule) -> str:
    """Every frame of every performer in time order: time, performer, values, hex bytes.

    Frames at the same microsecond keep performer order, then schedule order.
    """
    entries = []
    for pi, p in enumerate(schedule.performers):
        for fi, f in enumerate(p.frames):
            entries.append((to_us(f.t), pi, fi, p.name, f))
    entries.sort(key=lambda e: (e[0], e[1], e[2]))
    width = max((len(p.name) for p in schedule.performers), default=0)
    lines = [
        f"{_us_text(f.t):>12}  {name:<{width}}  {f.label}  [{f.data.hex(' ')}]"
        for _, _, _, name, f in entries
    ]
    return "\n".join(lines) + ("\n" if lines else "")
