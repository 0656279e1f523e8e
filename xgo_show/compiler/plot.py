"""Draw a schedule as a PNG a choreographer can read: the music grid, sections, one axis per unit.

From the top: a header with the section names and bar numbers; then per performer one axis per
physical unit (mm, deg, m/s, ... each register a line, an xArm's servos by name), a lane of
preset actions and settings, and a strip per LED. Bar lines (and beat lines, fainter) run
through every axis. Text labels are put in rows so that none overprints another. Values come
from :func:`xgo_show.compiler.timeline.build_timeline`: what goes on the wire, from show start.
Needs matplotlib (the optional ``plot`` extra), imported only when a plot is drawn.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from xgo_show.compiler.schedule import Schedule
from xgo_show.compiler.timeline import Event, PerformerTimeline, Timeline, build_timeline
from xgo_show.errors import PlotError

__all__ = ["plot_schedule", "timeline_figure"]

_WIDTH = 14.0  # inches
_LEFT, _RIGHT = 0.07, 0.83  # axes span; the legends sit right of the axes
_CURVE_H, _ROW_H, _STRIP_H, _HEADER_H, _GAP_H = 1.3, 0.2, 0.18, 0.45, 0.35  # inches
_TITLE_H = 0.75  # inches above the first axes: the title, and the bar numbers under it
_FOOT_H = 0.5  # inches under the last axes: the time axis' numbers and label
_FONT = 7.0  # points, every label
_HEADER_FONT = _FONT + 1  # points, the section names (bold)
_PAD = 4.0  # points of free space kept after a label


def _pyplot() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise PlotError(
            "plotting needs matplotlib: pip install 'xgo-show[plot]' (or pip install matplotlib)"
        ) from exc
    return plt


def plot_schedule(schedule: Schedule, path: str | Path) -> Path:
    """Draw ``schedule`` into a PNG at ``path``; returns the path."""
    plt = _pyplot()
    fig = timeline_figure(build_timeline(schedule))
    target = Path(path)
    try:
        fig.savefig(target, dpi=110)
    except OSError as exc:
        raise PlotError(f"cannot write plot {target}: {exc.strerror or exc}") from exc
    finally:
        plt.close(fig)
    return target


@functools.lru_cache(maxsize=4096)
def _text_width(text: str, size: float = _FONT, weight: str = "normal") -> float:
    """Width of ``text`` at ``size`` points and ``weight``, in inches, and the pad after it
    (measured on the font, not guessed)."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextToPath

    width, _, _ = TextToPath().get_text_width_height_descent(
        text, FontProperties(size=size, weight=weight), ismath=False
    )
    return float(width + _PAD) / 72.0


def _rows(
    items: Sequence[tuple[float, float, str]], seconds_per_inch: float, end: float, *,
    size: float = _FONT, weight: str = "normal",
) -> list[tuple[int, bool]]:
    """(row, right-aligned) for each (start, end, text), so that no label or span overlaps
    another: greedy by left edge, first row whose last occupant has ended. A label that would
    run past the show's end ends at its start instead. Each is measured as it is drawn: with
    a space before it (after it when right-aligned), at ``size`` points and ``weight``."""
    spans = []
    for start, stop, text in items:
        width = _text_width(f" {text}", size, weight) * seconds_per_inch
        right = start + width > end
        left = start - width if right else start
        spans.append((left, max(stop, start if right else start + width), right))
    order = sorted(range(len(spans)), key=lambda i: spans[i][0])
    ends: list[float] = []
    out: list[tuple[int, bool]] = [(0, False)] * len(spans)
    for i in order:
        left, reach, right = spans[i]
        for row, last in enumerate(ends):
            if last <= left:
                ends[row] = reach
                out[i] = (row, right)
                break
        else:
            ends.append(reach)
            out[i] = (len(ends) - 1, right)
    return out


