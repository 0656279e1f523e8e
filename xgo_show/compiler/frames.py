"""From cues to planned write frames: sampling, byte conversion, de-duplication, merging.

Everything runs on integer microseconds from show start, so equal times compare equal and the
output does not depend on float formatting. Trajectory and fade samples sit on a fixed tick grid
(tick ``k`` at ``k / control_rate`` seconds) but for each one's last, the exact target, which goes
out at the move's or fade's end itself; actions and settings go out at their own start.

Per tick, each register's physical value becomes its byte through :meth:`Register.to_byte` (or
:meth:`Register.encode_value` for settings); a *sample* whose bytes equal what was last sent is
dropped (settings and actions are always sent: the user asked for them). The registers left at
one tick are merged into as few frames as possible: registers at consecutive addresses share one
write frame (the layout is :meth:`Profile.walk`'s), and two runs separated by a small gap are
joined by re-sending the bytes the gap registers already hold, when that costs less link time
than a separate frame would (8 bytes of frame overhead plus the silence between frames).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Container, Iterable, Mapping, Sequence
from dataclasses import dataclass
from operator import ne
from typing import NamedTuple

from xgo_show.choreo.resolved import ActionCue, FadeCue, MotionCue, ResolvedTrack, SetCue
from xgo_show.compiler.layout import ACTION_REGISTER, Layout
from xgo_show.compiler.schedule import to_us
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
from xgo_show.wire.xgo import MAX_DATA, MIN_LENGTH, TAIL, write_frame

__all__ = [
    "PlannedFrame",
    "TrackPlan",
    "Write",
    "merge_writes",
    "plan_xgo_track",
    "tick_us",
    "to_us",
]

BYTES = tuple(bytes((i,)) for i in range(256))
_EPS = 1e-9


def tick_us(k: int, rate: float) -> int:
    """Time of control tick ``k`` in integer microseconds."""
    return round(k * 1_000_000 / rate)


def first_tick(t: float, rate: float) -> int:
    """Index of the first tick at or after ``t`` seconds."""
    return math.ceil(t * rate - _EPS)


class Write(NamedTuple):
    """One register's bytes to send (at the tick it is filed under)."""

    address: int
    data: bytes
    origin: Origin | None
    order: int  # index of the cue in its track: authoring order breaks ties within a tick
    sample: bool  # a trajectory/fade sample: de-duplicated, and droppable when decimating
    duration: float = 0.0  # seconds a preset action runs


class PlannedFrame(NamedTuple):
    """A frame at its planned time, before pacing."""

    t_us: int
    data: bytes  # complete wire bytes
    # Every field in the frame, (address, bytes), and what the plan asked for (the gap fillers
    # are not there). Both empty in sample frames planned without details (plan_xgo_track)
    # and in xArm frames: pacing reads them only when decimating, and an xArm has no samples.
    fields: tuple[tuple[int, bytes], ...]
    written: tuple[Write, ...]
    origin: Origin | None
    order: int
    droppable: bool  # only samples in it
    action: bool  # starts a preset action
    duration: float = 0.0


@dataclass
class TrackPlan:
    """A performer's planned frames, the end of its part, and what went wrong."""

    frames: list[PlannedFrame]
    end: float
    diagnostics: list[Diagnostic]
    samples: int = 0  # planned frames that hold only samples


