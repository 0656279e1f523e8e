"""Data types for device profiles: registers, actions, link and capabilities.

A profile is data, not code: the per-model tables in this package build these objects and every
other layer (compiler, simulator, runtime) reads them. Conversions between physical values and
register bytes live on :class:`Register` so that there is exactly one implementation.
"""

from __future__ import annotations

import enum
import math
import struct
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import cast

from xgo_show.errors import ProfileError, ValueRangeError

__all__ = [
    "Access",
    "Action",
    "Encoding",
    "ImuField",
    "ImuLayout",
    "Limits",
    "Link",
    "Profile",
    "Register",
    "limit_unit",
]


class Access(enum.Enum):
    READ = "read"
    WRITE = "write"
    READ_WRITE = "read-write"

    @property
    def readable(self) -> bool:
        return self is not Access.WRITE

    @property
    def writable(self) -> bool:
        return self is not Access.READ


class Encoding(enum.Enum):
    """How a register's bytes encode its value."""

    U8 = "u8"  # one byte; linear physical range when Register.minimum/maximum are set
    U8_PERIODIC = "u8-periodic"  # 0x00 = off, 0x01..0xFF linear over [minimum, maximum]
    ENUM = "enum"  # one byte with named values (Register.choices)
    FLOAT32 = "float32"  # 4 bytes little-endian IEEE 754
    INT16 = "int16"  # 2 bytes signed, big-endian (as the vendor library reads 0x66..0x68)
    RGB = "rgb"  # 3 bytes r, g, b
    ASCII = "ascii"  # fixed-size ASCII string, NUL padded
    BLOCK = "block"  # opaque fixed-size block (e.g. the 24-byte IMU block at 0x65)


#: The range of a velocity, acceleration or jerk limit the trajectory planner is given: below
#: 1e-3 (units/s^n) a move of a few units takes hours, above 1e7 the planner's numerics break
#: down; every profile's own limits lie well inside.
LIMIT_RANGE = (1e-3, 1e7)


@dataclass(frozen=True)
class Limits:
    """Kinematic limits for trajectories, in the register's physical unit per second^n."""

    velocity: float
    acceleration: float
    jerk: float


_POWERS = {1: "", 2: "²", 3: "³", 4: "⁴"}
_ORDERS = {"velocity": 1, "acceleration": 2, "jerk": 3}


def limit_unit(unit: str | None, kind: str) -> str:
    """The unit of a register's ``velocity``, ``acceleration`` or ``jerk`` limit: ``mm/s``,
    ``deg/s²``; a register already in a rate goes one power up (``deg/s`` -> ``deg/s³`` for
    its acceleration)."""
    order = _ORDERS[kind]
    if not unit:
        return f"its unit per second{_POWERS[order]}"
    if unit.endswith("/s"):
        return f"{unit[:-2]}/s{_POWERS[order + 1]}"
    return f"{unit}/s{_POWERS[order]}"


