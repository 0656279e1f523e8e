"""What one tick of a performer holds, as the planner files it and the fast path reads it.

A *source* is a cue that writes the same registers tick after tick (a move, a fade); a tick is
one source's sample, several sources' samples (:class:`Samples`), or a list of
:class:`~xgo_show.compiler.frames.Write` (settings, actions, and any tick where those meet
samples or two samples of one register meet).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from itertools import repeat
from operator import getitem, ne

from xgo_show.compiler.frames import Write
from xgo_show.diagnostics import Origin
from xgo_show.profiles.model import Register

__all__ = ["Entry", "Samples", "Source", "change_masks", "changes", "entry_writes"]


class Source:
    """A cue that writes the same registers tick after tick: a move (one byte a register) or a fade.

    Its sample at a tick is one ``bytes`` of every register's bytes in address order, not a
    :class:`Write` per register: ticks that only sources write (nearly all of a long show) are
    turned into frames straight from those bytes (see
    :class:`~xgo_show.compiler.fastpath.TickFrames`).
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
        # While "live" (see fastpath.TickFrames): the bytes its registers were last sent, which
        # the sent/known dictionaries are only told later. None otherwise.
        self.prev: bytes | None = None

    def writes(self, sample: bytes) -> list[Write]:
        """The sample as one Write per register (for ticks other cues write too)."""
        origin, order = self.origin, self.order
        return [
            Write(address, sample[b:e], origin, order, True)
            for address, (b, e) in zip(self.addresses, self.spans, strict=True)
        ]


class Samples(list[tuple[Source, bytes]]):
    """A tick several sources write, none of them the same register (e.g. a move and fades)."""


# What one tick holds: one source's sample (the common case), several sources' samples, or
# Writes (settings, actions, cut moves, and any tick where those meet samples).
Entry = tuple[Source, bytes] | Samples | list[Write]


def entry_writes(entry: Entry) -> list[Write]:
    """Any tick entry as a list of Writes."""
    if isinstance(entry, tuple):
        return entry[0].writes(entry[1])
    if isinstance(entry, Samples):
        return [w for src, sample in entry for w in src.writes(sample)]
    return entry


def change_masks(
    src: Source, samples: Sequence[bytes], prevs: Sequence[bytes]
) -> Iterator[tuple[bool, ...]]:
    """:func:`changes` of each sample and the one before it, in C-level maps (no Python call
    a tick): the column of each register's bytes compared with the column before."""
    if src.unit:
        return map(tuple, map(map, repeat(ne), samples, prevs))
    if src.one:
        return zip(map(ne, samples, prevs))
    columns = [map(ne, map(getitem, samples, repeat(part)), map(getitem, prevs, repeat(part)))
               for part in (slice(b, e) for b, e in src.spans)]
    return zip(*columns, strict=True)


def changes(src: Source, sample: bytes, prev: bytes) -> tuple[bool, ...]:
    """Which registers of a live source differ from its previous sample."""
    if src.unit:
        return tuple(map(ne, sample, prev))
    if src.one:
        return (sample != prev,)
    return tuple([sample[b:e] != prev[b:e] for b, e in src.spans])