class _Source:
    """A cue that writes the same registers tick after tick: a move (one byte a register) or a fade.

    Its sample at a tick is one ``bytes`` of every register's bytes in address order, not a
    :class:`Write` per register: ticks that only sources write (nearly all of a long show) are
    turned into frames straight from those bytes (see :class:`_TickFrames`).
    """

    __slots__ = ("address_set", "addresses", "one", "order", "origin", "prev", "spans", "unit")

    def __init__(self, regs: Sequence[Register], origin: Origin | None, order: int) -> None:
        self.addresses = tuple(r.address for r in regs)  # ascending
        self.address_set = frozenset(self.addresses)
        spans: list[tuple[int, int]] = []
        at = 0
        for r in regs:
            spans.append((at, at + r.size))
            at += r.size
        self.spans = tuple(spans)  # each register's bytes within a sample
        self.unit = at == len(regs)  # one byte a register: a sample compares byte by byte
        self.one = len(regs) == 1  # one register (a fade): a sample compares whole
        self.origin = origin
        self.order = order
        # While "live" (see _TickFrames): the bytes its registers were last sent, which the
        # sent/known dictionaries are only told later. None otherwise.
        self.prev: bytes | None = None

    def writes(self, sample: bytes) -> list[Write]:
        """The sample as one Write per register (for ticks other cues write too)."""
        origin, order = self.origin, self.order
        return [
            Write(address, sample[b:e], origin, order, True)
            for address, (b, e) in zip(self.addresses, self.spans, strict=True)
        ]


class _Samples(list[tuple[_Source, bytes]]):
    """A tick several sources write, none of them the same register (e.g. a move and fades)."""


# What one tick holds: one source's sample (the common case), several sources' samples, or
# Writes (settings, actions, cut moves, and any tick where those meet samples).
_Entry = tuple[_Source, bytes] | _Samples | list[Write]


def _entry_writes(entry: _Entry) -> list[Write]:
    """Any tick entry as a list of Writes."""
    if isinstance(entry, tuple):
        return entry[0].writes(entry[1])
    if isinstance(entry, _Samples):
        return [w for src, sample in entry for w in src.writes(sample)]
    return entry


class _SampleFrame(NamedTuple):
    """One frame of a merge plan for a tick only sources write, by where its bytes come from."""

    address: int
    one: tuple[int, int, int] | None  # (chunk, begin, end): all its data from one sample slice
    pieces: tuple[tuple[int, int, int], ...]  # (chunk, begin, end), or (-1, address, 0): known
    prefix: bytes  # frame bytes before the data
    check_base: int  # length + type + address: the checksum's part that is not data
    lead: int  # the chunk whose cue the frame is filed under (the earliest cue in it)
    refills: tuple[int, ...]  # registers re-sent from ``known`` (they now count as sent)


def _link_cost_us(link: Link, nbytes: int) -> float:
    return link.wire_time(nbytes) * 1_000_000


def merge_writes(
    layout: Layout,
    link: Link,
    gap: float,
    t_us: int,
    writes: Iterable[Write],
    known: Mapping[int, bytes],
    *,
    action_address: int | None = None,
) -> list[PlannedFrame]:
    """Merge one tick's writes (at most one per address) into as few write frames as pays.

    ``known`` holds the bytes each register was last sent; registers that may be re-sent
    (:meth:`Layout.can_fill`) and are known can fill a gap between two runs. Filling ``n``
    bytes is chosen when it takes less link time than a separate frame (8 bytes + ``gap``).
    """
    merger = _Merger(layout, link, gap, action_address)
    return merger.merge(t_us, sorted(writes, key=_address), known, uniform=False)


class _FramePlan(NamedTuple):
    """One frame of a merge plan: the fields it carries, by where their bytes come from."""

    address: int
    slots: tuple[tuple[int, int], ...]  # (address, index into the tick's writes, or -1: filler)
    writes: tuple[int, ...]  # indices of the tick's writes in this frame
    nbytes: int  # data bytes (a cheap check that the writes have the sizes planned with)
    prefix: bytes  # frame bytes before the data
    check_base: int  # length + type + address: the checksum's part that is not data
    fills: bool  # whether any slot is a gap filler


