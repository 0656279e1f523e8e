"""Pieces shared by the XGO tables (Mini, Lite, Rider): trajectory limits and common registers.

Internal: the per-family modules :mod:`xgo_dog` and :mod:`xgo_rider` build their tables from
these so that a register both families document the same way is written down once.
"""

from __future__ import annotations

import struct

from xgo_show.profiles.model import Access, Encoding, ImuField, ImuLayout, Limits, Register

__all__ = [
    "ANGLE",
    "ARM",
    "ARM_SERVO",
    "DOG_IMU",
    "GRIPPER",
    "HEIGHT",
    "LEG",
    "LEG_SERVO",
    "NEUTRAL",
    "OFF",
    "RIDER_IMU",
    "TRANSLATION",
    "XGO_BAUD",
    "XGO_GAP",
    "XGO_GAP_MARGIN",
    "XGO_MIN_GAP",
    "imu_registers",
    "system_registers",
]

XGO_BAUD = 115200
# The XGO documents ask for at least 1 ms between instructions. The runtime issues a frame that
# long after the previous one's last byte, but delivery jitters: seen from the robot's side of a
# pseudo-terminal, 1.0 ms silences arrive shorter by up to 0.16 ms outside stalls (0.84 ms: issue
# 12's measurement; benchmarks/silence_jitter.py prints the silences with and without a margin).
# The 0.2 ms margin covers that; the link carries a show's frames a few percent of the time, so
# it costs almost nothing. Frames a stall delivers together no margin can part.
XGO_MIN_GAP = 0.001
XGO_GAP_MARGIN = 0.0002
XGO_GAP = round(XGO_MIN_GAP + XGO_GAP_MARGIN, 6)  # planned between frames: compiler, runtime

NEUTRAL = b"\x80"  # documented initial value of every linear u8 register
OFF = b"\x00"

# Default trajectory limits (velocity, acceleration, jerk per second^n in the register's unit).
# These are OUR choices, not vendor facts: the documents give no rates. They are gentle enough
# that the servos of a small robot follow them without lag, and still let a show look lively
# (a full body-height swing of 45 mm takes under a second).
TRANSLATION = Limits(velocity=60.0, acceleration=300.0, jerk=2000.0)  # mm
HEIGHT = Limits(velocity=60.0, acceleration=300.0, jerk=2000.0)  # mm
ANGLE = Limits(velocity=60.0, acceleration=300.0, jerk=2000.0)  # deg
LEG = Limits(velocity=80.0, acceleration=400.0, jerk=3000.0)  # mm, foot positions
LEG_SERVO = Limits(velocity=120.0, acceleration=600.0, jerk=5000.0)  # deg, joints
ARM_SERVO = Limits(velocity=90.0, acceleration=450.0, jerk=4000.0)  # deg, arm joints
ARM = Limits(velocity=80.0, acceleration=400.0, jerk=3000.0)  # mm, arm end point
GRIPPER = Limits(velocity=100.0, acceleration=500.0, jerk=4000.0)  # % closed

# IMU block at 0x65. The dog's layout is what the vendor library decodes (unpack_imu): six int16
# little-endian (accelerometer raw / 16384 * 9.8 m/s², gyroscope raw / 16.4 °/s) and then
# roll, pitch, yaw as float32 little-endian degrees (the library converts them to radians
# itself). The Rider document says "float*6, 24 bytes"; the vendor library reads the same six
# float32 little-endian values (unpack_imu_r). Their order is not documented: we take the dog's
# (acc x, y, z then gyro x, y, z) and the physical units as-is (m/s², °/s).
_ACC = 9.8 / 16384
_GYRO = 1 / 16.4
DOG_IMU = ImuLayout(
    (
        ImuField("acc_x", "<h", _ACC, "m/s²"),
        ImuField("acc_y", "<h", _ACC, "m/s²"),
        ImuField("acc_z", "<h", _ACC, "m/s²"),
        ImuField("gyro_x", "<h", _GYRO, "deg/s"),
        ImuField("gyro_y", "<h", _GYRO, "deg/s"),
        ImuField("gyro_z", "<h", _GYRO, "deg/s"),
        ImuField("roll", "<f", 1.0, "deg"),
        ImuField("pitch", "<f", 1.0, "deg"),
        ImuField("yaw", "<f", 1.0, "deg"),
    )
)
RIDER_IMU = ImuLayout(
    (
        ImuField("acc_x", "<f", 1.0, "m/s²"),
        ImuField("acc_y", "<f", 1.0, "m/s²"),
        ImuField("acc_z", "<f", 1.0, "m/s²"),
        ImuField("gyro_x", "<f", 1.0, "deg/s"),
        ImuField("gyro_y", "<f", 1.0, "deg/s"),
        ImuField("gyro_z", "<f", 1.0, "deg/s"),
    )
)

