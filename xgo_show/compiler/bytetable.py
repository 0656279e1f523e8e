""":meth:`Register.to_byte` as a threshold table, for the compiler's sampling loop.

Sampling calls the physical -> byte conversion about a million times for a long show. The table
is *built from* ``Register.to_byte`` (there is still one conversion): for every byte ``b`` it
finds, by bisection over floats, the smallest physical value that ``to_byte`` maps to ``b`` or
more. Since the conversion is monotonic, the byte of ``x`` is then the number of thresholds at
or below ``x`` (one C-level ``bisect``). Values outside the register's range go to
``to_byte`` itself, which raises the usual :class:`ValueRangeError`.
"""

from __future__ import annotations

import math
from bisect import bisect_right

from xgo_show.profiles.model import Encoding, Register

__all__ = ["ByteTable"]


class ByteTable:
    """Callable ``physical -> byte`` equal to ``reg.to_byte`` (linear one-byte U8 registers)."""

    def __init__(self, reg: Register) -> None:
        if reg.encoding is not Encoding.U8 or not reg.linear or reg.size != 1:
            raise ValueError(f"{reg.name} is not a linear one-byte register")
        assert reg.minimum is not None and reg.maximum is not None
        self.reg = reg
        self.lo = lo = float(reg.minimum)
        self.hi = hi = float(reg.maximum)
        self.base = reg.to_byte(lo)
        thresholds: list[float] = []
        for b in range(self.base + 1, reg.to_byte(hi) + 1):
            # The rounding boundary between the values of bytes b - 1 and b is within a few
            # floats of their midpoint: step float by float from there (a few to_byte calls
            # instead of some fifty for a bisection); bisect if that takes unusually long.
            guess = (reg.to_physical(b - 1) + reg.to_physical(b)) / 2
            found = _step_to_threshold(reg, b, min(max(guess, lo), hi), lo, hi)
            thresholds.append(found if found is not None else _bisect_threshold(reg, b, lo, hi))
        self.thresholds = thresholds
        # The same thresholds after ``base`` entries of -inf: bisect_right(padded, x) is then
        # the byte itself (base + bisect_right(thresholds, x)) for any x in range.
        self.padded = [-math.inf] * self.base + thresholds

    def __call__(self, value: float) -> int:
        if self.lo <= value <= self.hi:
            return self.base + bisect_right(self.thresholds, value)
        return self.reg.to_byte(value)


_STEPS = 64  # floats to step at most from the guess


def _step_to_threshold(reg: Register, b: int, x: float, lo: float, hi: float) -> float | None:
    """The smallest float in [lo, hi] that ``to_byte`` maps to ``b`` or more, stepping from
    ``x``; None if it is more than _STEPS floats away."""
    if reg.to_byte(x) >= b:
        for _ in range(_STEPS):
            down = math.nextafter(x, -math.inf)
            if down < lo or reg.to_byte(down) < b:
                return x
            x = down
        return None
    for _ in range(_STEPS):
        x = math.nextafter(x, math.inf)
        if x > hi:
            return None
        if reg.to_byte(x) >= b:
            return x
    return None


def _bisect_threshold(reg: Register, b: int, lo: float, hi: float) -> float:
    """The same threshold by bisection over [lo, hi] (to_byte is monotonic)."""
    below, above = lo, hi  # to_byte(below) < b <= to_byte(above)
    while True:
        mid = (below + above) / 2
        if mid <= below or mid >= above:
            return above
        if reg.to_byte(mid) >= b:
            above = mid
        else:
            below = mid
