"""Ticks in time order -> frames: de-duplication, state, and the fast road for sample ticks.

:class:`TickFrames` keeps what each register was last sent and what it holds, drops samples
that change nothing, and hands ticks of Writes to the general merger
(:mod:`~xgo_show.compiler.merge`). Ticks only moves and fades write (nearly all of a long show)
take a faster road to the very same frames: which registers changed is a byte comparison with
the source's previous sample, the frame plan is cached per (registers, changed registers) and,
for a stretch of ticks, found by each tick's change code (:func:`~xgo_show.compiler.sources.
change_codes`, made for the whole stretch at once), and a frame's data is mostly one slice of a
sample. The frames go out as columns (:class:`~xgo_show.compiler.frames.PlannedFrames`), which
pacing and the schedule read as they are. ``tests/compiler/test_fast_path.py`` checks the two
roads give the same frames on random tracks (``details=True`` takes the general one).
"""

from __future__ import annotations

from collections.abc import Container, Mapping, Sequence
from itertools import chain, compress, groupby, repeat
from operator import itemgetter, ne
from typing import NamedTuple, cast

from xgo_show.compiler.frames import BYTES, PlannedFrames, Write
from xgo_show.compiler.layout import Layout
from xgo_show.compiler.merge import Merger, by_address, by_order
from xgo_show.compiler.sources import (
    Entry,
    Samples,
    Source,
    change_codes,
    changes,
    entry_writes,
)
from xgo_show.profiles.model import Link, Register
from xgo_show.wire.xgo import TAIL

__all__ = ["Piece", "SampleFrame", "TickFrames", "frames_from_ticks", "sample_plan"]

_HEAD, _SAMPLE = itemgetter(0), itemgetter(1)


class Piece(NamedTuple):
    """Where some of a frame's data comes from: a slice of one of the tick's samples, or the
    bytes a register is known to hold (a gap filler no source of the tick owns)."""

    chunk: int | None  # index of the tick's sample; None: ``known[address]``
    begin: int
    end: int
    address: int


class SampleFrame(NamedTuple):
    """One frame of a merge plan for a tick only sources write, by where its bytes come from."""

    address: int
    one: Piece | None  # the piece holding all its data, when that is one sample slice
    pieces: tuple[Piece, ...]  # its data, piece by piece
    prefix: bytes  # frame bytes before the data
    check_base: int  # length + type + address: the checksum's part that is not data
    lead: int  # the chunk whose cue the frame is filed under (the earliest cue in it)
    refills: tuple[int, ...]  # registers re-sent from ``known`` (they now count as sent)


