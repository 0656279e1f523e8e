"""A cheap proof that an XGO performer's frames fit its link, so ``validate`` need not make them.

``validate`` wants the compiler's findings, not its frames. The findings of a performer are the
planner's (found while it walks the cues: infeasible and overshooting moves, values a register
does not take, ...) and the pacing's (frames more than a control period late, or, with
``decimate``, sample frames dropped). Sampling every move and fade into frames and pacing them
costs some 90 % of a compile; the walk alone costs a few milliseconds per hundred cues.

So :func:`quick_track_diagnostics` walks the cues (the planner's own walk, sampling left out)
and then bounds, without making a frame, how late any frame could start:

* **What a tick may cost.** Every frame the merger makes starts with a register written at
  its tick and holds at least one, so a tick writing ``W`` registers makes at most ``W``
  frames; a gap between two runs is bridged only when that takes less link time than a frame's
  framing and silence would. So a tick's frames take at most, summed over the registers
  written there, ``c * (MIN_LENGTH + size) + gap_us + 2`` microseconds of link (``c`` µs a
  byte; the 2 µs absorb the per-frame rounding up and the merger's float comparison).
  A move writes its registers at each tick from its first to the last it is sampled at (a
  DoF a later cue took over stops before it) and its end; a fade its LED at each tick of its
  span (it really sends only the ticks where the colour changes) and its end; settings and
  actions their registers at their start. Counting a register once for each cue that writes
  it at a tick (the planner keeps one) only adds.
* **How late a frame may start.** Pacing starts each frame at its planned time or when the
  link is free, whichever is later: with costs at most the bounds above, the link is free no
  later than the same recurrence run on the bounds, ``F = max(t, F) + C(t)``. It is run window
  by window (a window: ticks with the same cues under way), in closed form: within a window
  lateness grows by at most ``C - Δ`` a tick (``Δ`` the shortest tick spacing) or, when the
  window's cost fits a tick, never grows.

If no frame can start later than the pacing allows (a period; half of one with ``decimate``,
where nothing is then dropped either), the performer's diagnostics are exactly the walk's.
Otherwise the answer is None and the caller compiles the performer in full, so the
diagnostics are always those of :func:`~xgo_show.compiler.build.compile_show`
(``tests/compiler/test_linkfit.py`` compares the two on random routines). A move that reaches
the edge of a register's range also goes the full way (its sampling may raise, as the
compiler's does).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable
from itertools import pairwise
from typing import NamedTuple

from xgo_show.choreo.resolved import ResolvedTrack
from xgo_show.compiler.frames import Write, first_tick, tick_us, to_us
from xgo_show.compiler.planner import XgoPlanner
from xgo_show.compiler.state import layout_of
from xgo_show.diagnostics import Diagnostic
from xgo_show.profiles.model import Link, Profile, Register
from xgo_show.wire.xgo import MIN_LENGTH

__all__ = ["LinkModel", "late_bound_us", "link_model", "quick_track_diagnostics"]


class _CueWalk(XgoPlanner):
    """The planner's walk over the cues, every diagnostic it finds, without the sampling."""

    def _sample_run(self, run: object) -> None:
        return None

    def _sample_fade(self, fade: object) -> None:
        return None

    def _sample_fades(self, group: object) -> None:
        return None


def quick_track_diagnostics(
    track: ResolvedTrack, profile: Profile, *, rate: float, link: Link, gap_us: int,
    period_us: int, decimate: bool,
) -> list[Diagnostic] | None:
    """The errors :func:`~xgo_show.compiler.build.compile_show` finds in ``track`` (an XGO
    performer), when the link provably fits its frames; None when the full compile must say."""
    walk = _CueWalk(layout_of(profile), track, rate)
    walk.plan()
    limit = period_us // 2 if decimate else period_us
    late = late_bound_us(walk, rate=rate, link=link, gap_us=gap_us, limit=limit)
    if late is None or late > limit:
        return None
    return walk.diag.items


def late_bound_us(
    walk: XgoPlanner, *, rate: float, link: Link, gap_us: int, limit: float
) -> float | None:
    """An upper bound of how late (µs) any frame of ``walk``'s performer starts once paced,
    or None when it cannot be bounded cheaply (a move reaching a register's edge). Stops
    counting once past ``limit``."""
    model = link_model(walk, rate=rate, link=link, gap_us=gap_us)
    if model is None:
        return None
    return _sweep(model, rate=rate, limit=limit)


class LinkModel(NamedTuple):
    """Where and what a performer may write, as :func:`late_bound_us` counts it."""

    #: tick index -> registers (addresses) whose sampling starts (+1) or stops (-1) there
    spans: dict[int, list[tuple[int, int]]]
    #: µs -> registers written at that instant (on a tick or between two)
    points: dict[int, set[int]]
    #: address -> the most link time (µs) its write adds to an instant's frames
    cost: dict[int, float]
    #: the least link time a frame takes (µs)
    smallest: float


