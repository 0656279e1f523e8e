"""One tick's writes -> as few write frames as pays: the general path (and the reference).

Registers at consecutive addresses share one write frame (the layout is :meth:`Profile.walk`'s),
and two runs separated by a small gap are joined by re-sending the bytes the gap registers
already hold, when that costs less link time than a separate frame would (8 bytes of frame
overhead plus the silence between frames). How a tick's writes group depends only on their
addresses and sizes and on which gap registers are known: :class:`Merger` plans it once per
address set and reuses the plan.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import NamedTuple

from xgo_show.compiler.frames import BYTES, PlannedFrame, Write
from xgo_show.compiler.layout import Layout
from xgo_show.errors import ProfileError
from xgo_show.profiles.model import Link
from xgo_show.wire.xgo import MAX_DATA, MIN_LENGTH, TAIL, write_frame

__all__ = ["FramePlan", "Merger", "Slot", "by_address", "by_order", "merge_writes", "wire_bytes"]


def link_cost_us(link: Link, nbytes: int) -> float:
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
    merger = Merger(layout, link, gap, action_address)
    return merger.merge(t_us, sorted(writes, key=by_address), known, uniform=False)


class Slot(NamedTuple):
    """One field of a planned frame: a register and where its bytes come from."""

    address: int
    write: int | None  # index into the tick's writes; None: a gap filler (``known`` bytes)


class FramePlan(NamedTuple):
    """One frame of a merge plan: the fields it carries, by where their bytes come from."""

    address: int
    slots: tuple[Slot, ...]  # every field of the frame, in address order
    writes: tuple[int, ...]  # indices of the tick's writes in this frame
    nbytes: int  # data bytes (a cheap check that the writes have the sizes planned with)
    prefix: bytes  # frame bytes before the data
    check_base: int  # length + type + address: the checksum's part that is not data
    fills: bool  # whether any slot is a gap filler


class Merger:
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
        self.plans: dict[tuple[int, ...], tuple[FramePlan, ...]] = {}

    def forget_plans(self) -> None:
        """Call when registers become known or unknown: fillers depend on that."""
        self.plans.clear()

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
            plan = self.plans[key] = self.plan_runs(ordered, known)
        frames = self._build(t_us, ordered, known, plan, uniform)
        if frames is None:  # sizes differ from the cached plan's: plan this tick afresh
            frames = self._build(t_us, ordered, known, self.plan_runs(ordered, known), uniform)
            assert frames is not None
        if len(frames) > 1 and not uniform:
            frames.sort(key=frame_order)
        return frames

    def plan_runs(
        self, ordered: Sequence[Write], known: Mapping[int, bytes]
    ) -> tuple[FramePlan, ...]:
        """Which writes (and gap fillers from ``known``) make which frame, and its header."""
        layout, link = self.layout, self.link
        frame_cost = self.frame_cost_us
        first = ordered[0]
        # (address, index into ordered or None for a gap filler, data bytes) per field
        runs: list[list[tuple[int, int | None, int]]] = [[(first.address, 0, len(first.data))]]
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
            fill = filler(layout, last_addr, addr, known)
            if fill:
                extra = sum(len(d) for _, d in fill)
                if (
                    run_len + extra + len(w.data) <= MAX_DATA
                    and link_cost_us(link, extra) < frame_cost
                ):
                    run = runs[-1]
                    run.extend((a, None, len(d)) for a, d in fill)
                    run.append((addr, i, len(w.data)))
                    run_len += extra + len(w.data)
                    last_addr = addr
                    continue
            runs.append([(addr, i, len(w.data))])
            run_len = len(w.data)
            last_addr = addr
        write_type = layout.profile.write_type
        plan: list[FramePlan] = []
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
            plan.append(FramePlan(
                address,
                tuple([Slot(a, i) for a, i, _ in run]),
                tuple([i for _, i, _ in run if i is not None]),
                nbytes,
                template[:len(template) - nbytes - 3],
                MIN_LENGTH + nbytes + write_type + address,
                any(i is None for _, i, _ in run),
            ))
        return tuple(plan)

    def _build(
        self,
        t_us: int,
        ordered: Sequence[Write],
        known: Mapping[int, bytes],
        plan: tuple[FramePlan, ...],
        uniform: bool,
    ) -> list[PlannedFrame] | None:
        frames: list[PlannedFrame] = []
        action_address = self.action_address
        for run in plan:
            if run.fills:
                fields = tuple([
                    (a, known[a] if i is None else ordered[i].data) for a, i in run.slots
                ])
            else:  # no filler: every slot names a write
                fields = tuple([(a, ordered[i].data) for a, i in run.slots if i is not None])
            data = b"".join([d for _, d in fields])
            if len(data) != run.nbytes:
                return None
            frame = wire_bytes(run.prefix, run.check_base, data)
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
            frames.append(PlannedFrame(
                t_us, frame, fields, written, lead.origin, lead.order, droppable, action,
                duration,
            ))
        return frames


def wire_bytes(prefix: bytes, check_base: int, data: bytes) -> bytes:
    """A planned frame's wire bytes: its header (from a merge plan), data, checksum, tail.

    ``check_base`` is the checksum's part that is not data (length + type + address).
    """
    return b"".join((prefix, data, BYTES[~(check_base + sum(data)) & 0xFF], TAIL))


def frame_order(f: PlannedFrame) -> tuple[int, int]:
    return (f.order, f.fields[0][0])


def by_address(w: Write) -> int:
    return w.address


def by_order(w: Write) -> int:
    return w.order


def filler(
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