class _Merger:
    """merge_writes for one performer, with merge plans cached.

    How one tick's writes group into frames depends only on their addresses and sizes and on
    which gap registers are known, and a show repeats the same few address sets tick after
    tick: the plan (which writes and fillers make which frame, its header bytes) is computed
    once per address set and reused while the set of known registers stays the same.
    """

    def __init__(
        self, layout: Layout, link: Link, gap: float, action_address: int | None
    ) -> None:
        self.layout = layout
        self.link = link
        self.action_address = action_address
        # Link time a frame costs beyond its data: its framing bytes plus the silence after.
        self.frame_cost_us = (link.wire_time(MIN_LENGTH) + gap) * 1_000_000
        self.plans: dict[tuple[int, ...], tuple[_FramePlan, ...]] = {}
        self.sample_plans: dict[object, tuple[_SampleFrame, ...]] = {}

    def forget_plans(self) -> None:
        """Call when registers become known or unknown: fillers depend on that."""
        self.plans.clear()
        self.sample_plans.clear()  # in place: _frames_from_ticks holds it

    def sample_plan(
        self,
        chunks: Sequence[tuple[_Source, bytes]],
        masks: Sequence[tuple[bool, ...]],
        known: Mapping[int, bytes],
    ) -> tuple[_SampleFrame, ...]:
        """The frames for a tick only sources write, given which registers changed (masks).

        The same grouping as :meth:`merge` on the changed registers' Writes; only, each field's
        bytes are located in the tick's samples (gap fillers too, when a source of the tick owns
        the register: its bytes there are the ones sent last) or else in ``known``. The plan
        depends on the sources' registers and their cues' order, not on the cues themselves:
        one plan serves every move over the same registers.
        """
        owner: dict[int, tuple[int, int, int]] = {}
        writes: list[Write] = []
        for ci, ((src, sample), mask) in enumerate(zip(chunks, masks, strict=True)):
            for address, (b, e), changed in zip(src.addresses, src.spans, mask, strict=True):
                owner[address] = (ci, b, e)
                if changed:
                    writes.append(Write(address, sample[b:e], src.origin, src.order, True))
        if not writes:
            return ()
        writes.sort(key=_address)
        frames: list[_SampleFrame] = []
        for run in self._plan(writes, known):
            pieces: list[tuple[int, int, int]] = []
            refills: list[int] = []
            for address, _ in run.slots:
                piece = owner.get(address)
                if piece is None:
                    piece = (-1, address, 0)
                    refills.append(address)
                if pieces and piece[0] >= 0 and pieces[-1][0] == piece[0] \
                        and pieces[-1][2] == piece[1]:
                    pieces[-1] = (piece[0], pieces[-1][1], piece[2])  # contiguous: one slice
                else:
                    pieces.append(piece)
            lead = min((writes[i] for i in run.writes), key=_order)  # as merge() files it
            frames.append(_SampleFrame(
                run.address,
                pieces[0] if len(pieces) == 1 and pieces[0][0] >= 0 else None,
                tuple(pieces), run.prefix, run.check_base, owner[lead.address][0],
                tuple(refills),
            ))
        if len(chunks) > 1:
            frames.sort(key=lambda f: (chunks[f.lead][0].order, f.address))
        return tuple(frames)

    def merge(
        self, t_us: int, ordered: Sequence[Write], known: Mapping[int, bytes], *, uniform: bool
    ) -> list[PlannedFrame]:
        """Frames for ``ordered`` (address order, one write per address) at ``t_us``.

        ``uniform``: the writes all come from one cue (same origin, order, kind), which spares
        the per-frame search for the lead write and the final sort.
        """
        if not ordered:
            return []
        key = tuple([w.address for w in ordered])
        plan = self.plans.get(key)
        if plan is None:
            plan = self.plans[key] = self._plan(ordered, known)
        frames = self._build(t_us, ordered, known, plan, uniform)
        if frames is None:  # sizes differ from the cached plan's: plan this tick afresh
            frames = self._build(t_us, ordered, known, self._plan(ordered, known), uniform)
            assert frames is not None
        if len(frames) > 1 and not uniform:
            frames.sort(key=_frame_order)
        return frames

    def _plan(self, ordered: Sequence[Write], known: Mapping[int, bytes]) -> tuple[_FramePlan, ...]:
        layout, link = self.layout, self.link
        frame_cost = self.frame_cost_us
        first = ordered[0]
        runs: list[list[tuple[int, int, int]]] = [[(first.address, 0, len(first.data))]]
        run_len = len(first.data)
        last_addr = first.address
        for i in range(1, len(ordered)):
            w = ordered[i]
            addr = w.address
            if addr == last_addr + 1 and run_len + len(w.data) <= MAX_DATA:
                runs[-1].append((addr, i, len(w.data)))
                run_len += len(w.data)
                last_addr = addr
                continue
            filler = _filler(layout, last_addr, addr, known)
            if filler:
                extra = sum(len(d) for _, d in filler)
                if (
                    run_len + extra + len(w.data) <= MAX_DATA
                    and _link_cost_us(link, extra) < frame_cost
                ):
                    run = runs[-1]
                    run.extend((a, -1, len(d)) for a, d in filler)
                    run.append((addr, i, len(w.data)))
                    run_len += extra + len(w.data)
                    last_addr = addr
                    continue
            runs.append([(addr, i, len(w.data))])
            run_len = len(w.data)
            last_addr = addr
        write_type = layout.profile.write_type
        plan: list[_FramePlan] = []
        for run in runs:
            address = run[0][0]
            nbytes = sum(n for _, _, n in run)
            if layout.walk(address, nbytes) is None:
                raise ProfileError(
                    f"{layout.profile.model}: {nbytes} bytes at 0x{address:02X} do not match "
                    "the register layout"
                )
            # The real encoder, on placeholder data: the same checks and the same header.
            template = write_frame(address, bytes(nbytes), write_type=write_type)
            plan.append(_FramePlan(
                address,
                tuple([(a, i) for a, i, _ in run]),
                tuple([i for _, i, _ in run if i >= 0]),
                nbytes,
                template[:len(template) - nbytes - 3],
                MIN_LENGTH + nbytes + write_type + address,
                any(i < 0 for _, i, _ in run),
            ))
        return tuple(plan)

    def _build(
        self,
        t_us: int,
        ordered: Sequence[Write],
        known: Mapping[int, bytes],
        plan: tuple[_FramePlan, ...],
        uniform: bool,
    ) -> list[PlannedFrame] | None:
        frames: list[PlannedFrame] = []
        action_address = self.action_address
        new = tuple.__new__
        for run in plan:
            if run.fills:
                fields = tuple([
                    (a, ordered[i].data if i >= 0 else known[a]) for a, i in run.slots
                ])
            else:
                fields = tuple([(a, ordered[i].data) for a, i in run.slots])
            data = b"".join([d for _, d in fields])
            if len(data) != run.nbytes:
                return None
            wire = _wire(run.prefix, run.check_base, data)
            written = tuple([ordered[i] for i in run.writes])
            lead = written[0]
            if uniform:
                # One cue: the same order and kind throughout.
                droppable = lead.sample
                action = not droppable and action_address is not None and any(
                    w.address == action_address for w in written
                )
                duration = 0.0 if droppable else max(0.0, lead.duration)
            else:
                droppable, action, duration = True, False, 0.0
                for w in written:
                    if w.order < lead.order:
                        lead = w
                    if not w.sample:
                        droppable = False
                        if w.address == action_address:
                            action = True
                        if w.duration > duration:
                            duration = w.duration
            frames.append(new(PlannedFrame, (
                t_us, wire, fields, written, lead.origin, lead.order, droppable, action,
                duration,
            )))
        return frames