def timeline_figure(timeline: Timeline) -> Any:
    """The matplotlib Figure for ``timeline`` (the caller saves and closes it)."""
    plt = _pyplot()
    end = timeline.duration
    seconds_per_inch = end / (_WIDTH * (_RIGHT - _LEFT))
    # Lay out every block first (heights in inches), then place the axes top-down.
    header = [(name, start, stop) for name, start, stop in timeline.sections]
    header_rows = _rows([(s, e, n) for n, s, e in header], seconds_per_inch, end,
                        size=_HEADER_FONT, weight="bold")
    blocks: list[tuple[str, float, Any]] = []
    if header or timeline.bars:
        top_row = max((r for r, _ in header_rows), default=0)
        blocks.append(("header", _HEADER_H + _ROW_H * top_row, None))
    for perf in timeline.performers:
        for lane in perf.lanes:
            blocks.append(("lane", _CURVE_H, (perf, lane)))
        shown = [e for e in perf.events if e.kind != "move"]
        if shown:
            rows = _rows([(e.start, e.end, e.text) for e in shown], seconds_per_inch, end)
            lane_h = _ROW_H * (max(r for r, _ in rows) + 1) + 0.1
            blocks.append(("events", lane_h, (perf, shown, rows)))
        strips = sorted({e.lane for e in perf.colours})
        if strips:
            blocks.append(("colours", _STRIP_H * len(strips) + 0.1, (perf, strips)))
        if not perf.lanes and not shown and not strips:
            blocks.append(("empty", _ROW_H * 2, perf))
    height = sum(h for _, h, _ in blocks) + _GAP_H * (len(timeline.performers) + 1) + _TITLE_H
    height += _FOOT_H
    fig = plt.figure(figsize=(_WIDTH, height))
    top = height - _TITLE_H
    axes: list[Any] = []
    current: PerformerTimeline | None = None
    for kind, h, data in blocks:
        perf = data[0] if isinstance(data, tuple) else data
        if kind != "header" and perf is not current:
            top -= _GAP_H if current is not None or blocks[0][0] == "header" else 0.0
            current = perf
            fig.text(_LEFT, (top + 0.05) / height, f"{perf.name} ({perf.title})",
                     fontsize=10, weight="bold", va="bottom")
        ax = fig.add_axes((_LEFT, (top - h) / height, _RIGHT - _LEFT, h / height))
        ax.set_xlim(0, end)
        top -= h
        axes.append(ax)
        if kind == "header":
            _draw_header(ax, timeline, header, header_rows)
        elif kind == "lane":
            _draw_lane(ax, data[1])
        elif kind == "events":
            _draw_events(ax, data[1], data[2])
        elif kind == "colours":
            _draw_colours(ax, data[0], data[1])
        else:
            ax.set_yticks([])
            ax.text(0.01, 0.5, "no frames", transform=ax.transAxes, fontsize=_FONT,
                    va="center")
        _draw_grid(ax, timeline, shade=kind != "header")
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    if axes:
        axes[-1].set_xlabel("show time (s)")
    grid = f" — {timeline.tempo_text}" if timeline.tempo_text else ""
    fig.suptitle(f"{timeline.name}{grid}", x=_LEFT, y=1 - 0.1 / height, ha="left",
                 va="top", fontsize=12)
    return fig


def _draw_grid(ax: Any, timeline: Timeline, *, shade: bool) -> None:
    # One collection per kind of line: thousands of single lines take seconds to draw.
    across = ax.get_xaxis_transform()
    if timeline.beats:
        ax.vlines(timeline.beats, 0, 1, transform=across, colors="0.85", linewidth=0.4,
                  zorder=0)
    if timeline.bars:
        ax.vlines([t for t, _ in timeline.bars], 0, 1, transform=across, colors="0.55",
                  linewidth=0.7, zorder=0, gid="bar-lines")
    if shade:
        for i, (_, start, stop) in enumerate(timeline.sections):
            if i % 2:
                ax.axvspan(start, stop, color="0.93", zorder=-1, linewidth=0)


