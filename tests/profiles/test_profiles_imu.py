"""IMU block layouts, checked against the vendor library's own decoders."""

from __future__ import annotations

import struct
from types import SimpleNamespace

import pytest
from hypothesis import given
from hypothesis import strategies as st
from xgolib.xgolib_dog import XGO_DOG, Byte2Float, Byte2Short

from xgo_show.errors import ValueRangeError
from xgo_show.profiles import get_profile

MINI = get_profile("mini")
RIDER = get_profile("rider")
assert MINI.imu is not None and RIDER.imu is not None
DOG_IMU = MINI.imu
RIDER_IMU = RIDER.imu

_ACC = st.floats(-19.0, 19.0)  # within int16 at 16384 LSB per g
_GYRO = st.floats(-1900.0, 1900.0)
_ANGLE = st.floats(-180.0, 180.0, width=32)


def test_layouts_fill_the_24_byte_block() -> None:
    for profile in (MINI, get_profile("lite"), RIDER):
        assert profile.imu is not None
        assert profile.imu.size == profile.register("imu_block").size == 24
    assert get_profile("xarm").imu is None


@given(
    acc=st.tuples(_ACC, _ACC, _ACC),
    gyro=st.tuples(_GYRO, _GYRO, _GYRO),
    angles=st.tuples(_ANGLE, _ANGLE, _ANGLE),
)
def test_dog_block_decodes_like_the_vendor_library(
    acc: tuple[float, float, float],
    gyro: tuple[float, float, float],
    angles: tuple[float, float, float],
) -> None:
    values = dict(zip(DOG_IMU.names, (*acc, *gyro, *angles), strict=True))
    raw = DOG_IMU.pack(values)
    assert len(raw) == 24
    decoded = DOG_IMU.unpack(raw)
    vendor = XGO_DOG.unpack_imu(SimpleNamespace(rx_data=bytearray(raw)))  # type: ignore[arg-type]
    for i, name in enumerate(DOG_IMU.names):
        expected = vendor[i] / 3.14 * 180 if i >= 6 else vendor[i]  # vendor returns radians
        assert decoded[name] == pytest.approx(expected, rel=1e-6, abs=1e-6)
        # quantisation: half a raw step for the int16 fields
        step = 9.8 / 16384 if i < 3 else 1 / 16.4 if i < 6 else 0.0
        assert abs(decoded[name] - values[name]) <= step / 2 + 1e-4 * max(1.0, abs(values[name]))


@given(st.lists(st.floats(-1e3, 1e3, width=32), min_size=6, max_size=6))
def test_rider_block_is_six_float32_le(values: list[float]) -> None:
    raw = RIDER_IMU.pack(dict(zip(RIDER_IMU.names, values, strict=True)))
    assert raw == struct.pack("<6f", *values)
    assert list(RIDER_IMU.unpack(raw).values()) == values


def test_angle_registers_match_the_vendor_readers() -> None:
    roll = MINI.register("imu_roll").encode_value(-12.5)
    assert Byte2Float(bytearray(roll)) == -12.5
    raw = RIDER.register("imu_yaw_i16").encode_value(-300)
    assert Byte2Short(bytearray(raw)) == -300


def test_pack_rejects_unknown_fields_and_overflow() -> None:
    with pytest.raises(ValueRangeError, match="temperature"):
        DOG_IMU.pack({"temperature": 20.0})
    with pytest.raises(ValueRangeError, match="acc_x"):
        DOG_IMU.pack({"acc_x": 100.0})  # > 2 g does not fit the int16
    with pytest.raises(ValueRangeError):
        DOG_IMU.unpack(bytes(23))


def test_missing_fields_pack_as_zero() -> None:
    assert DOG_IMU.pack({}) == bytes(24)
    assert DOG_IMU.unpack(bytes(24)) == dict.fromkeys(DOG_IMU.names, 0.0)
