"""XGO-Rider (two-wheel-legged): the "Double wheel foot memory table 2024-11".

Table from xgo-serial-protocol-rider.md (and its Chinese original -zh.md, which also documents
0x02 = 0x01 normal and 0x03 = 0x01 loop). Physical ranges from the vendor library
(xgolib_rider.py, ``changePara('xgorider')``). The Rider's vendor library writes with command
type 0x01, so we do the same.
"""

from __future__ import annotations

from xgo_show.profiles._common import (
    HEIGHT,
    NEUTRAL,
    OFF,
    RIDER_IMU,
    XGO_BAUD,
    XGO_GAP,
    imu_registers,
    system_registers,
)
from xgo_show.profiles.model import Access, Action, Encoding, Limits, Link, Profile, Register

__all__ = ["RIDER", "RIDER_ACTIONS"]

FIRMWARE = "R-1.2.3"  # the document's own example

_RIDER_IMU_NOTE = (
    '24 bytes: six float32 little-endian values ("IMU 6-axis data"); order taken as acc x, y, '
    "z then gyro x, y, z (Profile.imu)"
)


def _registers() -> tuple[Register, ...]:
    """The Rider's registers, in the documents' order (built in a function, not as module data,
    so that mutation testing reaches the table: docs/contributing.md)."""
    return (
        *system_registers(
            FIRMWARE,
            bt_name_note=(
                "Bluetooth name, up to 20 ASCII letters and digits; shown as XGORider_<name>"
            ),
            update_reply="the robot answers with a command whose content is 0x55, then expects the "
            "hex file after 1 s",
        ),
        Register(
            0x02,
            "status",
            Access.READ,
            Encoding.ENUM,
            initial=b"\x01",
            choices={"fallen": 0, "normal": 1},
            description="0x00 fallen over, 0x01 normal",
            group="telemetry",
        ),
        Register(
            0x06,
            "set_origin",
            Access.WRITE,
            Encoding.ENUM,
            initial=OFF,
            choices={"idle": 0, "set": 1},
            description="0x01 takes the current heading as 0 degrees and zeroes the odometer",
            group="setting",
        ),
        Register(
            0x08,
            "auto_feedback",
            Access.WRITE,
            Encoding.ENUM,
            initial=OFF,
            choices={"off": 0, "on": 1},
            description="0x01 streams battery, joint angles, IMU and odometry at 50 Hz",
            group="setting",
        ),
        Register(
            0x0A,
            "steering_hold",
            Access.WRITE,
            Encoding.ENUM,
            initial=b"\x01",
            choices={"off": 0, "on": 1},
            description="static steering loop: on keeps the heading (turned by hand, it turns "
            "back)",
            group="setting",
        ),
        Register(
            0x30,
            "vx",
            Access.WRITE,
            Encoding.U8,
            initial=NEUTRAL,
            unit="m/s",
            minimum=-1.5,
            maximum=1.5,
            group="speed",
            limits=Limits(velocity=1.5, acceleration=6.0, jerk=40.0),  # our choice
            description="forward/backward speed; 0x80 = stop",
        ),
        Register(
            0x32,
            "vyaw",
            Access.WRITE,
            Encoding.U8,
            initial=NEUTRAL,
            unit="deg/s",
            minimum=-360.0,
            maximum=360.0,
            group="speed",
            limits=Limits(velocity=360.0, acceleration=1800.0, jerk=15000.0),  # our choice
            description="rotation speed (clockwise facing the z axis = maximum); 0x80 = stop",
        ),
        Register(
            0x35,
            "body_z",
            Access.WRITE,
            Encoding.U8,
            initial=NEUTRAL,
            unit="mm",
            minimum=60.0,
            maximum=120.0,
            limits=HEIGHT,
            group="posture",
            description="body height",
        ),
        # 0x36 is not in the Rider table, but the brief's canonical list and the vendor library
        # (rider_roll -> ATTITUDE 0x36, limit ±17 deg) use it.
        Register(
            0x36,
            "roll",
            Access.WRITE,
            Encoding.U8,
            initial=NEUTRAL,
            unit="deg",
            minimum=-17.0,
            maximum=17.0,
            group="posture",
            limits=Limits(velocity=40.0, acceleration=200.0, jerk=1500.0),  # our choice
            description="body roll; cannot work together with periodic_roll",
        ),
        Register(
            0x39,
            "periodic_roll",
            Access.WRITE,
            Encoding.U8_PERIODIC,
            initial=OFF,
            unit="s",
            minimum=1.0,
            maximum=2.0,
            group="periodic",
            description="roll the body periodically; value = period (1..2 s), 0 = off",
        ),
        Register(
            0x3E,
            "action",
            Access.WRITE,
            Encoding.U8,
            initial=OFF,
            group="action",
            description="run a preset action by id; 255 restores the default posture",
        ),
        *imu_registers(_RIDER_IMU_NOTE, mode_access=Access.WRITE),
        *(
            Register(
                0x69 + i,
                f"led{i + 1}",
                Access.WRITE,
                Encoding.RGB,
                size=3,
                initial=bytes(3),
                group="led",
                # No initial value in the document; a simulated robot starts with the LEDs off.
                description=f"LED {i + 1} colour r, g, b (0..255 each; 0, 0, 0 = off)",
            )
            for i in range(4)
        ),
        Register(
            0x82,
            "periodic_z",
            Access.WRITE,
            Encoding.U8_PERIODIC,
            initial=OFF,
            unit="s",
            minimum=1.0,
            maximum=2.0,
            group="periodic",
            description="move the body up and down periodically; value = period (1..2 s), "
            "0 = off; amplitude is half the position limit",
        ),
    )


# Rider actions: the documents give no durations (the vendor library's Rider ActionTime is a
# copy of the dog's table, so it is not evidence), hence None. 255 is the generic "restore the
# default posture" of the action register.
def _actions() -> tuple[Action, ...]:
    return (
        Action(1, "swinging", None),  # 左右摇摆
        Action(2, "ups_and_downs", None),  # 高低起伏
        Action(3, "forward_and_backward", None),  # 前进后退
        Action(4, "four_sided_serpentine", None),  # 四方蛇形
        Action(5, "lift_and_rotate", None),  # 升降旋转
        Action(6, "circular_shake", None),  # 圆周晃动
        Action(255, "reset", None),
    )


RIDER_ACTIONS = _actions()


def _rider() -> Profile:
    return Profile(
        model="rider",
        family="xgo",
        title="XGO-Rider",
        link=Link(baud=XGO_BAUD, gap=XGO_GAP),
        registers=tuple(sorted(_registers(), key=lambda r: r.address)),
        actions=RIDER_ACTIONS,
        write_type=0x01,
        # "RA..." firmware is the XGO-RA, which the vendor drives with other ranges (±87, height
        # 0..100): not a Rider for our tables, see registry.model_from_firmware.
        firmware_prefixes=("R",),
        capabilities=frozenset({"wheels", "led", "actions", "periodic", "posture", "imu"}),
        safe_stop=(("vx", 0.0), ("vyaw", 0.0), ("periodic_roll", 0.0), ("periodic_z", 0.0)),
        default_posture=("body_z", "roll"),
        firmware_default=FIRMWARE,
        imu=RIDER_IMU,
    )


RIDER = _rider()
