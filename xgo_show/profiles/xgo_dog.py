"""XGO-Mini and XGO-Lite: one shared memory table, per-model physical ranges.

The table follows the "Robot dog memory table" of xgo-serial-protocol-mini-lite.txt. Both models
have the same addresses and meanings; they differ only in the physical ranges the linear
registers map onto, which come from the vendor library (xgolib_dog.py, ``changePara``).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass

from xgo_show.profiles._common import (
    ANGLE,
    ARM,
    ARM_SERVO,
    DOG_IMU,
    GRIPPER,
    HEIGHT,
    LEG,
    LEG_SERVO,
    NEUTRAL,
    OFF,
    TRANSLATION,
    XGO_BAUD,
    XGO_GAP,
    imu_registers,
    system_registers,
)
from xgo_show.profiles.model import (
    Access,
    Action,
    Encoding,
    Limits,
    Link,
    Profile,
    Register,
)

__all__ = ["DOG_ACTIONS", "LEG_NAMES", "LITE", "LITE_RANGES", "MINI", "MINI_RANGES", "SERVO_IDS"]

Range = tuple[float, float]

# Physical ranges per model, from the vendor library's changePara('xgomini' / 'xgolite'):
# TRANSLATION_LIMIT -> body_x/y/z, ATTITUDE_LIMIT -> roll/pitch/yaw, LEG_LIMIT -> leg*_x/y/z,
# MOTOR_LIMIT[0..2] -> leg servos by joint (index (i-1) % 3 of servos 11, 12, 13, 21, ...: the
# lower joint x1, the middle joint x2, the upper/shoulder joint x3 — "下 中 上" in the vendor
# comment), MOTOR_LIMIT[4], [5] -> arm servos 52, 53 (MOTOR_LIMIT[3] belongs to servo 51, the
# gripper, which the library drives through the gripper register 0x71 instead),
# PERIOD_LIMIT -> periodic_*, MARK_TIME_LIMIT -> mark_time, VX/VY/VYAW_LIMIT -> speeds,
# ARM_LIMIT[0], [1] -> arm_x, arm_z (the document states the same [-80, 155] and [-95, 155] mm).
MINI_RANGES: Mapping[str, Range] = {
    "vx": (-25.0, 25.0),
    "vy": (-18.0, 18.0),
    "vyaw": (-100.0, 100.0),
    "body_x": (-35.0, 35.0),
    "body_y": (-19.5, 19.5),
    "body_z": (75.0, 120.0),
    "roll": (-20.0, 20.0),
    "pitch": (-22.0, 22.0),
    "yaw": (-16.0, 16.0),
    "periodic": (1.5, 8.0),
    "mark_time": (10.0, 35.0),
    "leg_x": (-35.0, 35.0),
    "leg_y": (-18.0, 18.0),
    "leg_z": (75.0, 115.0),
    "servo_x1": (-73.0, 57.0),
    "servo_x2": (-66.0, 93.0),
    "servo_x3": (-31.0, 31.0),
    "servo_52": (-85.0, 50.0),
    "servo_53": (-75.0, 90.0),
    "arm_x": (-80.0, 155.0),
    "arm_z": (-95.0, 155.0),
}
LITE_RANGES: Mapping[str, Range] = {
    "vx": (-25.0, 25.0),
    "vy": (-18.0, 18.0),
    "vyaw": (-100.0, 100.0),
    "body_x": (-25.0, 25.0),
    "body_y": (-18.0, 18.0),
    "body_z": (60.0, 110.0),
    "roll": (-20.0, 20.0),
    "pitch": (-10.0, 10.0),
    "yaw": (-12.0, 12.0),
    "periodic": (1.5, 8.0),
    "mark_time": (10.0, 25.0),
    "leg_x": (-25.0, 25.0),
    "leg_y": (-18.0, 18.0),
    "leg_z": (60.0, 110.0),
    "servo_x1": (-70.0, 50.0),
    "servo_x2": (-70.0, 90.0),
    "servo_x3": (-30.0, 30.0),
    "servo_52": (-115.0, 70.0),
    "servo_53": (-85.0, 100.0),
    "arm_x": (-80.0, 155.0),
    "arm_z": (-95.0, 155.0),
}

# Speed units. vx/vy: the documents give no unit; the vendor's API documentation calls the value
# the "translation step size" (move(direction, step), x in [-25, 25], y in [-18, 18]), i.e. a
# stride length whose ground speed also depends on the pace register (0x3D). We therefore keep
# the vendor's numbers and call the unit mm/step rather than inventing a mm/s calibration.
# vyaw: the vendor's ±100 is taken as deg/s (also undocumented).
_SPEED_UNITS: Mapping[str, str] = {"vx": "mm/step", "vy": "mm/step", "vyaw": "deg/s"}
# How fast a speed command may change along a trajectory: full scale within about a second
# (our choice, not a vendor fact).
_SPEED_LIMITS: Mapping[str, Limits] = {
    "vx": Limits(velocity=50.0, acceleration=250.0, jerk=2000.0),
    "vy": Limits(velocity=36.0, acceleration=180.0, jerk=1500.0),
    "vyaw": Limits(velocity=200.0, acceleration=1000.0, jerk=8000.0),
}

LEG_NAMES: Mapping[int, str] = {1: "left front", 2: "right front", 3: "right hind", 4: "left hind"}
# Servo ids in register order 0x50..0x5B: leg l (1..4), joint j (1 lower, 2 middle, 3 upper).
SERVO_IDS: tuple[int, ...] = tuple(10 * leg + joint for leg in range(1, 5) for joint in range(1, 4))
_JOINTS: Mapping[int, str] = {1: "lower (elbow)", 2: "middle (arm)", 3: "upper (shoulder)"}


@dataclass(frozen=True)
class _Linear:
    """A linear register of the shared table whose range comes from the per-model dict."""

    address: int
    name: str
    range_key: str
    unit: str
    description: str
    group: str
    limits: Limits | None
    access: Access = Access.READ_WRITE
    encoding: Encoding = Encoding.U8
    initial: bytes = NEUTRAL


def _linear_rows() -> Iterator[_Linear]:
    for axis_i, name in enumerate(("vx", "vy", "vyaw")):
        what = ("forward/backward", "left/right", "rotation (clockwise = maximum)")[axis_i]
        yield _Linear(
            0x30 + axis_i,
            name,
            name,
            _SPEED_UNITS[name],
            f"{what} speed; 0x80 = stop, 0x00 reverse maximum, 0xFF forward maximum",
            "speed",
            _SPEED_LIMITS[name],
        )
    for i, axis in enumerate("xyz"):
        name = f"body_{axis}"
        yield _Linear(
            0x33 + i,
            name,
            name,
            "mm",
            "body height" if axis == "z" else f"body translation along {axis}, feet stay put",
            "posture",
            HEIGHT if axis == "z" else TRANSLATION,
        )
    for i, (name, axis) in enumerate((("roll", "x"), ("pitch", "y"), ("yaw", "z"))):
        yield _Linear(
            0x36 + i,
            name,
            name,
            "deg",
            f"body rotation about the {axis} axis ({name})",
            "posture",
            ANGLE,
        )
    # Periodic motion: 0x00 stops; 0x01..0xFF map linearly onto the period in seconds, as the
    # vendor library writes it (period 1.5 s -> 0x01, 8 s -> 0xFF). The document words it as
    # "minimum-maximum rotation speed", which we do not follow: the vendor's numbers are periods.
    for i, name in enumerate(("periodic_roll", "periodic_pitch", "periodic_yaw")):
        yield _Linear(
            0x39 + i,
            name,
            "periodic",
            "s",
            f"rotate the body periodically ({name[9:]}); value = period, 0 = off; "
            "cannot work together with the posture registers",
            "periodic",
            None,
            encoding=Encoding.U8_PERIODIC,
            initial=OFF,
        )
    yield _Linear(
        0x3C,
        "mark_time",
        "mark_time",
        "mm",
        "mark time (step in place); value = step height, 0 = stop",
        "speed",
        None,
        encoding=Encoding.U8_PERIODIC,
        initial=OFF,
    )
    for i, axis in enumerate("xyz"):
        yield _Linear(
            0x80 + i,
            f"periodic_{axis}",
            "periodic",
            "s",
            f"translate the body periodically along {axis}; value = period, 0 = off; "
            "amplitude is half the position limit",
            "periodic",
            None,
            encoding=Encoding.U8_PERIODIC,
            initial=OFF,
        )
    for leg in range(1, 5):
        for i, axis in enumerate("xyz"):
            yield _Linear(
                0x40 + 3 * (leg - 1) + i,
                f"leg{leg}_{axis}",
                f"leg_{axis}",
                "mm",
                f"{LEG_NAMES[leg]} foot position along {axis} (single-leg frame, z down)",
                "leg",
                LEG,
            )
    for i, sid in enumerate(SERVO_IDS):
        yield _Linear(
            0x50 + i,
            f"servo_{sid}",
            f"servo_x{sid % 10}",
            "deg",
            f"servo {sid} angle: {LEG_NAMES[sid // 10]} leg, {_JOINTS[sid % 10]} joint",
            "servo",
            LEG_SERVO,
        )
    yield _Linear(
        0x5D,
        "servo_52",
        "servo_52",
        "deg",
        "servo 52 angle: robotic arm forearm",
        "servo",
        ARM_SERVO,
    )
    yield _Linear(
        0x5E,
        "servo_53",
        "servo_53",
        "deg",
        "servo 53 angle: robotic arm upper arm",
        "servo",
        ARM_SERVO,
    )
    yield _Linear(
        0x73,
        "arm_x",
        "arm_x",
        "mm",
        "arm end point x; origin at the arm servo's rotation axis",
        "arm",
        ARM,
        access=Access.WRITE,
    )
    yield _Linear(
        0x74,
        "arm_z",
        "arm_z",
        "mm",
        "arm end point z",
        "arm",
        ARM,
        access=Access.WRITE,
    )


def _linear(row: _Linear, ranges: Mapping[str, Range]) -> Register:
    lo, hi = ranges[row.range_key]
    return Register(
        row.address,
        row.name,
        row.access,
        row.encoding,
        initial=row.initial,
        unit=row.unit,
        minimum=lo,
        maximum=hi,
        description=row.description,
        limits=row.limits,
        group=row.group,
        # Symmetric ranges: zero is exactly 0x80 (the documented neutral). Asymmetric ranges
        # (servo joints, arm_x/arm_z) map plainly linearly, as the document states for the arm
        # and as the vendor library converts the servos.
        zero_at_neutral=(lo == -hi),
    )


_FIXED: tuple[Register, ...] = (
    Register(
        0x00,
        "status",
        Access.READ,
        Encoding.U8,
        initial=OFF,
        description="working status (the document gives no codes)",
        group="telemetry",
    ),
    Register(
        0x09,
        "gait",
        Access.WRITE,
        Encoding.ENUM,
        initial=OFF,
        choices={"trot": 0, "walk": 1, "high_walk": 2},
        description="gait: 0x00 trot, 0x01 walk, 0x02 high walk",
        group="setting",
    ),
    Register(
        0x20,
        "servo_unload",
        Access.READ_WRITE,
        Encoding.ENUM,
        initial=OFF,
        # 0x15/0x25 (leg 5 = the arm) are what the vendor library sends; the document lists 1..4.
        choices={
            "loaded": 0x00,
            "unload_all": 0x01,
            **{f"unload_leg{n}": 0x10 + n for n in range(1, 6)},
            **{f"load_leg{n}": 0x20 + n for n in range(1, 6)},
        },
        description=(
            "debug: 0x00 servos working, 0x01 unload all, 0x11..0x14 unload leg 1..4, "
            "0x21..0x24 load leg 1..4 again"
        ),
        unsafe=True,
        group="setting",
    ),
    Register(
        0x21,
        "servo_zero",
        Access.WRITE,
        Encoding.ENUM,
        initial=OFF,
        choices={"normal": 0, "set_zero": 1},
        description="0x01 records the current position of every servo as its zero (returns to 0)",
        unsafe=True,
        group="setting",
    ),
    Register(
        0x3D,
        "pace",
        Access.READ_WRITE,
        Encoding.ENUM,
        initial=OFF,
        choices={"normal": 0, "slow": 1, "fast": 2},
        description="stepping frequency: 0x00 normal, 0x01 slow, 0x02 fast",
        group="setting",
    ),
    Register(
        0x3E,
        "action",
        Access.WRITE,
        Encoding.U8,
        initial=OFF,
        description="run a preset action by id (see the action table); 255 restores the default "
        "posture",
        group="action",
    ),
    Register(
        0x5C,
        "servo_speed",
        Access.READ_WRITE,
        Encoding.U8,
        initial=NEUTRAL,
        description="servo speed in servo mode, 0x00..0xFF = minimum..maximum (raw byte)",
        group="setting",
    ),
    Register(
        0x71,
        "gripper",
        Access.WRITE,
        Encoding.U8,
        initial=NEUTRAL,
        unit="%",
        minimum=0.0,
        maximum=100.0,
        limits=GRIPPER,
        group="gripper",
        # The document says "0x00 full opening | 0xFF full opening": a typo, one end must be
        # closed. We read 0x00 = fully open and 0xFF = fully closed, so the value is "% closed".
        description="gripper, 0 % = fully open .. 100 % = fully closed (0x00..0xFF)",
    ),
    Register(
        0x72,
        "arm_mode",
        Access.WRITE,
        Encoding.ENUM,
        initial=OFF,
        choices={"off": 0, "stabilise": 1},
        description="0x01 keeps the arm's end point still in space while the body moves",
        group="setting",
    ),
)

_DOG_IMU_NOTE = (
    "24 bytes: acc x, y, z and gyro x, y, z as int16 little-endian (raw/16384*9.8 m/s², "
    "raw/16.4 deg/s), then roll, pitch, yaw as float32 little-endian degrees (Profile.imu)"
)


def _dog_registers(ranges: Mapping[str, Range], firmware: str) -> tuple[Register, ...]:
    regs = (
        *system_registers(
            firmware,
            bt_name_note="Bluetooth name, ASCII letters and digits (up to 20 bytes)",
            update_reply="the robot echoes the command, then expects the hex file after 1 s",
        ),
        *_FIXED,
        *(_linear(row, ranges) for row in _linear_rows()),
        *imu_registers(_DOG_IMU_NOTE, mode_access=Access.READ_WRITE),
    )
    return tuple(sorted(regs, key=lambda r: r.address))


# Preset actions: id, name, seconds (document table "Action content"). Action 5 is missing from
# the English document; the vendor library's ActionTime gives it 4 s and no name, so we name it
# by number. 13 and 15 are both "wave" in the document (the Chinese seed covers the Rider only),
# so the second becomes wave_2. 12 "site down" is read as "sit down"; 255 is what the vendor's
# reset() sends.
DOG_ACTIONS: tuple[Action, ...] = tuple(
    Action(i, name, float(seconds))
    for i, name, seconds in (
        (1, "get_down", 3),
        (2, "stand_up", 3),
        (3, "creep_forward", 5),
        (4, "circle_around", 5),
        (5, "action_5", 4),
        (6, "squat_up", 4),
        (7, "turn_roll", 4),
        (8, "turn_pitch", 4),
        (9, "turn_yaw", 4),
        (10, "three_axis_rotation", 7),
        (11, "pee", 7),
        (12, "sit_down", 5),
        (13, "wave", 7),
        (14, "stretch", 10),
        (15, "wave_2", 6),
        (16, "swing_left_right", 6),
        (17, "beg_for_food", 4),
        (18, "look_for_food", 6),
        (19, "shake_hands", 10),
        (20, "chicken_head", 9),
        (21, "push_ups", 8),
        (22, "look_around", 7),
        (23, "dance", 6),
        (24, "naughty", 7),
        (128, "catch_up", 10),
        (129, "caught", 10),
        (130, "catch", 10),
        (255, "reset", 1),
    )
)

_DOG_CAPABILITIES = frozenset(
    {"legs", "lateral", "arm", "gripper", "actions", "periodic", "posture", "imu"}
)
# Writes that bring a dog to rest: speeds to neutral (0x80), mark time and every periodic motion
# off (0x00). Values are physical, converted by Register.to_byte.
_DOG_SAFE_STOP: tuple[tuple[str, float], ...] = (
    ("vx", 0.0),
    ("vy", 0.0),
    ("vyaw", 0.0),
    ("mark_time", 0.0),
    ("periodic_roll", 0.0),
    ("periodic_pitch", 0.0),
    ("periodic_yaw", 0.0),
    ("periodic_x", 0.0),
    ("periodic_y", 0.0),
    ("periodic_z", 0.0),
)
# Action 255 "restores the default posture": the body pose registers go back to their initial
# values. (The vendor's reset() says every parameter returns to its initial state, so a robot
# also stops: apply safe_stop with it.) Leg and servo registers are not listed: their initial
# 0x80 is not the standing pose in single-leg/servo mode coordinates.
_DOG_POSTURE = ("body_x", "body_y", "body_z", "roll", "pitch", "yaw")


def _dog_profile(
    model: str, title: str, ranges: Mapping[str, Range], firmware: str, prefixes: tuple[str, ...]
) -> Profile:
    return Profile(
        model=model,
        family="xgo",
        title=title,
        link=Link(baud=XGO_BAUD, gap=XGO_GAP),
        registers=_dog_registers(ranges, firmware),
        actions=DOG_ACTIONS,
        write_type=0x00,
        firmware_prefixes=prefixes,
        capabilities=_DOG_CAPABILITIES,
        safe_stop=_DOG_SAFE_STOP,
        default_posture=_DOG_POSTURE,
        firmware_default=firmware,
        imu=DOG_IMU,
    )


# Firmware strings follow the documented form "<model letter>-<version>" ("R-1.2.3" is the
# document's example); the version numbers here are only illustrative. The vendor's
# auto-detection drives "MW..." and "W..." firmware (XGO-mini2SW) with the Mini's parameters.
MINI = _dog_profile("mini", "XGO-Mini", MINI_RANGES, "M-1.4.1", ("M", "MW", "W"))
LITE = _dog_profile("lite", "XGO-Lite", LITE_RANGES, "L-1.4.1", ("L",))