def _draw_header(ax: Any, timeline: Timeline, header: list[tuple[str, float, float]],
                 rows: list[tuple[int, bool]]) -> None:
    ax.set_yticks([])
    for side in ("left", "right", "bottom"):
        ax.spines[side].set_visible(False)
    ax.set_ylim(0, max((r for r, _ in rows), default=0) + 1.6)
    for i, ((name, start, stop), (row, right)) in enumerate(zip(header, rows, strict=True)):
        ax.axvspan(start, stop, ymin=0, ymax=0.12, color=f"C{i % 10}", alpha=0.5)
        ax.text(start, row + 0.5, f"{name} " if right else f" {name}", fontsize=_HEADER_FONT,
                va="center", ha="right" if right else "left", weight="bold", gid="label")
    if timeline.bars:
        ax.xaxis.set_ticks_position("top")
        step = _label_step(timeline, min_inches=0.3)
        ticks = [(t, n) for i, (t, n) in enumerate(timeline.bars) if i % step == 0]
        ax.set_xticks([t for t, _ in ticks], [str(n) for _, n in ticks], fontsize=_FONT)
        ax.set_ylabel("bar", fontsize=_FONT, rotation=0, ha="right", va="top")
        ax.yaxis.set_label_coords(-0.005, 1.0)
    else:
        ax.set_xticks([])


def _label_step(timeline: Timeline, *, min_inches: float) -> int:
    """Label every n-th bar so that bar numbers stay ``min_inches`` apart."""
    bars = timeline.bars
    if len(bars) < 2:
        return 1
    shortest = min(b[0] - a[0] for a, b in itertools.pairwise(bars))
    inches = shortest / timeline.duration * _WIDTH * (_RIGHT - _LEFT)
    step = 1
    while inches * step < min_inches:
        step *= 2
    return step


def _draw_lane(ax: Any, lane: Any) -> None:
    for curve in lane.curves:
        known = [i for i, t in enumerate(curve.times) if t >= curve.known_from]
        style = {"drawstyle": "default" if curve.ramp else "steps-post", "linewidth": 1.3}
        (line,) = ax.plot(curve.times[known[0]:], curve.values[known[0]:], label=curve.name,
                          **style)
        if known[0] > 0:  # before its first move: assumed, dotted
            ax.plot(curve.times[:known[0] + 1], curve.values[:known[0] + 1], linestyle=":",
                    color=line.get_color(), linewidth=1.0)
    ax.set_ylabel(lane.unit, fontsize=9)
    ax.tick_params(labelsize=_FONT)
    ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=_FONT, frameon=False,
              borderaxespad=0.0)


def _draw_events(ax: Any, events: list[Event], rows: list[tuple[int, bool]]) -> None:
    top = max(r for r, _ in rows) + 1
    ax.set_ylim(top, 0)  # the first row on top
    ax.set_yticks([])
    ax.set_ylabel("cues", fontsize=9, rotation=0, ha="right", va="center")
    for event, (row, right) in zip(events, rows, strict=True):
        if event.kind == "action":
            ax.add_patch(_box(event.start, row + 0.1, event.end - event.start, 0.8,
                              "tab:orange", 0.35))
        else:
            ax.plot([event.start], [row + 0.5], marker="|", color="dimgrey", markersize=6)
        text = f"{event.text} " if right else f" {event.text}"
        ax.text(event.start, row + 0.5, text, fontsize=_FONT, va="center",
                ha="right" if right else "left", gid="label")


def _draw_colours(ax: Any, perf: PerformerTimeline, strips: list[str]) -> None:
    ax.set_ylim(len(strips), 0)
    ax.set_yticks([i + 0.5 for i in range(len(strips))], strips, fontsize=_FONT)
    for row, strip in enumerate(strips):  # one collection per LED: fades make thousands of runs
        runs = [e for e in perf.colours if e.lane == strip and e.colour is not None]
        ax.broken_barh([(e.start, e.end - e.start) for e in runs], (row + 0.1, 0.8),
                       facecolors=[tuple(c / 255 for c in e.colour or ()) for e in runs],
                       linewidth=0)


def _box(x: float, y: float, w: float, h: float, colour: Any, alpha: float) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle((x, y), w, h, facecolor=colour, alpha=alpha, linewidth=0)
