"""xArm servo position <-> degree conversion."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from xarm.util import Util

from xgo_show.errors import ValueRangeError
from xgo_show.profiles.xarm import (
    battery_floor_mv,
    battery_percent,
    degrees_to_position,
    position_to_degrees,
)


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


def test_battery_floor_maps_percent_onto_the_servos_supply_range() -> None:
    # 0 % is the LX-15D's 6.0 V, 100 % its 8.4 V (a 2S pack, empty to full), linearly.
    assert battery_floor_mv(0) == 6000.0
    assert battery_floor_mv(100) == 8400.0
    assert battery_floor_mv(20) == pytest.approx(6480.0)  # the default floor
    assert battery_floor_mv(50) == pytest.approx(7200.0)


def test_battery_percent_is_the_inverse_and_not_clamped() -> None:
    assert battery_percent(6000) == 0.0
    assert battery_percent(8400) == 100.0
    assert battery_percent(7200) == pytest.approx(50.0)
    assert battery_percent(8640) == pytest.approx(110.0)  # above full: over 100
    assert battery_percent(5760) == pytest.approx(-10.0)


@given(st.floats(-50.0, 150.0))
def test_battery_round_trip(percent: float) -> None:
    assert battery_percent(battery_floor_mv(percent)) == pytest.approx(percent, abs=1e-9)


def test_range_refusals_name_the_value_and_the_range() -> None:
    with pytest.raises(ValueRangeError, match=r"^xArm servo angle 130 deg is out of range "
                       r"\[-125, 125\]$"):
        degrees_to_position(130.0)
    with pytest.raises(ValueRangeError, match=r"^xArm servo position 1001 is out of range "
                       r"\[0, 1000\]$"):
        position_to_degrees(1001)
