"""One XGO performer's cues -> each tick's writes, then its planned frames.

Everything runs on integer microseconds from show start, so equal times compare equal and the
output does not depend on float formatting. Trajectory and fade samples sit on a fixed tick grid
(tick ``k`` at ``k / control_rate`` seconds) but for each one's last, the exact target, which goes
out at the move's or fade's end itself; actions and settings go out at their own start.

Per tick, each register's physical value becomes its byte through :meth:`Register.to_byte` (or
:meth:`Register.encode_value` for settings); a *sample* whose bytes equal what was last sent is
dropped (settings and actions are always sent: the user asked for them). The fast path
(:mod:`~xgo_show.compiler.fastpath`) turns the ticks into frames.
"""

from __future__ import annotations

import math
from bisect import bisect_left, bisect_right, insort
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from itertools import compress, repeat
from operator import is_, itemgetter, ne, not_

from xgo_show.choreo.resolved import ActionCue, FadeCue, MotionCue, ResolvedTrack, SetCue
from xgo_show.compiler.fastpath import frames_from_ticks
from xgo_show.compiler.frames import (
    BYTES,
    TIME_EPS,
    TrackPlan,
    Write,
    cue_label,
    cut_rows,
    first_tick,
    tick_times,
    tick_us,
    to_us,
)
from xgo_show.compiler.layout import ACTION_REGISTER, Layout
from xgo_show.compiler.sources import Entry, Samples, Source, entry_writes
from xgo_show.compiler.trajectory import (
    DofState,
    InfeasibleMotion,
    MotionPlan,
    TrajectoryError,
    plan_motion,
)
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.errors import ProfileError, ProtocolError
from xgo_show.families.xgo.posture import posture_after
from xgo_show.profiles.model import Encoding, Limits, Link, Register

__all__ = ["XgoPlanner", "plan_xgo_track"]

_HEAD = itemgetter(0)


class _Diag:
    def __init__(self, performer: str) -> None:
        self.performer = performer
        self.items: list[Diagnostic] = []

    def error(self, origin: Origin | None, message: str) -> None:
        self.items.append(
            Diagnostic("error", message, origin, f"tracks.{self.performer}")
        )


@dataclass
class _Fade:
    """A planned LED fade; ``cut`` is when a later cue took its register over, if one did."""

    cue: FadeCue
    order: int
    reg: Register
    start: tuple[int, int, int]  # the colour it fades from
    cut: float | None = None

    def colour_at(self, t: float) -> tuple[int, int, int]:
        """The colour at show time ``t`` (clamped to the fade's span)."""
        duration = self.cue.duration
        frac = 1.0 if duration <= 0 else min(max((t - self.cue.start) / duration, 0.0), 1.0)
        (r0, g0, b0), (r1, g1, b1) = self.start, self.cue.to
        return (round(r0 + (r1 - r0) * frac), round(g0 + (g1 - g0) * frac),
                round(b0 + (b1 - b0) * frac))


@dataclass(eq=False)
class _Run:
    """A planned trajectory: its plan, its registers, and when each DoF's sampling stops."""

    plan: MotionPlan
    regs: tuple[Register, ...]
    origin: Origin
    order: int
    cuts: list[float | None]  # per DoF: show time another cue took the register over


def _round_up(seconds: float) -> float:
    """Up to the next 0.01 s (float noise of 1e-6 s ignored)."""
    return math.ceil(seconds * 100 - 1e-4) / 100