@dataclass(frozen=True)
class Register:
    """One register in a robot's memory table.

    Each address names one *field* of ``size`` bytes (a float32 at 0x62 and another at 0x63; an
    RGB triple at 0x69 and the next at 0x6A). A read or write of several bytes from a first
    address walks fields at consecutive addresses, taking each field's ``size`` bytes in turn
    (see :meth:`Profile.walk`); for the common one-byte registers that is plain consecutive
    memory.

    For linear ``U8`` registers, :meth:`to_byte` maps ``[minimum, maximum]`` onto 0x00..0xFF.
    When the range straddles zero the map is piecewise linear through (0, 0x80), so that zero
    is exactly the documented neutral 0x80 (the vendor library truncates zero speed to 0x7F and
    its "stop" creeps). Rounding is to nearest. Values outside the range raise
    :class:`ValueRangeError`; nothing is silently clamped.
    """

    address: int
    name: str
    access: Access
    encoding: Encoding = Encoding.U8
    size: int = 1
    initial: bytes | None = None
    unit: str | None = None
    minimum: float | None = None
    maximum: float | None = None
    description: str = ""
    choices: Mapping[str, int] = field(default_factory=dict)
    unsafe: bool = False  # never touched during a show (firmware, calibration, rename, unload…)
    limits: Limits | None = None  # default trajectory limits; None = not trajectory-capable
    group: str = ""  # what kind of control this is: "speed", "posture", "periodic", "leg", …
    # False: a range that straddles zero maps plainly linearly over [minimum, maximum] (the
    # document states so for asymmetric ranges such as arm_x [-80, 155] mm, and the vendor
    # library converts asymmetric servo ranges that way), so zero is *not* at 0x80.
    zero_at_neutral: bool = True

    @property
    def linear(self) -> bool:
        return self.minimum is not None and self.maximum is not None

    def check(self, value: float) -> None:
        """Raise :class:`ValueRangeError` if ``value`` is outside the physical range."""
        if not self.linear:
            return
        assert self.minimum is not None and self.maximum is not None
        if math.isnan(value) or not self.minimum - 1e-9 <= value <= self.maximum + 1e-9:
            unit = f" {self.unit}" if self.unit else ""
            raise ValueRangeError(
                # Enough digits that a value just past a limit never prints as the limit.
                f"{self.name} = {value:.10g}{unit} is out of range "
                f"[{self.minimum:g}, {self.maximum:g}]{unit}"
            )

    def to_byte(self, value: float) -> int:
        """Physical value -> register byte (linear U8 and U8_PERIODIC registers)."""
        if self.encoding is Encoding.U8_PERIODIC and value == 0:
            return 0
        if not self.linear:
            if isinstance(value, float) and not value.is_integer():
                raise ValueRangeError(f"{self.name} takes a whole byte value, not {value:g}")
            if not 0 <= value <= 0xFF:
                raise ValueRangeError(f"{self.name} = {value:g} is not a byte (0..255)")
            return int(value)
        self.check(value)
        lo, hi = self.minimum, self.maximum
        assert lo is not None and hi is not None
        value = min(max(value, lo), hi)  # absorb the 1e-9 tolerance of check()
        if self.encoding is Encoding.U8_PERIODIC:
            return 1 + round((value - lo) / (hi - lo) * 254)
        if lo < 0 < hi and self.zero_at_neutral:
            if value >= 0:
                return 0x80 + round(value / hi * 0x7F)
            return 0x80 - round(value / lo * 0x80)
        return round((value - lo) / (hi - lo) * 0xFF)

    def to_physical(self, byte: int) -> float:
        """Register byte -> physical value (inverse of :meth:`to_byte`)."""
        if not self.linear:
            return float(byte)
        lo, hi = self.minimum, self.maximum
        assert lo is not None and hi is not None
        if self.encoding is Encoding.U8_PERIODIC:
            return 0.0 if byte == 0 else lo + (byte - 1) / 254 * (hi - lo)
        if lo < 0 < hi and self.zero_at_neutral:
            if byte >= 0x80:
                return (byte - 0x80) / 0x7F * hi
            return (0x80 - byte) / 0x80 * lo
        return lo + byte / 0xFF * (hi - lo)

    def encode_value(self, value: object) -> bytes:
        """Encode a value of any encoding into this register's bytes.

        Raises :class:`ValueRangeError` for a value out of range or of the wrong kind (a
        string or a bool where a number is needed, ...).
        """
        enc = self.encoding
        numeric = (Encoding.U8, Encoding.U8_PERIODIC, Encoding.FLOAT32, Encoding.INT16)
        if enc in numeric and (isinstance(value, bool) or not isinstance(value, (int, float))):
            raise ValueRangeError(f"{self.name} takes a number, not {value!r}")
        if enc is Encoding.ENUM and (isinstance(value, bool) or
                                     not isinstance(value, (int, str))):
            allowed = ", ".join(self.choices)
            raise ValueRangeError(f"{self.name} takes one of {allowed}, not {value!r}")
        if enc in (Encoding.U8, Encoding.U8_PERIODIC):
            return bytes((self.to_byte(float(value)),))  # type: ignore[arg-type]
        if enc is Encoding.ENUM:
            if isinstance(value, str):
                if value not in self.choices:
                    allowed = ", ".join(self.choices)
                    raise ValueRangeError(f"{self.name}: unknown value {value!r}; one of {allowed}")
                return bytes((self.choices[value],))
            if int(value) not in self.choices.values():  # type: ignore[call-overload]
                raise ValueRangeError(f"{self.name}: {value!r} is not one of {dict(self.choices)}")
            return bytes((int(value),))  # type: ignore[call-overload]
        if enc is Encoding.FLOAT32:
            return struct.pack("<f", float(value))  # type: ignore[arg-type]
        if enc is Encoding.INT16:
            return struct.pack(">h", int(value))  # type: ignore[call-overload]
        if enc is Encoding.RGB:
            rgb = tuple(cast("Iterable[object]", value))
            if len(rgb) != 3 or not all(isinstance(c, int) and 0 <= c <= 255 for c in rgb):
                raise ValueRangeError(f"{self.name} takes three bytes r, g, b in 0..255")
            return bytes(cast("tuple[int, ...]", rgb))
        if enc is Encoding.ASCII:
            raw = str(value).encode("ascii")
            if len(raw) > self.size:
                raise ValueRangeError(f"{self.name} holds at most {self.size} ASCII characters")
            return raw.ljust(self.size, b"\0")
        raw = bytes(cast("bytes", value))
        if len(raw) != self.size:
            raise ValueRangeError(f"{self.name} is a {self.size}-byte block")
        return raw

    def decode_value(self, raw: bytes) -> object:
        """This register's bytes -> value (inverse of :meth:`encode_value`).

        Linear ``U8``/``U8_PERIODIC`` give the physical float, other ``U8`` the byte as int,
        ``ENUM`` the choice's name (the int if unnamed), ``FLOAT32`` float, ``INT16`` int,
        ``RGB`` an ``(r, g, b)`` tuple, ``ASCII`` the string without NUL padding, ``BLOCK`` the
        bytes. Raises :class:`ValueRangeError` if ``raw`` is not ``size`` bytes.
        """
        if len(raw) != self.size:
            raise ValueRangeError(f"{self.name} is {self.size} bytes, not {len(raw)}")
        enc = self.encoding
        if enc in (Encoding.U8, Encoding.U8_PERIODIC):
            return self.to_physical(raw[0]) if self.linear else raw[0]
        if enc is Encoding.ENUM:
            for label, code in self.choices.items():
                if code == raw[0]:
                    return label
            return raw[0]
        if enc is Encoding.FLOAT32:
            return float(struct.unpack("<f", raw)[0])
        if enc is Encoding.INT16:
            return int(struct.unpack(">h", raw)[0])
        if enc is Encoding.RGB:
            return (raw[0], raw[1], raw[2])
        if enc is Encoding.ASCII:
            return raw.split(b"\0", 1)[0].decode("ascii", errors="replace")
        return bytes(raw)


