"""LewanSoul/Hiwonder xArm: six bus servos, no register table.

The xArm is commanded per servo (lewansoul-xarm-protocol.txt: ServoMove with positions 0..1000).
Positions span -125..+125 degrees (vendor ``xarm`` package), i.e. 4 positions per degree with
500 at 0 degrees. Servo 1 is the gripper.

Unsafe commands. The xArm has no registers to mark ``unsafe`` as the XGO profiles do; the
equivalent is a set of command numbers (:data:`UNSAFE_COMMANDS`) that a show never sends: they
change what the arm stores (calibration offsets, action groups, servo limits) or drop the arm
(servos unpowered). The runtime refuses a schedule holding one unless ``--allow-unsafe``.

Battery. The controller reports its supply in millivolts. The LX-15D bus servos work from
6.0 V to 8.4 V (a 2S lithium pack from empty to full), so a show's battery floor in percent is
mapped linearly onto that range: 0 % = :data:`BATTERY_MV_EMPTY`, 100 % =
:data:`BATTERY_MV_FULL` (the default floor of 20 % is 6.48 V).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from xgo_show.errors import ValueRangeError
from xgo_show.profiles.model import Link, Profile

__all__ = [
    "BATTERY_MV_EMPTY",
    "BATTERY_MV_FULL",
    "DEGREES_MAX",
    "DEGREES_MIN",
    "GRIPPER_SERVO",
    "POSITION_MAX",
    "SERVO_NAMES",
    "UNSAFE_COMMANDS",
    "XARM",
    "battery_floor_mv",
    "battery_percent",
    "degrees_to_position",
    "position_to_degrees",
]

POSITION_MAX = 1000
# What each servo moves (the vendor's numbering, as choreographies/xarm_hello.yaml explains).
SERVO_NAMES: Mapping[int, str] = {
    1: "gripper", 2: "wrist rotation", 3: "wrist", 4: "elbow", 5: "shoulder", 6: "base",
}

DEGREES_MIN = -125.0
DEGREES_MAX = 125.0
GRIPPER_SERVO = 1
_PER_DEGREE = POSITION_MAX / (DEGREES_MAX - DEGREES_MIN)  # 4 positions per degree

# The LX-15D servos' working supply range (a 2S lithium pack, empty to full), in millivolts.
BATTERY_MV_EMPTY = 6000
BATTERY_MV_FULL = 8400

# Command numbers (wire.xarm.XarmCommand) a show never sends, and why: the xArm's equivalent
# of the XGO registers marked ``unsafe``.
UNSAFE_COMMANDS: Mapping[int, str] = {
    8: "GroupErase: erases action groups stored on the board",
    20: "ServoOff: unpowers servos, the arm drops",
    24: "ServoOffsetWrite: servo calibration",
    26: "BusServoMoroCtrl: switches a servo to motor mode",
    27: "BusServoInfoWrite: reprograms every attached servo's limits",
}


def battery_floor_mv(percent: float) -> float:
    """A battery floor in percent -> millivolts on the 6.0..8.4 V range of the servos."""
    return BATTERY_MV_EMPTY + (BATTERY_MV_FULL - BATTERY_MV_EMPTY) * percent / 100.0


def battery_percent(millivolts: float) -> float:
    """Battery millivolts -> percent of the 6.0..8.4 V range (not clamped: 8.6 V is > 100)."""
    return (millivolts - BATTERY_MV_EMPTY) * 100.0 / (BATTERY_MV_FULL - BATTERY_MV_EMPTY)


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