def _too_short(cue: MotionCue, reg: Register, lim: Limits, exc: InfeasibleMotion) -> str:
    """The message for a move given less time than its limits need: in the unit the user
    wrote (beats or bars as well as seconds), naming the segment of a multi-point path. It
    names the move, not the performer or the phrase's use, so that a phrase played by several
    tracks or several times is said once (the compiler merges repeats)."""
    n, of = cue.segment
    targets = ", ".join(f"{name} {value:g}" for name, value in cue.targets.items())
    what = (f"segment {n} of {of} of the move (to {targets})" if of > 1
            else f"the move to {targets}")
    # Rounded up: "at least 0.51 s" must be enough, and never read like "0.50 s" when 0.50 s
    # was given and falls short.
    need = f"{_round_up(exc.minimum):.2f} s"
    given = f"{exc.requested:.2f} s"
    if cue.given is not None and exc.requested > 0:
        amount, unit = cue.given
        per_second = amount / exc.requested
        need += f" ({_round_up(exc.minimum * per_second):.2f} {unit})"
        given = f"{amount:.3g} {unit} ({exc.requested:.2f} s)"
    return (f"{what} needs at least {need} under its limits "
            f"({reg.name}: {_limits_text(reg, lim)}) but is given {given}")


def _limits_text(reg: Register, lim: Limits) -> str:
    u = reg.unit or "units"
    return (
        f"velocity {lim.velocity:g} {u}/s, acceleration {lim.acceleration:g} {u}/s², "
        f"jerk {lim.jerk:g} {u}/s³"
    )


def _rows(columns: Sequence[Iterable[int]], count: int) -> list[bytes]:
    """``list(map(bytes, zip(*columns)))`` for ``columns`` of ``count`` bytes' values each:
    row ``i`` as ``bytes``, made column by column. Each column becomes one ``bytes`` (a C-level
    loop), is put in place in one buffer by an extended slice, and the buffer is cut into rows
    by :func:`~xgo_show.compiler.frames.cut_rows`: no tuple a row nor a ``bytes()`` call on one
    (the samples of a long show's every tick: 900,000 rows of 4 bytes in 0.045 s against
    0.081 s).
    """
    width = len(columns)
    if width == 1:
        return list(map(BYTES.__getitem__, columns[0]))
    buf = bytearray(width * count)
    for i, column in enumerate(columns):
        buf[i::width] = bytes(column)  # a column of another length than count raises
    return cut_rows(buf, width)


def _tick_samples(at_time: Callable[[float], tuple[list[float], ...]], tables: list[list[float]],
                  times: list[float]) -> list[bytes]:
    """A trajectory's sample at each of ``times``: every DoF's byte, ``bisect_right`` of its
    position over its table (see :class:`~xgo_show.compiler.bytetable.ByteTable`).

    One ``at_time`` a tick in a comprehension, then per DoF one C-level map over its column of
    positions: the compiler's hottest code (nearly every tick of a long show is a sample).
    """
    if not times:
        return []
    positions = [at_time(t)[0] for t in times]
    return _rows([map(bisect_right, repeat(table), column)
                  for table, column in zip(tables, zip(*positions, strict=True), strict=True)],
                 len(times))


def _fade_fractions(k: int, end: int, rate: float, t0: float, duration: float) -> list[float]:
    """How far a fade of ``duration`` from ``t0`` is at each tick from ``k`` to ``end``
    (excluded), clamped to 0..1 as :meth:`_Fade.colour_at` does."""
    fracs = [(j / rate - t0) / duration for j in range(k, end)]
    # The fractions grow with j, so only a few at either end may lie outside (float noise at
    # the start and the stop).
    for i in range(len(fracs)):
        if fracs[i] >= 0.0:
            break
        fracs[i] = 0.0
    for i in range(len(fracs) - 1, -1, -1):
        if fracs[i] <= 1.0:
            break
        fracs[i] = 1.0
    return fracs


def _fade_channels(fracs: list[float], start: tuple[int, int, int],
                   delta: tuple[int, int, int]) -> list[list[int]]:
    """A fade's red, green and blue at each of ``fracs``: the arithmetic of
    :meth:`_Fade.colour_at`, one list comprehension a channel (cheaper than a call a tick;
    C-level maps of operator functions cost more instructions still)."""
    (r0, g0, b0), (dr, dg, db) = start, delta
    return [[round(r0 + dr * f) for f in fracs], [round(g0 + dg * f) for f in fracs],
            [round(b0 + db * f) for f in fracs]]


