"""Byte tables built afresh in each test (the shared ones are cached): the padded form the
sampling loop bisects directly, and the registers a table refuses."""

from __future__ import annotations

import math
from bisect import bisect_right

import pytest

from xgo_show.compiler.bytetable import ByteTable
from xgo_show.errors import ValueRangeError
from xgo_show.profiles import Access, Encoding, Register, get_profile


def test_the_padded_table_gives_the_byte_by_itself() -> None:
    # The compiler's hot loop maps a value to its byte with bisect_right(padded, x) alone.
    for name in ("body_z", "vx", "yaw"):
        reg = get_profile("mini").register(name)
        table = ByteTable(reg)
        xs = [reg.minimum, reg.maximum]
        for t in table.thresholds:
            xs += [t, math.nextafter(t, -math.inf)]
        for x in xs:
            assert bisect_right(table.padded, x) == table(x) == reg.to_byte(x), (name, x)
        with pytest.raises(ValueRangeError, match=name):
            table(reg.maximum + 1.0)  # out of range: to_byte's own error


def test_only_linear_one_byte_registers_get_a_table() -> None:
    refused = [
        Register(0x10, "raw", Access.WRITE),  # U8 without a physical range
        Register(0x11, "wave", Access.WRITE, encoding=Encoding.U8_PERIODIC, minimum=1.0,
                 maximum=2.0),
        Register(0x12, "wide", Access.WRITE, size=2, minimum=0.0, maximum=1.0),
    ]
    for reg in refused:
        with pytest.raises(ValueError) as err:
            ByteTable(reg)
        assert str(err.value) == f"{reg.name} is not a linear one-byte register"
