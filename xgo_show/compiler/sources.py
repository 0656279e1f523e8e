"""What one tick of a performer holds, as the planner files it and the fast path reads it.

A *source* is a cue that writes the same registers tick after tick (a move, a fade); a tick is
one source's sample, several sources' samples (:class:`Samples`), or a list of
:class:`~xgo_show.compiler.frames.Write` (settings, actions, and any tick where those meet
samples or two samples of one register meet).
"""

from __future__ import annotations

from collections.abc import Sequence
from operator import ne

from xgo_show.compiler.frames import Write, cut_rows
from xgo_show.diagnostics import Origin
from xgo_show.profiles.model import Register

__all__ = ["Entry", "Samples", "Source", "change_codes", "changes", "entry_writes"]


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


def change_codes(samples: Sequence[bytes]) -> list[bytes]:
    """Which bytes of each sample after the first differ from the sample before: a code a
    sample, as long as a sample, 0x80 where the byte changed and 0 where it did not (all zero
    where nothing changed). Equal codes, equal :func:`changes`: the fast path looks a tick's
    frames up by its code, made for every tick at once, with no Python call nor tuple a tick.

    The samples (a source's: of one length, which is not checked) are joined, and the join
    without its first sample XORed with the join without its last as two big ints; a byte ``b``
    of the XOR becomes 0x80 when not zero by ``((b & 0x7f) + 0x7f | b) & 0x80``, done on every
    byte at once: ``b & 0x7f`` plus 0x7f reaches the top bit exactly when the low seven bits
    are not all zero and never carries into the next byte (0x7f + 0x7f is 0xfe). The result is
    cut back into one code a sample.
    """
    if not samples:
        return []
    width = len(samples[0])
    joined = b"".join(samples)
    size = len(joined) - width
    diff = int.from_bytes(joined[width:], "big") ^ int.from_bytes(joined[:-width], "big")
    low = int.from_bytes(b"\x7f" * size, "big")
    code = ((diff & low) + low | diff) & int.from_bytes(b"\x80" * size, "big")
    return cut_rows(code.to_bytes(size, "big"), width)


def changes(src: Source, sample: bytes, prev: bytes) -> tuple[bool, ...]:
    """Which registers of a live source differ from its previous sample."""
    if src.unit:
        return tuple(map(ne, sample, prev))
    if src.one:
        return (sample != prev,)
    return tuple([sample[b:e] != prev[b:e] for b, e in src.spans])