def _fade_colours(k: int, end: int, rate: float, t0: float, duration: float,
                  start: tuple[int, int, int], delta: tuple[int, int, int]) -> list[bytes]:
    """The colour of a fade at each tick from ``k`` to ``end`` (excluded), as bytes."""
    return _rows(_fade_channels(_fade_fractions(k, end, rate, t0, duration), start, delta),
                 max(end - k, 0))


def _supersedes(src: Source, other: Source) -> bool:
    """Whether ``src``'s sample at a tick leaves nothing of ``other``'s there: it writes every
    register ``other`` does, for a cue no earlier (the later cue's write of a register wins
    a tick, :meth:`~xgo_show.compiler.fastpath.TickFrames.writes_tick`), so the tick's frames
    are those of ``src``'s sample alone."""
    return other.order <= src.order and other.address_set <= src.address_set


class XgoPlanner:
    """Walks one XGO performer's cues in order, keeping the commanded state as it goes."""

    #: File a sample that supersedes the one filed at its tick in that one's place (see
    #: _emit_samples); False mixes the two as Writes: the plain road, the tests' reference.
    supersede = True

    def __init__(self, layout: Layout, track: ResolvedTrack, rate: float) -> None:
        self.layout = layout
        self.profile = layout.profile
        self.track = track
        self.rate = rate
        self.diag = _Diag(track.performer)
        self.commanded: dict[str, float] = {}  # last commanded physical value (linear regs)
        self.colours: dict[str, tuple[int, int, int]] = {}
        for reg in self.profile.registers:
            if reg.initial is None:
                continue
            if reg.linear and reg.size == 1:
                self.commanded[reg.name] = reg.to_physical(reg.initial[0])
            elif reg.encoding is Encoding.RGB:
                self.colours[reg.name] = (reg.initial[0], reg.initial[1], reg.initial[2])
        self.active: dict[str, tuple[_Run, int]] = {}  # register -> latest run and its DoF
        self.runs: list[_Run] = []
        self.fades: list[_Fade] = []
        self.fading: dict[str, _Fade] = {}  # the last fade of each RGB register
        self.ticks: dict[int, Entry] = {}
        self.mixed: set[int] = set()  # ticks that more than one cue writes (see _emit)
        self.action_reg = layout.by_name.get(ACTION_REGISTER)
        # When each preset action goes out, in time order (see _fade_group)
        self.action_ticks: list[int] = []
        self.end = 0.0

    # -- cues -------------------------------------------------------------------------------

    def plan(self) -> None:
        for order, cue in enumerate(self.track.cues):
            try:
                if isinstance(cue, MotionCue):
                    self._motion(cue, order)
                elif isinstance(cue, SetCue):
                    self._set(cue, order)
                elif isinstance(cue, ActionCue):
                    self._action(cue, order)
                elif isinstance(cue, FadeCue):
                    self._fade(cue, order)
                else:
                    self.diag.error(
                        cue.origin, f"{self.profile.model} is not an xArm; it takes no arm cue"
                    )
            except (ProfileError, ProtocolError) as exc:
                self.diag.error(cue.origin, f"{cue_label(cue.origin)}: {exc}")
        for run in self.runs:
            self._sample_run(run)
        i = 0
        while i < len(self.fades):
            group = self._fade_group(i)
            if len(group) > 1:
                self._sample_fades(group)
            else:
                self._sample_fade(self.fades[i])
            i += len(group)

    def _emit(self, t_us: int, writes: list[Write]) -> None:
        """File one cue's writes at ``t_us`` (one per register, in address order).

        A tick only one cue writes needs no de-duplication or sorting when merged: the ticks
        where a second cue adds writes are noted in ``mixed``.
        """
        if not writes:
            return
        entry = self.ticks.get(t_us)
        if entry is None:
            self.ticks[t_us] = writes
            return
        bucket = entry_writes(entry)
        if bucket is entry:
            bucket.extend(writes)
        else:
            self.ticks[t_us] = bucket + writes
        self.mixed.add(t_us)

    def _emit_sample(self, t_us: int, src: Source, sample: bytes) -> None:
        """File a source's sample at ``t_us``; with Writes or a sample of the same register
        there, the tick becomes Writes (mixed), unless ``src`` supersedes that sample."""
        self._emit_samples(src, ((t_us, sample),))

    def _emit_samples(self, src: Source, samples: Iterable[tuple[int, bytes]]) -> None:
        """:meth:`_emit_sample` of each (tick, sample), in one loop: a fade's ticks mostly land
        on a move's (a Rider's LEDs beside its body), a call each would cost a third more.

        A sample filed there already that ``src`` supersedes (see :func:`_supersedes`) is
        replaced, not mixed with: where one move or fade hands over to the next, the last
        sample of the first and the first of the next fall on the same tick, and that tick
        then stays one of samples, in the stretch of the next one's ticks.
        """
        ticks, mine = self.ticks, src.address_set
        for t_us, sample in samples:
            entry = ticks.get(t_us)
            if entry is None:
                ticks[t_us] = (src, sample)
                continue
            if isinstance(entry, tuple):
                other = entry[0]
                if mine.isdisjoint(other.addresses):
                    ticks[t_us] = Samples((entry, (src, sample)))
                    continue
                if self.supersede and _supersedes(src, other):
                    ticks[t_us] = (src, sample)
                    continue
            elif isinstance(entry, Samples):
                met = [i for i, (other, _) in enumerate(entry)
                       if not mine.isdisjoint(other.addresses)]
                if not met:
                    entry.append((src, sample))
                    continue
                if len(met) == 1 and self.supersede and _supersedes(src, entry[met[0]][0]):
                    entry[met[0]] = (src, sample)
                    continue
            self._emit(t_us, src.writes(sample))

    def _take_over(self, name: str, t: float) -> DofState | None:
        """A cue writes ``name`` at ``t``: stop sampling a move still running on it.

        Returns the state the move had reached, or None if no move was running.
        """
        entry = self.active.get(name)
        if entry is None:
            return None
        run, dof = entry
        if run.cuts[dof] is not None or t >= run.plan.end - TIME_EPS:
            return None
        run.cuts[dof] = t
        return run.plan.state_at(t)[dof]

    def _set(self, cue: SetCue, order: int) -> None:
        regs = sorted(
            ((self.layout.register(n), v) for n, v in cue.values.items()),
            key=lambda rv: rv[0].address,
        )
        t_us = to_us(cue.start)
        writes: list[Write] = []
        try:
            for reg, value in regs:
                data = reg.encode_value(value)
                writes.append(Write(reg.address, data, cue.origin, order, False))
                self._take_over(reg.name, cue.start)
                if reg.linear and reg.size == 1 and isinstance(value, (int, float)):
                    self.commanded[reg.name] = float(value)
                elif reg.encoding is Encoding.RGB:
                    self._cut_fade(reg.name, cue.start)
                    self.colours[reg.name] = (data[0], data[1], data[2])
        finally:
            self._emit(t_us, writes)  # what was encoded before an error still goes out
        self.end = max(self.end, cue.start)

    def _action(self, cue: ActionCue, order: int) -> None:
        if self.action_reg is None:
            self.diag.error(cue.origin, f"{self.profile.model} has no action register")
            return
        data = self.action_reg.encode_value(cue.action_id)
        t_us = to_us(cue.start)
        # Any motion write cuts a running action on the robot: moves still under way (the cue
        # interrupts them, on purpose) stop sampling before the action's command goes out.
        for name in self.active:
            reached = self._take_over(name, cue.start)
            if reached is not None:
                self.commanded[name] = reached.position  # the move stopped about here
        self._emit(t_us, [
            Write(self.action_reg.address, data, cue.origin, order, False, cue.duration)
        ])
        insort(self.action_ticks, t_us)
        # The reset action restores the default posture: later moves start from there.
        self.commanded.update(posture_after(self.profile, cue.action_id))
        self.end = max(self.end, cue.start + cue.duration)

    def _fade(self, cue: FadeCue, order: int) -> None:
        reg = self.layout.register(cue.register)
        if reg.encoding is not Encoding.RGB:
            self.diag.error(cue.origin, f"{cue.register} is not an RGB register; it cannot fade")
            return
        reg.encode_value(cue.to)
        # Cutting a fade still under way starts from the colour it had reached.
        reached = self._cut_fade(cue.register, cue.start)
        start = reached if reached is not None else self.colours.get(cue.register, (0, 0, 0))
        self.colours[cue.register] = cue.to
        self.end = max(self.end, cue.start + cue.duration)
        fade = _Fade(cue, order, reg, start)
        self.fades.append(fade)
        self.fading[cue.register] = fade

    def _cut_fade(self, name: str, t: float) -> tuple[int, int, int] | None:
        """A cue writes RGB register ``name`` at ``t``: stop a fade of it still under way there.

        Returns the colour the fade had reached, or None if none was running.
        """
        fade = self.fading.get(name)
        if (fade is None or fade.cut is not None
                or t >= fade.cue.start + fade.cue.duration - TIME_EPS):
            return None
        fade.cut = t
        return fade.colour_at(t)

    def _fade_ticks(self, cue: FadeCue, stop_us: int) -> tuple[int, int]:
        """A fade's first tick and the first tick at or after ``stop_us``, by galloping."""
        rate = self.rate
        k = first_tick(cue.start, rate)
        end = k
        step = 1
        while cue.duration > 0 and round(end * 1_000_000 / rate) < stop_us:
            end += step
            step *= 2
        while step > 1:  # back to the first tick at or after the stop
            step //= 2
            if round((end - step) * 1_000_000 / rate) >= stop_us and end - step >= k:
                end -= step
        return k, end

    def _fade_group(self, i: int) -> list[_Fade]:
        """The fades from ``self.fades[i]`` that one source can sample together: the fades of
        one ``led:`` cue (the resolver's consecutive FadeCues of one origin, start and length,
        in address order), none cut, each changing colour about every tick (see
        _sample_fade), with no preset action from their start to their end. Their ticks then
        make the same frames as the fades' own: a register whose colour holds at a tick where
        another's changes is compared with what it was last sent, which is its colour the tick
        before (only a preset action, or a cue cutting the fade, would make these differ)."""
        fades = self.fades
        first = fades[i]
        group = [first]
        cue = first.cue
        for fade in fades[i + 1:]:
            last = group[-1]
            if (fade.order != last.order + 1 or fade.cue.start != cue.start
                    or fade.cue.duration != cue.duration or fade.cue.origin != cue.origin
                    or fade.cut is not None or last.cut is not None
                    or fade.reg.address <= last.reg.address):
                break
            group.append(fade)
        if len(group) == 1 or cue.duration <= 0:
            return group[:1]
        stop_us = to_us(cue.start + cue.duration)
        k, end = self._fade_ticks(cue, stop_us)
        start_us = round(k * 1_000_000 / self.rate)
        actions = self.action_ticks  # the first at or after the start: is it by the stop?
        at = bisect_left(actions, start_us)
        if at < len(actions) and actions[at] <= stop_us:
            return group[:1]
        for fade in group:
            (r0, g0, b0), (r1, g1, b1) = fade.start, fade.cue.to
            if (abs(r1 - r0) + abs(g1 - g0) + abs(b1 - b0)) * 2 < end - k:
                return group[:1]  # a slow fade: galloping over its runs costs less
        return group

    def _sample_fades(self, group: list[_Fade]) -> None:
        """:meth:`_sample_fade` of a :meth:`_fade_group`'s fades as one source: a tick's
        sample is every fade's colour, in address order."""
        first = group[0]
        cue, rate = first.cue, self.rate
        stop_us = to_us(cue.start + cue.duration)
        src = Source(tuple(f.reg for f in group), cue.origin, first.order)
        k, end = self._fade_ticks(cue, stop_us)
        # One start and length: the same fractions for every fade of the group.
        fracs = _fade_fractions(k, end, rate, cue.start, cue.duration)
        channels = []
        for fade in group:
            (r0, g0, b0), (r1, g1, b1) = fade.start, fade.cue.to
            channels += _fade_channels(fracs, fade.start, (r1 - r0, g1 - g0, b1 - b0))
        self._emit_changes(src, k, end, _rows(channels, len(fracs)))
        self._emit_sample(stop_us, src, b"".join([bytes(f.cue.to) for f in group]))

    def _emit_changes(self, src: Source, k: int, end: int, colours: list[bytes]) -> None:
        """File a fade's colours at ticks ``k`` to ``end`` (excluded): only those that differ
        from the tick before's (a tick repeating the colour sends nothing)."""
        rate = self.rate
        times = tick_times(k, end, rate)
        changed = list(map(ne, colours, [b"", *colours]))
        if not all(changed):
            times = list(compress(times, changed))
            colours = list(compress(colours, changed))
        ticks = self.ticks
        held = list(map(ticks.get, times))
        # _emit_samples list by list where a tick holds one other source's sample on other
        # registers (a Rider's LEDs beside its move: nearly every tick), tick by tick elsewhere.
        one = list(map(is_, map(type, held), repeat(tuple)))
        if any(one):
            mine = src.address_set
            others = set(map(_HEAD, compress(held, one)))  # type: ignore[arg-type]
            if all(mine.isdisjoint(other.addresses) for other in others):
                pairs = zip(compress(held, one), zip(repeat(src), compress(colours, one)),
                            strict=False)
                ticks.update(zip(compress(times, one), map(Samples, pairs),  # type: ignore[arg-type]
                                 strict=False))
                if all(one):
                    return
                rest = list(map(not_, one))
                times, colours = list(compress(times, rest)), list(compress(colours, rest))
        self._emit_samples(src, zip(times, colours, strict=True))

    def _sample_fade(self, fade: _Fade) -> None:
        """Steps on the tick grid strictly before the end, then the exact colour at the end
        itself (as a move's last sample: never after it, over a cue starting there). A fade
        another cue cut stops before that cue's start, with no final colour."""
        cue, rate = fade.cue, self.rate
        stop_us = to_us(cue.start + cue.duration if fade.cut is None else fade.cut)
        src = Source((fade.reg,), cue.origin, fade.order)
        ticks, emit = self.ticks, self._emit_sample
        t0, duration = cue.start, cue.duration
        (r0, g0, b0), (r1, g1, b1) = fade.start, cue.to
        dr, dg, db = r1 - r0, g1 - g0, b1 - b0
        def colour(k: int) -> bytes:  # fade.colour_at at tick k, inlined
            frac = min(max((k / rate - t0) / duration, 0.0), 1.0)
            return bytes((round(r0 + dr * frac), round(g0 + dg * frac), round(b0 + db * frac)))

        # Only the ticks where the colour changes (a tick repeating the colour sends nothing):
        # the cost follows the frames (at most 766 for 0..255 on three channels), not the
        # fade's length times the control rate. Each channel is monotone in time, so the
        # ticks holding one colour are a run; its end is found by galloping then bisection,
        # which costs one colour per tick when the colour changes every tick (a short fade)
        # and a logarithm of the run when it holds for long (a slow one).
        k, end = self._fade_ticks(cue, stop_us)  # end: the first tick at or after the stop
        if (abs(dr) + abs(dg) + abs(db)) * 2 >= end - k:
            # The colour changes about every tick (a short fade, or a wide one): every tick's
            # colour at once, list by list, is cheaper than galloping over runs of one.
            self._emit_changes(src, k, end, _fade_colours(k, end, rate, t0, duration,
                                                          fade.start, (dr, dg, db)))
        else:
            sample = colour(k) if k < end else b""
            while k < end:
                t_us = round(k * 1_000_000 / rate)
                if t_us in ticks:
                    emit(t_us, src, sample)
                else:
                    ticks[t_us] = (src, sample)  # emit's common case, inlined
                # colour(lo) == sample; hi: the stop or a tick of another colour, nxt its colour
                lo, hi, step, nxt = k, k + 1, 1, b""
                while hi < end and (nxt := colour(hi)) == sample:
                    lo, step = hi, step * 2
                    hi = lo + step
                if hi >= end:
                    hi, nxt = end, b""
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    there = colour(mid)
                    if there == sample:
                        lo = mid
                    else:
                        hi, nxt = mid, there
                k, sample = hi, nxt
        if fade.cut is None:
            emit(stop_us, src, bytes(cue.to))

    def _motion(self, cue: MotionCue, order: int) -> None:
        diag = self.diag
        pairs: list[tuple[Register, Limits]] = []
        for name in cue.targets:
            reg = self.layout.register(name)
            lim = cue.limits.get(name, reg.limits)
            if lim is None or reg.encoding is not Encoding.U8 or not reg.linear or reg.size != 1:
                diag.error(
                    cue.origin, f"{cue_label(cue.origin)}: {name} cannot follow a trajectory"
                )
                return
            pairs.append((reg, lim))
        pairs.sort(key=lambda p: p[0].address)
        regs = tuple(r for r, _ in pairs)
        limits = [lim for _, lim in pairs]
        current: list[DofState] = []
        for reg in regs:
            # Interrupting a move still under way starts from where it is, moving as it moves;
            # otherwise from the last commanded value, at rest.
            reached = self._take_over(reg.name, cue.start)
            current.append(reached if reached is not None else DofState(self.commanded[reg.name]))
        names = [r.name for r in regs]
        targets = [float(cue.targets[n]) for n in names]
        try:
            plan = plan_motion(names, cue.start, current, targets, limits, cue.duration)
        except InfeasibleMotion as exc:
            reg = regs[exc.dof]
            diag.error(cue.origin, _too_short(cue, reg, limits[exc.dof], exc))
            return
        except TrajectoryError as exc:
            diag.error(cue.origin, f"{cue_label(cue.origin)}: {exc}")
            return
        for reg, (lo, hi) in zip(regs, plan.extrema(), strict=True):
            assert reg.minimum is not None and reg.maximum is not None
            if lo < reg.minimum - 1e-6 or hi > reg.maximum + 1e-6:
                worst = lo if lo < reg.minimum - 1e-6 else hi
                diag.error(
                    cue.origin,
                    f"{cue_label(cue.origin)}: {reg.name} would overshoot to {worst:.1f}"
                    f"{reg.unit or ''} (range {reg.minimum:g}..{reg.maximum:g}) because it "
                    "interrupts the move before it",
                )
                return
        run = _Run(plan, regs, cue.origin, order, [None] * len(regs))
        self.runs.append(run)
        for i, (reg, target) in enumerate(zip(regs, targets, strict=True)):
            self.commanded[reg.name] = target
            self.active[reg.name] = (run, i)
        self.end = max(self.end, plan.end)

    # -- sampling ---------------------------------------------------------------------------

    def _sample_run(self, run: _Run) -> None:
        """Sample a trajectory on the tick grid from its start, then its exact end.

        Ticks strictly before the move's end carry samples; the last sample is the exact target
        (rounding never leaves a register one byte short) and goes out at the end itself, on the
        grid or not: never after it, where it would overwrite a cue starting right at the end
        (and a motion write would cut a preset action starting there). A DoF another cue took
        over stops before that cue's start and sends no final target.
        """
        plan, rate = run.plan, self.rate
        k0 = first_tick(plan.start, rate)
        end_us = to_us(plan.end)
        # k_end: index of the final sample, at end_us; on the grid it is the tick at the end.
        k_end = first_tick(plan.end, rate)
        if k_end > k0 and tick_us(k_end - 1, rate) >= end_us:  # the end a hair past a tick
            k_end -= 1
        stops = [
            (k_end if cut is None else min(first_tick(cut, rate), k_end) - 1)
            for cut in run.cuts
        ]
        targets = plan.targets
        last = max(stops, default=k0 - 1)
        at_time = plan.trajectory.at_time
        start = plan.start
        # Every byte is bisect over the register's padded byte table, which clamps to the
        # ends' bytes: _motion refused a path leaving the range by more than a millionth, and
        # what float noise leaves past an end (a move interrupted on its way to an end by
        # another to it: up to 1e-8 past it) must go out as the end's byte, as
        # Register.to_byte clamps its own 1e-9 (it raised past that: a valid show refused).
        # While every DoF is sampled, all bytes of a tick come from one C-level map of bisect
        # over the tables: the hot loop of the compiler.
        full = min(stops)
        padded = [self.layout.byte_table(reg).padded for reg in run.regs]
        addresses = [reg.address for reg in run.regs]
        origin, order = run.origin, run.order
        src = Source(run.regs, origin, order)
        ticks = self.ticks
        emit, emit_sample = self._emit, self._emit_sample
        # The hot loop of the compiler: the ticks before the end with every DoF sampled, all
        # at once (a comprehension, then C-level maps: cheaper than a loop with statements).
        ks = range(k0, min(full, k_end - 1) + 1)
        times = [k / rate - start for k in ks]
        for i, t in enumerate(times):  # max(t, 0.0): the first tick may sit a hair before
            if t >= 0.0:
                break
            times[i] = 0.0
        samples = _tick_samples(at_time, padded, times)
        stamps = tick_times(ks.start, ks.stop, rate)
        # The ticks another cue's sample or writes hold already (a move's first tick is the
        # previous one's last), then the others at once: all filed, those few put back and
        # emitted one by one.
        taken = ticks.keys() & stamps
        held = {t_us: ticks[t_us] for t_us in taken}
        ticks.update(zip(stamps, zip(repeat(src), samples, strict=False), strict=True))
        if held:
            ticks.update(held)
            if len(held) < 8:  # a move's first tick: found by a short search
                pairs = [(t_us, samples[stamps.index(t_us)]) for t_us in held]
            else:  # moves side by side on other registers: every tick
                where = dict(zip(stamps, samples, strict=True))
                pairs = [(t_us, where[t_us]) for t_us in held]
            self._emit_samples(src, pairs)
        for k in range(max(k0, min(full, k_end - 1) + 1), last + 1):
            if k >= k_end:
                pos, t_us = targets, end_us
            else:
                pos = at_time(max(k / rate - start, 0.0))[0]
                t_us = round(k * 1_000_000 / rate)
            if k <= full:
                emit_sample(t_us, src, bytes(map(bisect_right, padded, pos)))
                continue
            writes = []
            for i, address in enumerate(addresses):
                if k <= stops[i]:
                    writes.append(Write(address, BYTES[bisect_right(padded[i], pos[i])], origin,
                                        order, True))
            emit(t_us, writes)


def plan_xgo_track(
    layout: Layout,
    track: ResolvedTrack,
    *,
    rate: float,
    link: Link,
    gap: float,
    details: bool = True,
) -> TrackPlan:
    """Plan every frame of one XGO performer (unpaced), with its diagnostics.

    ``details=False`` leaves ``fields`` and ``written`` empty in frames holding only move and
    fade samples, which is faster; pacing needs them only to decimate.
    """
    planner = XgoPlanner(layout, track, rate)
    planner.plan()
    frames, samples = frames_from_ticks(
        layout, link, gap, planner.ticks, planner.mixed, planner.action_reg, details
    )
    return TrackPlan(frames, planner.end, planner.diag.items, samples)