_FLOAT_ZERO = struct.pack("<f", 0.0)


def system_registers(
    firmware: str, *, bt_name_note: str, update_reply: str
) -> tuple[Register, ...]:
    """Battery, show mode, calibration, firmware update and version, Bluetooth name.

    Same address and meaning on every XGO; ``firmware`` becomes the initial firmware string.
    """
    return (
        Register(
            0x01,
            "battery",
            Access.READ,
            Encoding.U8,
            initial=bytes((100,)),
            unit="%",
            description=(
                "Battery level 0..100 %, the byte is the percentage. The documents give 0xFF as "
                "the initial value but a 0..100 range; a simulated robot starts full (100)."
            ),
            group="telemetry",
        ),
        Register(
            0x03,
            "show_mode",
            Access.WRITE,
            Encoding.ENUM,
            initial=OFF,
            choices={"normal": 0, "loop": 1},
            description="0x00 normal control, 0x01 loop the preset actions (performance mode)",
            group="setting",
        ),
        Register(
            0x04,
            "calibration",
            Access.WRITE,
            Encoding.ENUM,
            initial=OFF,
            choices={"exit": 0, "enter": 1},
            description="0x01 enter calibration mode, 0x00 exit and store the calibration",
            unsafe=True,
            group="setting",
        ),
        Register(
            0x05,
            "firmware_update",
            Access.WRITE,
            Encoding.ENUM,
            initial=OFF,
            choices={"off": 0, "update": 1},
            description=f"0x01 enter firmware update mode; {update_reply}",
            unsafe=True,
            group="setting",
        ),
        Register(
            0x07,
            "firmware",
            Access.READ,
            Encoding.ASCII,
            size=10,
            initial=firmware.encode("ascii").ljust(10, b"\0"),
            description=(
                "Firmware version, a 10-byte NUL-padded ASCII string such as 'R-1.2.3'; the first "
                "letter names the model (M mini, L lite, R rider)"
            ),
            group="telemetry",
        ),
        Register(
            0x13,
            "bt_name",
            Access.WRITE,
            Encoding.ASCII,
            size=20,
            initial=bytes(20),
            description=bt_name_note,
            unsafe=True,
            group="setting",
        ),
    )


def imu_registers(block: str, *, mode_access: Access) -> tuple[Register, ...]:
    """Self-stabilisation switch and IMU read-outs at 0x61..0x68 (same on every XGO)."""
    angles = (
        Register(
            0x62 + i,
            f"imu_{axis}",
            Access.READ,
            Encoding.FLOAT32,
            size=4,
            initial=_FLOAT_ZERO,
            unit="deg",
            description=f"{axis} angle, float32 little-endian degrees",
            group="telemetry",
        )
        for i, axis in enumerate(("roll", "pitch", "yaw"))
    )
    ints = (
        Register(
            0x66 + i,
            f"imu_{axis}_i16",
            Access.READ,
            Encoding.INT16,
            size=2,
            initial=bytes(2),
            unit="deg",
            description=(
                f"{axis} angle, int16 big-endian (as the vendor library's Byte2Short reads it); "
                "the documents give no scale, the vendor library returns the raw value as degrees"
            ),
            group="telemetry",
        )
        for i, axis in enumerate(("roll", "pitch", "yaw"))
    )
    return (
        Register(
            0x61,
            "imu_mode",
            mode_access,
            Encoding.ENUM,
            initial=OFF,
            choices={"off": 0, "stabilise": 1},
            description="0x00 off, 0x01 self-stabilising mode",
            group="setting",
        ),
        *angles,
        Register(
            0x65,
            "imu_block",
            Access.READ,
            Encoding.BLOCK,
            size=24,
            initial=bytes(24),
            description=block,
            group="telemetry",
        ),
        *ints,
    )
