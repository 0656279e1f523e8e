"""LewanSoul/Hiwonder xArm: six bus servos, no register table.

The xArm is commanded per servo (lewansoul-xarm-protocol.txt: ServoMove with positions 0..1000).
Positions span -125..+125 degrees (vendor ``xarm`` package), i.e. 4 positions per degree with
500 at 0 degrees. Servo 1 is the gripper.
"""

from __future__ import annotations

import math

from xgo_show.errors import ValueRangeError
from xgo_show.profiles.model import Link, Profile

__all__ = [
    "DEGREES_MAX",
    "DEGREES_MIN",
    "GRIPPER_SERVO",
    "POSITION_MAX",
    "XARM",
    "degrees_to_position",
    "position_to_degrees",
]

POSITION_MAX = 1000
DEGREES_MIN = -125.0
DEGREES_MAX = 125.0
GRIPPER_SERVO = 1
_PER_DEGREE = POSITION_MAX / (DEGREES_MAX - DEGREES_MIN)  # 4 positions per degree


def degrees_to_position(degrees: float) -> int:
    """Servo angle in degrees (-125..125) -> position 0..1000, rounded to nearest.

    The vendor package quantises to 0.25 degrees and truncates; rounding to nearest gives the
    same positions for every multiple of 0.25 and is symmetric about 0 (= 500).
    """
    if math.isnan(degrees) or not DEGREES_MIN <= degrees <= DEGREES_MAX:
        raise ValueRangeError(
            f"xArm servo angle {degrees:g} deg is out of range [{DEGREES_MIN:g}, {DEGREES_MAX:g}]"
        )
    return round((degrees - DEGREES_MIN) * _PER_DEGREE)


def position_to_degrees(position: int) -> float:
    """Servo position 0..1000 -> degrees (-125..125)."""
    if not 0 <= position <= POSITION_MAX:
        raise ValueRangeError(f"xArm servo position {position} is out of range [0, 1000]")
    return DEGREES_MIN + position / _PER_DEGREE


XARM = Profile(
    model="xarm",
    family="xarm",
    title="LewanSoul xArm",
    # TTL serial at 9600 baud per the document. The document gives no interval between
    # commands; we keep the XGO's 1 ms of silence between frames.
    link=Link(baud=9600, gap=0.001),
    xarm_servos=(1, 2, 3, 4, 5, 6),
    capabilities=frozenset({"servos", "gripper"}),
)