@dataclass(frozen=True)
class ImuField:
    """One value in an IMU block: its struct format and the scale from raw to physical."""

    name: str
    fmt: str  # struct format of one value, byte order included: "<h", "<f"
    scale: float = 1.0  # physical value = raw value * scale
    unit: str = ""

    @property
    def size(self) -> int:
        return struct.calcsize(self.fmt)


@dataclass(frozen=True)
class ImuLayout:
    """The fields of an IMU block register, in byte order (see ``Profile.imu``)."""

    fields: tuple[ImuField, ...]

    @property
    def size(self) -> int:
        return sum(f.size for f in self.fields)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.fields)

    def pack(self, values: Mapping[str, float]) -> bytes:
        """Physical values (missing names = 0) -> block bytes; integers round to nearest."""
        unknown = set(values) - set(self.names)
        if unknown:
            raise ValueRangeError(f"IMU block has no field {sorted(unknown)[0]!r}")
        out = bytearray()
        for f in self.fields:
            raw = values.get(f.name, 0.0) / f.scale
            if f.fmt[-1] in "fd":
                out += struct.pack(f.fmt, raw)
                continue
            try:
                out += struct.pack(f.fmt, round(raw))
            except struct.error as exc:
                raise ValueRangeError(
                    f"IMU {f.name} = {values[f.name]:g} {f.unit} does not fit {f.fmt!r}"
                ) from exc
        return bytes(out)

    def unpack(self, raw: bytes) -> dict[str, float]:
        """Block bytes -> physical values by field name."""
        if len(raw) != self.size:
            raise ValueRangeError(f"IMU block is {self.size} bytes, not {len(raw)}")
        out: dict[str, float] = {}
        offset = 0
        for f in self.fields:
            (value,) = struct.unpack_from(f.fmt, raw, offset)
            out[f.name] = float(value) * f.scale
            offset += f.size
        return out