def _wire(prefix: bytes, check_base: int, data: bytes) -> bytes:
    """A planned frame's wire bytes: its header (from a merge plan), data, checksum, tail.

    ``check_base`` is the checksum's part that is not data (length + type + address).
    """
    return b"".join((prefix, data, BYTES[~(check_base + sum(data)) & 0xFF], TAIL))


def _frame_order(f: PlannedFrame) -> tuple[int, int]:
    return (f.order, f.fields[0][0])


def _address(w: Write) -> int:
    return w.address


def _order(w: Write) -> int:
    return w.order


def _filler(
    layout: Layout, last: int, nxt: int, known: Mapping[int, bytes]
) -> list[tuple[int, bytes]] | None:
    """The known fields strictly between ``last`` and ``nxt``; None if the gap can't be filled."""
    out: list[tuple[int, bytes]] = []
    for addr in range(last + 1, nxt):
        reg = layout.by_address.get(addr)
        if reg is None or not layout.can_fill(reg) or addr not in known:
            return None
        out.append((addr, known[addr]))
    return out


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


def cue_label(origin: Origin) -> str:
    """How messages name a cue: by its name, else by its line."""
    return f"cue {origin.cue!r}" if origin.cue else f"the cue at line {origin.line}"


def _round_up(seconds: float) -> float:
    """Up to the next 0.01 s (float noise of 1e-6 s ignored)."""
    return math.ceil(seconds * 100 - 1e-4) / 100