def link_model(walk: XgoPlanner, *, rate: float, link: Link, gap_us: int) -> LinkModel | None:
    """What ``walk``'s performer may write when, at most (None: not modelled, see
    :func:`late_bound_us`)."""
    per_byte = link.bits_per_byte * 1_000_000 / link.baud
    cost: dict[int, float] = {}  # address -> the most link time its write adds to a tick

    def count(address: int, size: int) -> None:  # see the module docstring
        cost[address] = max(cost.get(address, 0.0), per_byte * (MIN_LENGTH + size) + gap_us + 2)

    def regs_of(regs: Iterable[Register]) -> tuple[int, ...]:
        for reg in regs:
            count(reg.address, reg.size)
        return tuple(reg.address for reg in regs)

    spans: dict[int, list[tuple[int, int]]] = defaultdict(list)  # tick -> (address, +-1)
    points: dict[int, set[int]] = defaultdict(set)  # µs -> addresses written at that instant
    layout = walk.layout
    for run in walk.runs:
        plan = run.plan
        tables = [layout.byte_table(reg) for reg in run.regs]
        # A move whose path passes its byte tables' ends (float noise past an end, which the
        # planner clamps: _motion refuses more) is left to the full compile: rare, and not
        # worth a bound of its own.
        if not all(t.lo <= lo and hi <= t.hi and t.lo <= x <= t.hi for t, (lo, hi), x
                   in zip(tables, plan.extrema(), plan.targets, strict=True)):
            return None
        addresses = regs_of(run.regs)
        # The ticks the planner samples (its _sample_run): from the first at or after the
        # start to the last before the end, a DoF another cue took over stopping before
        # that cue's tick; then the exact target at the end itself.
        k0 = first_tick(plan.start, rate)
        end_us = to_us(plan.end)
        k_end = first_tick(plan.end, rate)
        if k_end > k0 and tick_us(k_end - 1, rate) >= end_us:
            k_end -= 1
        for address, cut in zip(addresses, run.cuts, strict=True):
            stop = k_end - 1 if cut is None else min(first_tick(cut, rate), k_end) - 1
            if stop >= k0:
                spans[k0].append((address, 1))
                spans[stop + 1].append((address, -1))
            if cut is None:
                points[end_us].add(address)
    for fade in walk.fades:
        cue = fade.cue
        stop_us = to_us(cue.start + cue.duration if fade.cut is None else fade.cut)
        (address,) = regs_of((fade.reg,))
        # Its ticks (the planner's _sample_fade sends only those where the colour changes):
        # from the first at or after the start to the last before the stop; then the end.
        k0 = first_tick(cue.start, rate)
        k1 = first_tick(stop_us / 1_000_000, rate)  # near the first tick at or after the stop
        while tick_us(k1, rate) < stop_us:
            k1 += 1
        while k1 > k0 and tick_us(k1 - 1, rate) >= stop_us:
            k1 -= 1
        if cue.duration > 0 and k1 > k0:
            spans[k0].append((address, 1))
            spans[k1].append((address, -1))
        if fade.cut is None:
            points[stop_us].add(address)
    for t_us, entry in walk.ticks.items():  # settings and actions (no samples were filed)
        if not isinstance(entry, list):
            return None  # a sample filed by a walk that samples after all: not counted here
        for w in entry:
            if not isinstance(w, Write):
                return None
            count(w.address, len(w.data))
            points[t_us].add(w.address)
    return LinkModel(spans, points, cost, per_byte * (MIN_LENGTH + 1) + gap_us)


def _sweep(model: LinkModel, *, rate: float, limit: float) -> float:
    """The pacing recurrence on cost bounds, window by window (see the module docstring).

    A register counts once per instant, however many cues write it there: the planner keeps
    one write per register and tick. The last frame of an instant starts ``model.smallest``
    (the least a frame costs) before the link is free after it.
    """
    spans, points, cost, smallest = model
    # Each point on a tick becomes a window of its own tick; one between ticks ends the window
    # before it. Windows then hold no point inside and are visited in time order with them.
    on_tick: dict[int, set[int]] = {}
    between: list[tuple[int, float]] = []
    bounds = set(spans)
    for t_us, written in points.items():
        k = round(t_us * rate / 1_000_000)
        while tick_us(k, rate) > t_us:
            k -= 1
        while tick_us(k + 1, rate) <= t_us:
            k += 1
        if tick_us(k, rate) == t_us:
            on_tick[k] = written
            bounds.update((k, k + 1))
        else:  # between tick k and k + 1
            between.append((t_us, sum(cost[a] for a in written)))
            bounds.add(k + 1)
    order = sorted(bounds)
    # (start µs, first tick, last tick, cost a tick) per window, and the points between ticks
    # as windows of no tick: sorted by time, a point between ticks k and k + 1 falls after
    # the window ending at k and before the one starting at k + 1.
    events: list[tuple[int, int, int, float]] = []
    sampled: dict[int, int] = defaultdict(int)  # address -> cues sampling it
    level = 0.0
    for a, b in pairwise(order):
        for address, delta in spans.get(a, ()):
            before = sampled[address]
            sampled[address] = before + delta
            if before == 0:
                level += cost[address]
            elif before + delta == 0:
                level -= cost[address]
        c = level
        if b == a + 1 and a in on_tick:
            c += sum(cost[x] for x in on_tick[a] if not sampled[x])
        if c > 1e-6:
            events.append((tick_us(a, rate), a, b - 1, c))
    events.extend((t_us, 0, -1, extra) for t_us, extra in between)
    events.sort()
    step = math.floor(1_000_000 / rate) - 1  # the shortest tick spacing, rounding included
    free = -math.inf  # when the link is free, at the latest
    worst = 0.0
    for start, a, b, c in events:
        late = max(0.0, free - start)  # of the window's first frame
        worst = max(worst, late + c - smallest)
        if b > a:  # more ticks: lateness grows by at most c - step a tick, or not at all
            n = b - a
            if c > step:
                late += n * (c - step)
                worst = max(worst, late + c - smallest)
            else:
                late = max(0.0, late - n * (step - c))
            free = tick_us(b, rate) + late + c
        else:
            free = start + late + c
        if worst > limit:
            break
    return worst