def sample_plan(
    merger: Merger,
    chunks: Sequence[tuple[Source, bytes]],
    masks: Sequence[tuple[bool, ...]],
    known: Mapping[int, bytes],
) -> tuple[SampleFrame, ...]:
    """The frames for a tick only sources write, given which registers changed (masks).

    The same grouping as :meth:`Merger.merge` on the changed registers' Writes; only, each field's
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
    writes.sort(key=by_address)
    frames: list[SampleFrame] = []
    for run in merger.plan_runs(writes, known):
        pieces: list[Piece] = []
        refills: list[int] = []
        for address, _ in run.slots:
            found = owner.get(address)
            if found is None:
                piece = Piece(None, 0, 0, address)
                refills.append(address)
            else:
                piece = Piece(*found, address)
            last = pieces[-1] if pieces else None
            if (last is not None and piece.chunk is not None and last.chunk == piece.chunk
                    and last.end == piece.begin):
                pieces[-1] = last._replace(end=piece.end)  # contiguous: one slice
            else:
                pieces.append(piece)
        lead = min((writes[i] for i in run.writes), key=by_order)  # as merge() files it
        frames.append(SampleFrame(
            run.address,
            pieces[0] if len(pieces) == 1 and pieces[0].chunk is not None else None,
            tuple(pieces), run.prefix, run.check_base, owner[lead.address][0],
            tuple(refills),
        ))
    if len(chunks) > 1:
        frames.sort(key=lambda f: (chunks[f.lead][0].order, f.address))
    return tuple(frames)


class TickFrames:
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
        self.merger = Merger(layout, link, gap,
                              action_reg.address if action_reg is not None else None)
        self.sent: dict[int, bytes] = {}
        self.known: dict[int, bytes] = {
            r.address: r.initial for r in layout.profile.registers if r.initial is not None
        }
        self.n_known = len(self.known)
        self.frames = PlannedFrames()
        self.samples = 0  # frames holding only samples
        self.live: list[Source] = []
        self.shapes: dict[tuple[Source, ...], int] = {}  # see sources_tick
        self.shape_numbers: dict[object, int] = {}
        # Frame plans of ticks only sources write, by (registers, changed registers): see build
        self.sample_plans: dict[object, tuple[SampleFrame, ...]] = {}
        # Of those for one source, by its registers then by change code (see
        # sources.change_codes): the plans that are one frame of one slice of the sample, as
        # (prefix, check_base, begin, end); None: another plan. stretch's road.
        self.slices: dict[tuple[int, ...], dict[bytes, tuple[bytes, int, int, int] | None]] = {}
        # Of those for several sources, by shape (see sources_tick) then by the sources' change
        # codes: the plans whose every frame is one slice of one of the tick's samples, as
        # (chunk, begin, end, prefix, check_base, lead chunk) a frame; None: another plan.
        # samples_stretch's road.
        self.rows: dict[int, dict[tuple[bytes, ...], tuple[tuple[int, int, int, bytes, int, int],
                                                           ...] | None]] = {}

    def _known_changed(self) -> None:
        if len(self.known) != self.n_known:  # fillers depend on which registers are known
            self.n_known = len(self.known)
            self.merger.forget_plans()
            self.sample_plans.clear()
            self.slices.clear()
            self.rows.clear()

    def flush(self, keep: Container[Source] = ()) -> None:
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

    def _fresh(self, src: Source, sample: bytes) -> tuple[bool, ...]:
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

    def source_sample(self, t_us: int, src: Source, sample: bytes) -> None:
        """A tick only ``src`` writes, the first of a stretch of them (or alone): every live
        source is flushed (``src`` too, when it wrote the tick before beside others), ``src``'s
        registers are compared with what was sent, and it becomes the one live source.

        The tick before is never ``src``'s alone: :func:`frames_from_ticks` hands such ticks
        on together, to :meth:`stretch`.
        """
        self.flush()
        mask = self._fresh(src, sample)
        self._known_changed()
        self.build(t_us, (src.addresses, mask), ((src, sample),), (mask,), (src,))

    def sources_tick(self, t_us: int, chunks: Samples) -> None:
        """A tick several sources write, none the same register, the first of a stretch of
        ticks these sources write (the tick before was not theirs: :func:`frames_from_ticks`
        hands on their consecutive ticks together, to :meth:`samples_stretch`).

        Live sources of the tick stay live, compared with their previous samples; the others
        are flushed, and the tick's new sources compared with what was sent.
        """
        sources = [src for src, _ in chunks]
        masks: list[tuple[bool, ...]] = []
        if self.live:
            self.flush(sources)
        fresh = False
        for src, sample in chunks:
            prev = src.prev
            if prev is None:
                masks.append(self._fresh(src, sample))
                fresh = True
            else:
                masks.append(changes(src, sample, prev))
                src.prev = sample
        if fresh:
            self._known_changed()
        # The plan depends on the sources' registers and the order of their cues only: one
        # small number per such shape (cheaper to hash, tick after tick, than the shape).
        group = tuple(sources)
        shape = self.shapes.get(group)
        if shape is None:
            value = (
                tuple([src.addresses for src in sources]),
                tuple(sorted(range(len(sources)), key=lambda i: sources[i].order)),
            )
            shape = self.shapes[group] = self.shape_numbers.setdefault(
                value, len(self.shape_numbers))
        self.build(t_us, (shape, tuple(masks)), chunks, masks, sources)

    def plan(
        self, key: object, chunks: Sequence[tuple[Source, bytes]],
        masks: Sequence[tuple[bool, ...]],
    ) -> tuple[SampleFrame, ...]:
        """The sample plan for ``key`` (see :meth:`build`), made once."""
        plan = self.sample_plans.get(key)
        if plan is None:
            plan = self.sample_plans[key] = sample_plan(self.merger, chunks, masks, self.known)
        return plan

    def build(
        self,
        t_us: int,
        key: object,
        chunks: Sequence[tuple[Source, bytes]],
        masks: Sequence[tuple[bool, ...]],
        sources: Sequence[Source],
    ) -> None:
        """The frames of a tick only sources write, by the sample plan cached under ``key``."""
        plan = self.plan(key, chunks, masks)
        wire: list[bytes] = []
        leads: list[Source] = []
        # Each SampleFrame unpacked at once (cheaper than reading its fields one by one).
        for _, one, pieces, prefix, check_base, lead_chunk, refills in plan:
            if one is not None:
                chunk, begin, end, _ = one
                data = chunks[chunk][1][begin:end]  # type: ignore[index]
            else:
                known = self.known
                data = b"".join([
                    known[address] if chunk is None else chunks[chunk][1][begin:end]
                    for chunk, begin, end, address in pieces
                ])
                for address in refills:  # re-sent: now it counts as sent too
                    self.sent[address] = known[address]
            leads.append(sources[lead_chunk])
            # merge.wire_bytes inlined: once per frame of a long show
            wire.append(b"".join((prefix, data, BYTES[~(check_base + sum(data)) & 0xFF], TAIL)))
        self.frames.add_samples([t_us] * len(wire), wire, [lead.origin for lead in leads],
                                [lead.order for lead in leads])
        self.samples += len(plan)

    def stretch(self, times: Sequence[int], pairs: Sequence[tuple[Source, bytes]]) -> None:
        """Consecutive ticks only one source writes (``pairs``: its samples at ``times``).

        :meth:`source_sample` of each, list by list: after the first tick the source is the
        one live source, each sample is compared with the one before, and the frames whose
        plan is one slice of the sample (nearly all) are made in one comprehension.
        """
        src, first = pairs[0]
        self.source_sample(times[0], src, first)
        samples = list(map(_SAMPLE, pairs))
        src.prev = samples[-1]  # or an equal sample (a tick repeating it sends nothing)
        codes = change_codes(samples)
        rest, prevs, ts = samples[1:], samples[:-1], times[1:]
        unchanged = bytes(len(first))
        if unchanged in codes:  # the sample before repeated: that tick sends nothing
            changed = list(map(ne, codes, repeat(unchanged)))
            rest = list(compress(rest, changed))
            prevs = list(compress(prevs, changed))
            ts = list(compress(ts, changed))
            codes = list(compress(codes, changed))
            if not rest:
                return
        table = self.slices.get(src.addresses)
        if table is None:
            table = self.slices[src.addresses] = {}
        cuts = list(map(table.get, codes))
        if None in cuts:  # plans not made yet, or not one slice (build() makes those frames)
            at = cuts.index(None)
            while True:
                if codes[at] not in table:
                    mask = changes(src, rest[at], prevs[at])
                    table[codes[at]] = _slice_plan(
                        self.plan((src.addresses, mask), ((src, rest[at]),), (mask,)))
                    cuts = list(map(table.get, codes))
                try:
                    at = cuts.index(None, at + 1)
                except ValueError:
                    break
        frames, origin, order = self.frames, src.origin, src.order
        at, count = 0, len(cuts)
        while at < count:
            try:
                stop = cuts.index(None, at)
            except ValueError:
                stop = count
            if stop > at:
                # build() for a one-slice plan, inlined, tick after tick
                wire = [
                    b"".join((prefix, data := sample[begin:end],
                              BYTES[~(check_base + sum(data)) & 0xFF], TAIL))
                    for sample, (prefix, check_base, begin, end) in zip(
                        rest[at:stop], cast(list[tuple[bytes, int, int, int]], cuts[at:stop]),
                        strict=True)
                ]
                frames.add_run(ts[at:stop], wire, origin, order)
                self.samples += stop - at
            if stop < count:
                mask = changes(src, rest[stop], prevs[stop])
                self.build(ts[stop], (src.addresses, mask), ((src, rest[stop]),), (mask,),
                           (src,))
            at = stop + 1

    def samples_stretch(self, sources: tuple[Source, ...], times: Sequence[int],
                        rows: Sequence[Samples]) -> None:
        """Consecutive ticks the same several sources write (``rows``, at ``times``).

        :meth:`sources_tick` of each, list by list: after the first tick every source is live,
        each one's samples are compared with the ones before, and the ticks whose plan makes
        each frame of one slice of one sample (nearly all) are made in one comprehension.
        """
        self.sources_tick(times[0], rows[0])
        rest, ts = rows[1:], times[1:]
        if not rest:
            return
        columns: list[list[bytes]] = []
        for j, src in enumerate(sources):
            column = list(map(_SAMPLE, map(itemgetter(j), rows)))
            columns.append(change_codes(column))
            src.prev = column[-1]
        codes = list(zip(*columns, strict=True))
        shape = self.shapes[sources]
        table = self.rows.get(shape)
        if table is None:
            table = self.rows[shape] = {}
        plans = list(map(table.get, codes))
        if None in plans:  # plans not made yet, or not of one slice a frame
            at = plans.index(None)
            while True:
                if codes[at] not in table:
                    masks = _masks(rest[at], rows[at])
                    table[codes[at]] = _row_plan(self.plan((shape, masks), rest[at], masks))
                    plans = list(map(table.get, codes))
                try:
                    at = plans.index(None, at + 1)
                except ValueError:
                    break
        frames = self.frames
        origins = [src.origin for src in sources]
        orders = [src.order for src in sources]
        at, count = 0, len(plans)
        while at < count:
            try:
                stop = plans.index(None, at)
            except ValueError:
                stop = count
            if stop > at:
                # build() for each tick, inlined (its one-slice frames only), column by column
                block = cast(list[tuple[tuple[int, int, int, bytes, int, int], ...]],
                             plans[at:stop])
                wire = [
                    b"".join((prefix, data := row[chunk][1][begin:end],
                              BYTES[~(check_base + sum(data)) & 0xFF], TAIL))
                    for row, plan in zip(rest[at:stop], block, strict=True)
                    for chunk, begin, end, prefix, check_base, _ in plan
                ]
                leads = [frame[5] for plan in block for frame in plan]
                frames.add_samples(
                    list(chain.from_iterable(map(repeat, ts[at:stop], map(len, block)))), wire,
                    list(map(origins.__getitem__, leads)), list(map(orders.__getitem__, leads)))
                self.samples += sum(map(len, plans[at:stop]))  # type: ignore[arg-type]
            if stop < count:
                masks = _masks(rest[stop], rows[stop])
                self.build(ts[stop], (shape, masks), rest[stop], masks, sources)
            at = stop + 1

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
            for w in sorted(bucket, key=by_order):  # stable: emit order breaks ties
                chosen[w.address] = w
            keep = [w for w in chosen.values() if not (w.sample and get(w.address) == w.data)]
            keep.sort(key=by_address)
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


def _slice_plan(plan: tuple[SampleFrame, ...]) -> tuple[bytes, int, int, int] | None:
    """A sample plan of one source as stretch reads it: (prefix, check_base, begin, end) when
    it is one frame of one slice of the sample, else None."""
    one = plan[0].one if len(plan) == 1 else None
    return None if one is None else (plan[0].prefix, plan[0].check_base, one.begin, one.end)


def _masks(row: Samples, before: Samples) -> tuple[tuple[bool, ...], ...]:
    """:func:`~xgo_show.compiler.sources.changes` of each source of a tick (``row``) since the
    tick before (``before``: the same sources)."""
    return tuple([changes(src, sample, prev)
                  for (src, sample), (_, prev) in zip(row, before, strict=True)])


def _row_plan(plan: tuple[SampleFrame, ...]) -> tuple[tuple[int, int, int, bytes, int, int],
                                                      ...] | None:
    """A sample plan of several sources as samples_stretch reads it (None: not every frame is
    one slice of one sample). The plan serves any sources of its shape: a frame names its lead
    by chunk."""
    out = []
    for frame in plan:
        if frame.one is None or frame.one.chunk is None:
            return None
        out.append((frame.one.chunk, frame.one.begin, frame.one.end, frame.prefix,
                    frame.check_base, frame.lead))
    return tuple(out)


def frames_from_ticks(
    layout: Layout,
    link: Link,
    gap: float,
    ticks: Mapping[int, Entry],
    mixed: Container[int],
    action_reg: Register | None,
    details: bool = True,
) -> tuple[PlannedFrames, int]:
    """Every tick's frames in time order, and how many hold only samples (see TickFrames).

    ``mixed`` names the ticks that more than one cue wrote. Without ``details``, frames of
    ticks only sources write carry no ``fields`` nor ``written`` (pacing reads those only to
    decimate); with it, every tick goes through Writes.
    """
    out = TickFrames(layout, link, gap, action_reg)
    filed = list(ticks)
    times = sorted(filed)
    # The planner files a long show's ticks in time order (a move's, then the next's): its
    # entries are then the mapping's values, without a look-up a tick.
    entries = list(ticks.values()) if times == filed else list(map(ticks.__getitem__, times))
    if details:
        writes_tick = out.writes_tick
        for t_us, entry in zip(times, entries, strict=True):
            writes_tick(t_us, entry_writes(entry), t_us in mixed or isinstance(entry, Samples))
        return out.frames, out.samples
    at = 0
    # Runs of consecutive ticks of one kind, then within them of the same sources: a stretch
    # of ticks only one move writes (nearly every tick of a long show), or the same move and
    # fades, is made into frames list by list.
    for kind, run in groupby(map(type, entries)):
        n = len(list(run))
        stamps, block = times[at:at + n], entries[at:at + n]
        at += n
        if kind is tuple:
            sub = 0
            for _, same in groupby(map(_HEAD, block)):
                m = len(list(same))
                if m > 1:
                    out.stretch(stamps[sub:sub + m], block[sub:sub + m])  # type: ignore[arg-type]
                else:
                    out.source_sample(stamps[sub], *block[sub])
                sub += m
        elif kind is Samples:
            sub = 0
            heads = map(map, repeat(_HEAD), block)  # type: ignore[arg-type]
            for sources, same in groupby(map(tuple, heads)):
                m = len(list(same))
                if m > 1:
                    out.samples_stretch(sources, stamps[sub:sub + m],
                                        block[sub:sub + m])  # type: ignore[arg-type]
                else:
                    out.sources_tick(stamps[sub], block[sub])  # type: ignore[arg-type]
                sub += m
        else:
            for t_us, entry in zip(stamps, block, strict=True):
                out.writes_tick(t_us, entry, t_us in mixed)  # type: ignore[arg-type]
    return out.frames, out.samples