def _limits_text(reg: Register, lim: Limits) -> str:
    u = reg.unit or "units"
    return (
        f"velocity {lim.velocity:g} {u}/s, acceleration {lim.acceleration:g} {u}/s², "
        f"jerk {lim.jerk:g} {u}/s³"
    )


class _XgoPlanner:
    """Walks one XGO performer's cues in order, keeping the commanded state as it goes."""

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
        self.ticks: dict[int, _Entry] = {}
        self.mixed: set[int] = set()  # ticks that more than one cue writes (see _emit)
        self.action_reg = layout.by_name.get(ACTION_REGISTER)
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
        for fade in self.fades:
            self._sample_fade(fade)

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
        bucket = _entry_writes(entry)
        if bucket is entry:
            bucket.extend(writes)
        else:
            self.ticks[t_us] = bucket + writes
        self.mixed.add(t_us)

    def _emit_sample(self, t_us: int, src: _Source, sample: bytes) -> None:
        """File a source's sample at ``t_us``; with Writes or a sample of the same register
        there, the tick becomes Writes (mixed)."""
        entry = self.ticks.get(t_us)
        if entry is None:
            self.ticks[t_us] = (src, sample)
            return
        mine = src.address_set
        if isinstance(entry, tuple):
            if mine.isdisjoint(entry[0].addresses):
                self.ticks[t_us] = _Samples((entry, (src, sample)))
                return
        elif isinstance(entry, _Samples):
            for other, _ in entry:
                if not mine.isdisjoint(other.addresses):
                    break
            else:
                entry.append((src, sample))
                return
        self._emit(t_us, src.writes(sample))

    def _take_over(self, name: str, t: float) -> DofState | None:
        """A cue writes ``name`` at ``t``: stop sampling a move still running on it.

        Returns the state the move had reached, or None if no move was running.
        """
        entry = self.active.get(name)
        if entry is None:
            return None
        run, dof = entry
        if run.cuts[dof] is not None or t >= run.plan.end - _EPS:
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
        if fade is None or fade.cut is not None or t >= fade.cue.start + fade.cue.duration - _EPS:
            return None
        fade.cut = t
        return fade.colour_at(t)

    def _sample_fade(self, fade: _Fade) -> None:
        """Steps on the tick grid strictly before the end, then the exact colour at the end
        itself (as a move's last sample: never after it, over a cue starting there). A fade
        another cue cut stops before that cue's start, with no final colour."""
        cue, rate = fade.cue, self.rate
        stop_us = to_us(cue.start + cue.duration if fade.cut is None else fade.cut)
        src = _Source((fade.reg,), cue.origin, fade.order)
        ticks, emit = self.ticks, self._emit_sample
        t0, duration = cue.start, cue.duration
        (r0, g0, b0), (r1, g1, b1) = fade.start, cue.to
        dr, dg, db = r1 - r0, g1 - g0, b1 - b0
        k = first_tick(t0, rate)
        # tick_us(k, rate) and fade.colour_at, inlined: this runs for every tick of every fade
        while duration > 0 and (t_us := round(k * 1_000_000 / rate)) < stop_us:
            frac = min(max((k / rate - t0) / duration, 0.0), 1.0)
            sample = bytes((round(r0 + dr * frac), round(g0 + dg * frac), round(b0 + db * frac)))
            if t_us in ticks:
                emit(t_us, src, sample)
            else:
                ticks[t_us] = (src, sample)  # emit's common case, inlined
            k += 1
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
            diag.error(
                cue.origin,
                # Rounded up: "at least 0.51 s" must be enough, and never read like "0.50 s"
                # when 0.50 s was given and falls short.
                f"{cue_label(cue.origin)} needs at least {_round_up(exc.minimum):.2f} s under "
                "its limits "
                f"({reg.name}: {_limits_text(reg, limits[exc.dof])}) but is given "
                f"{exc.requested:.2f} s",
            )
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
        tables = [self.layout.byte_table(reg) for reg in run.regs]
        # While every DoF is sampled and the whole move (ruckig's exact extrema, and the
        # targets) lies within each register's range, all bytes of a tick come from one
        # C-level map of bisect over the tables: the hot loop of the compiler.
        in_range = all(
            t.lo <= lo and hi <= t.hi and t.lo <= x <= t.hi
            for t, (lo, hi), x in zip(tables, plan.extrema(), targets, strict=True)
        )
        full = min(stops, default=k0 - 1) if in_range else k0 - 1
        padded = [t.padded for t in tables]
        # Elsewhere, the table per DoF (out of range, Register.to_byte raises the usual error).
        spec = [(reg.address, t) for reg, t in zip(run.regs, tables, strict=True)]
        origin, order = run.origin, run.order
        src = _Source(run.regs, origin, order)
        ticks = self.ticks
        emit, emit_sample = self._emit, self._emit_sample
        new = tuple.__new__
        # The hot loop of the compiler: the ticks before the end with every DoF sampled.
        for k in range(k0, min(full, k_end - 1) + 1):
            t_us = round(k * 1_000_000 / rate)  # tick_us(k, rate), inlined
            sample = bytes(map(bisect_right, padded, at_time(max(k / rate - start, 0.0))[0]))
            if t_us in ticks:
                emit_sample(t_us, src, sample)
            else:
                ticks[t_us] = (src, sample)  # emit_sample's common case, inlined
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
            for i, (address, table) in enumerate(spec):
                if k <= stops[i]:
                    writes.append(new(Write, (
                        address, BYTES[table(pos[i])], origin, order, True, 0.0
                    )))
            emit(t_us, writes)