@dataclass(frozen=True)
class Action:
    """A preset action; ``duration`` is None where the documents do not give it."""

    id: int
    name: str
    duration: float | None


@dataclass(frozen=True)
class Link:
    """The serial link to a robot: 8N1 at ``baud``, ``gap`` seconds of silence between frames."""

    baud: int
    gap: float
    bits_per_byte: int = 10  # start + 8 data + stop

    def wire_time(self, nbytes: int) -> float:
        """Seconds the link needs to carry ``nbytes``."""
        return nbytes * self.bits_per_byte / self.baud


@dataclass(frozen=True)
class Profile:
    """Everything the rest of the package needs to know about one robot model."""

    model: str
    family: str  # its robot family (xgo_show.families): "xgo", "xarm", or one registered
    title: str
    link: Link
    registers: tuple[Register, ...] = ()
    actions: tuple[Action, ...] = ()
    write_type: int = 0x00
    firmware_prefixes: tuple[str, ...] = ()
    capabilities: frozenset[str] = frozenset()
    # Register writes (name -> physical value or raw byte) that bring the robot to rest.
    safe_stop: tuple[tuple[str, float], ...] = ()
    # Registers whose values make up the default posture (restored by action 255).
    default_posture: tuple[str, ...] = ()
    xarm_servos: tuple[int, ...] = ()  # xArm servo ids (family "xarm")
    # What a simulated robot of this model reports at the firmware register (0x07).
    firmware_default: str = ""
    # Layout of the IMU block register (imu_block, 0x65); None where the model has none.
    imu: ImuLayout | None = None

    def register(self, name: str) -> Register:
        """Look a register up by name; the error lists the valid names."""
        for reg in self.registers:
            if reg.name == name:
                return reg
        valid = ", ".join(sorted(r.name for r in self.registers if not r.unsafe))
        raise ProfileError(f"{self.model} has no register {name!r}; valid: {valid}")

    def register_at(self, address: int) -> Register | None:
        """The register that starts at ``address``, if any."""
        for reg in self.registers:
            if reg.address == address:
                return reg
        return None

    def walk(self, address: int, nbytes: int) -> list[Register]:
        """The fields a read/write of ``nbytes`` from ``address`` covers, in order.

        Raises :class:`ProfileError` if an address on the way has no register or the last field
        would be cut short. Shared by the simulator (to apply writes and answer reads) and the
        compiler (to merge adjacent registers into one frame), so both agree on the layout.
        """
        out: list[Register] = []
        left = nbytes
        addr = address
        while left > 0:
            reg = self.register_at(addr)
            if reg is None:
                raise ProfileError(f"{self.model} has no register at 0x{addr:02X}")
            if reg.size > left:
                raise ProfileError(
                    f"{reg.name} at 0x{addr:02X} is {reg.size} bytes; only {left} remain"
                )
            out.append(reg)
            left -= reg.size
            addr += 1
        return out

    def action(self, key: int | str) -> Action:
        """Look an action up by number or name; the error lists the valid ones."""
        for act in self.actions:
            if act.id == key or act.name == key:
                return act
        valid = ", ".join(f"{a.id} {a.name}" for a in self.actions)
        raise ProfileError(f"{self.model} has no action {key!r}; valid: {valid}")

    def supports(self, capability: str) -> bool:
        return capability in self.capabilities
