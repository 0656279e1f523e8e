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
            below, above = lo, hi  # to_byte(below) < b <= to_byte(above)
            while True:
                mid = (below + above) / 2
                if mid <= below or mid >= above:
                    break
                if reg.to_byte(mid) >= b:
                    above = mid
                else:
                    below = mid
            thresholds.append(above)
        self.thresholds = thresholds
        # The same thresholds after ``base`` entries of -inf: bisect_right(padded, x) is then
        # the byte itself (base + bisect_right(thresholds, x)) for any x in range.
        self.padded = [-math.inf] * self.base + thresholds

    def __call__(self, value: float) -> int:
        if self.lo <= value <= self.hi:
            return self.base + bisect_right(self.thresholds, value)
        return self.reg.to_byte(value)