class _TickFrames:
    """Frames for one performer's ticks, in time order: de-duplication, merging, state.

    ``sent`` holds what each register was last sent (unchanged samples drop); ``known`` what
    each register holds as far as we know (gap fillers re-send these bytes): the initial values
    at the start, and nothing after a preset action until sent again.

    Ticks only sources write (samples of moves and fades: nearly all of a long show) take a
    faster road to the same frames: which registers changed is a byte comparison with the
    source's previous sample, the merge plan is cached per (registers, changed registers), and
    a frame's data is mostly one slice of a sample. Such sources stay *live*: their registers
    hold their ``prev`` sample, which sent/known learn only when the source is flushed, before
    anything else reads those registers (another cue's tick, a tick without the source).
    """

    def __init__(self, layout: Layout, link: Link, gap: float, action_reg: Register | None
                 ) -> None:
        self.merger = _Merger(layout, link, gap,
                              action_reg.address if action_reg is not None else None)
        self.sent: dict[int, bytes] = {}
        self.known: dict[int, bytes] = {
            r.address: r.initial for r in layout.profile.registers if r.initial is not None
        }
        self.n_known = len(self.known)
        self.frames: list[PlannedFrame] = []
        self.samples = 0  # frames holding only samples
        self.live: list[_Source] = []
        self.shapes: dict[tuple[_Source, ...], object] = {}  # see sources_tick

    def _known_changed(self) -> None:
        if len(self.known) != self.n_known:  # fillers depend on which registers are known
            self.n_known = len(self.known)
            self.merger.forget_plans()

    def flush(self, keep: Container[_Source] = ()) -> None:
        """Tell sent/known the live sources' samples (but those in ``keep``, which stay live)."""
        sent, known = self.sent, self.known
        for src in self.live:
            if src in keep:
                continue
            prev = src.prev
            assert prev is not None
            for address, (b, e) in zip(src.addresses, src.spans, strict=True):
                sent[address] = known[address] = prev[b:e]
            src.prev = None
        self.live[:] = [src for src in self.live if src in keep]  # in place: see the loop

    def _fresh(self, src: _Source, sample: bytes) -> tuple[bool, ...]:
        """Registers of a source not live that differ from what was sent; it becomes live."""
        sent, known = self.sent, self.known
        mask = []
        for address, (b, e) in zip(src.addresses, src.spans, strict=True):
            part = sample[b:e]
            changed = sent.get(address) != part
            if changed:  # told now: the register may be new to ``known``
                sent[address] = known[address] = part
            mask.append(changed)
        src.prev = sample
        self.live.append(src)
        return tuple(mask)

    def source_tick(self, t_us: int, src: _Source, sample: bytes) -> None:
        """A tick only ``src`` writes, ``src`` not the one live source (it becomes so).

        The next tick of the one live source is :func:`_frames_from_ticks`'s own (inlined).
        """
        self.flush()
        mask = self._fresh(src, sample)
        self._known_changed()
        self.build(t_us, (src.addresses, mask), ((src, sample),), (mask,), (src,))

    def sources_tick(self, t_us: int, chunks: _Samples) -> None:
        """A tick several sources write, none the same register."""
        sources = [src for src, _ in chunks]
        if self.live != sources and self.live:
            self.flush(sources)
        masks = []
        fresh = False
        for src, sample in chunks:
            prev = src.prev
            if prev is None:
                masks.append(self._fresh(src, sample))
                fresh = True
            else:
                masks.append(_changes(src, sample, prev))
                src.prev = sample
        if fresh:
            self._known_changed()
        # The plan depends on the sources' registers and the order of their cues only.
        group = tuple(sources)
        shape = self.shapes.get(group)
        if shape is None:
            shape = self.shapes[group] = (
                tuple([src.addresses for src in sources]),
                tuple(sorted(range(len(sources)), key=lambda i: sources[i].order)),
            )
        self.build(t_us, (shape, tuple(masks)), chunks, masks, sources)

    def build(
        self,
        t_us: int,
        key: object,
        chunks: Sequence[tuple[_Source, bytes]],
        masks: Sequence[tuple[bool, ...]],
        sources: Sequence[_Source],
    ) -> None:
        """The frames of a tick only sources write, by the sample plan cached under ``key``."""
        plans = self.merger.sample_plans
        plan = plans.get(key)
        if plan is None:
            plan = plans[key] = self.merger.sample_plan(chunks, masks, self.known)
        append = self.frames.append
        new = tuple.__new__
        for f in plan:
            one = f.one
            if one is not None:
                data = chunks[one[0]][1][one[1]:one[2]]
            else:
                known = self.known
                data = b"".join([
                    chunks[ci][1][b:e] if ci >= 0 else known[b] for ci, b, e in f.pieces
                ])
                for address in f.refills:  # re-sent: now it counts as sent too
                    self.sent[address] = known[address]
            lead = sources[f.lead]
            append(new(PlannedFrame, (
                t_us,
                _wire(f.prefix, f.check_base, data),
                (), (), lead.origin, lead.order, True, False, 0.0,
            )))
        self.samples += len(plan)

    def writes_tick(self, t_us: int, bucket: list[Write], mixed: bool) -> None:
        """A tick of Writes: keep the last write per register, drop unchanged samples, merge.

        Unless ``mixed``, the tick holds one cue's writes, one per register in address order,
        which need no sorting nor de-duplication.
        """
        if self.live:
            self.flush()
        sent, known = self.sent, self.known
        get = sent.get
        keep: Sequence[Write]
        if mixed:
            chosen: dict[int, Write] = {}
            for w in sorted(bucket, key=_order):  # stable: emit order breaks ties
                chosen[w.address] = w
            keep = [w for w in chosen.values() if not (w.sample and get(w.address) == w.data)]
            keep.sort(key=_address)
        else:
            keep = [w for w in bucket if get(w.address) != w.data] if bucket[0].sample else bucket
        if not keep:
            return
        tick_frames = self.merger.merge(t_us, keep, known, uniform=not mixed)
        self.frames.extend(tick_frames)
        action = False
        for f in tick_frames:
            self.samples += f.droppable
            action = action or f.action
            sent.update(f.fields)  # gap fillers included: they went out too
            known.update(f.fields)
        if action:
            # A preset action moves the robot on its own: what it holds afterwards is unknown,
            # so nothing counts as already sent (and nothing is re-sent as a gap filler).
            sent.clear()
            known.clear()
        self._known_changed()


