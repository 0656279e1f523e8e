"""xArm servo position <-> degree conversion."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from xarm.util import Util

from xgo_show.errors import ValueRangeError
from xgo_show.profiles.xarm import degrees_to_position, position_to_degrees


def test_fixed_points() -> None:
    assert degrees_to_position(-125) == 0
    assert degrees_to_position(0) == 500
    assert degrees_to_position(125) == 1000
    assert degrees_to_position(0.1) == 500  # 0.4 position rounds down
    assert degrees_to_position(0.15) == 501  # 0.6 position rounds up
    assert position_to_degrees(0) == -125.0
    assert position_to_degrees(500) == 0.0
    assert position_to_degrees(1000) == 125.0


@given(st.integers(0, 1000))
def test_positions_round_trip(position: int) -> None:
    assert degrees_to_position(position_to_degrees(position)) == position


@given(st.floats(-125.0, 125.0))
def test_degrees_round_trip_within_half_a_step(degrees: float) -> None:
    back = position_to_degrees(degrees_to_position(degrees))
    assert abs(back - degrees) <= 0.125 + 1e-9


@given(st.integers(-500, 500))
def test_agrees_with_the_vendor_package_on_its_quarter_degree_grid(quarters: int) -> None:
    degrees = quarters / 4
    assert degrees_to_position(degrees) == Util._angle_to_position(degrees)
    assert position_to_degrees(degrees_to_position(degrees)) == pytest.approx(degrees)


@pytest.mark.parametrize("degrees", [-125.01, 125.01, 180.0, math.nan, -math.inf])
def test_out_of_range_degrees(degrees: float) -> None:
    with pytest.raises(ValueRangeError, match="xArm"):
        degrees_to_position(degrees)


@pytest.mark.parametrize("position", [-1, 1001])
def test_out_of_range_position(position: int) -> None:
    with pytest.raises(ValueRangeError, match="xArm"):
        position_to_degrees(position)