def _changes(src: _Source, sample: bytes, prev: bytes) -> tuple[bool, ...]:
    """Which registers of a live source differ from its previous sample."""
    if src.unit:
        return tuple(map(ne, sample, prev))
    if src.one:
        return (sample != prev,)
    return tuple([sample[b:e] != prev[b:e] for b, e in src.spans])


def _frames_from_ticks(
    layout: Layout,
    link: Link,
    gap: float,
    ticks: Mapping[int, _Entry],
    mixed: Container[int],
    action_reg: Register | None,
    details: bool = True,
) -> tuple[list[PlannedFrame], int]:
    """Every tick's frames in time order, and how many hold only samples (see _TickFrames).

    ``mixed`` names the ticks that more than one cue wrote. Without ``details``, frames of
    ticks only sources write carry no ``fields`` nor ``written`` (pacing reads those only to
    decimate); with it, every tick goes through Writes.
    """
    out = _TickFrames(layout, link, gap, action_reg)
    source_tick, sources_tick, writes_tick = out.source_tick, out.sources_tick, out.writes_tick
    build = out.build
    # Held across the loop: _TickFrames updates these in place.
    live, plans, append = out.live, out.merger.sample_plans, out.frames.append
    new = tuple.__new__
    for t_us in sorted(ticks):
        entry = ticks[t_us]
        if details:
            writes_tick(t_us, _entry_writes(entry),
                        t_us in mixed or isinstance(entry, _Samples))
        elif isinstance(entry, tuple):  # one source's sample: nearly every tick
            src, sample = entry
            prev = src.prev
            # prev is set exactly while src is live: else src is not the one live source.
            if prev is None or len(live) != 1:
                source_tick(t_us, src, sample)
                continue
            # The commonest tick of all: the next sample of the one live source.
            if sample == prev:
                continue
            src.prev = sample
            mask = tuple(map(ne, sample, prev)) if src.unit else _changes(src, sample, prev)
            key = (src.addresses, mask)
            plan = plans.get(key)
            if plan is not None and len(plan) == 1 and (one := plan[0].one) is not None:
                # build() for its commonest plan, inlined (and _wire): one frame, one slice of
                # the sample.
                f = plan[0]
                data = sample[one[1]:one[2]]
                append(new(PlannedFrame, (
                    t_us,
                    b"".join((f.prefix, data, BYTES[~(f.check_base + sum(data)) & 0xFF], TAIL)),
                    (), (), src.origin, src.order, True, False, 0.0,
                )))
                out.samples += 1
            else:
                build(t_us, key, ((src, sample),), (mask,), (src,))
        elif isinstance(entry, _Samples):
            sources_tick(t_us, entry)
        else:
            writes_tick(t_us, entry, t_us in mixed)
    return out.frames, out.samples


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
    planner = _XgoPlanner(layout, track, rate)
    planner.plan()
    frames, samples = _frames_from_ticks(
        layout, link, gap, planner.ticks, planner.mixed, planner.action_reg, details
    )
    return TrackPlan(frames, planner.end, planner.diag.items, samples)
