"""Telemetry polled in the link's spare capacity: battery, status, attitude.

The poller is pure bookkeeping (no I/O, no threads): the executor's writer asks it which read
request is due and sends it only where the next scheduled frame is far enough away; the
executor's reader feeds it whatever bytes arrive. XGO replies are parsed with the one XGO codec
and laid out with :meth:`Profile.walk`; frames nobody asked for (a Rider's auto-feedback, line
noise) are counted and ignored.

The xArm has one item, GetBatteryVoltage (a 4-byte request, a 6-byte reply: 4.2 + 6.3 ms at
9600 baud). How the controller treats a command that arrives while it is answering is not
documented, so the executor keeps room for the reply too (:attr:`TelemetryItem.reply_bytes`):
no scheduled frame reaches the board while it is answering. The reading is kept as
``battery_v`` (volts) and checked against the show's floor mapped onto the servos' 6.0..8.4 V
range (:func:`xgo_show.profiles.xarm.battery_floor_mv`).

Faults: a Rider reporting status 0x00 (fallen), or a battery below the floor on two readings in
a row (one low reading under a load spike is not a flat battery).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from xgo_show.errors import ProfileError
from xgo_show.profiles.model import Profile, Register
from xgo_show.profiles.xarm import battery_floor_mv
from xgo_show.wire import xarm as xarm_wire
from xgo_show.wire.xgo import XgoDecoder, read_frame

__all__ = ["FALLEN_STATUS", "TelemetryItem", "TelemetryPoller", "TelemetrySample"]

# Status register values that mean the robot has fallen over, by model (from the seed docs:
# the Rider's 0x02 "working status" reads 0x00 in the falling state).
FALLEN_STATUS: Mapping[str, int] = {"rider": 0x00}

# What is polled, as (item name, first register, registers read): read only where the model
# has the registers.
_ITEMS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("battery", ("battery",)),
    ("status", ("status",)),
    ("attitude", ("imu_roll", "imu_pitch")),
)


@dataclass(frozen=True)
class TelemetryItem:
    """One read request and the fields its reply carries.

    ``address`` is the first register read (XGO) or the command number (xArm, whose replies
    carry no register fields: ``fields`` is empty). ``reply_bytes`` is the reply's length where
    the robot must not receive a frame while it answers (the executor leaves room for it).
    """

    name: str
    address: int
    fields: tuple[Register, ...]
    request: bytes
    reply_bytes: int = 0

    @property
    def count(self) -> int:
        return sum(f.size for f in self.fields)


@dataclass(frozen=True)
class TelemetrySample:
    """One value read back: register name, value, monotonic time it arrived."""

    name: str
    value: float
    t: float


def _number(reg: Register, raw: bytes) -> float:
    """Register bytes -> a number: the decoded value, or the raw code for named enums."""
    value = reg.decode_value(raw)
    if isinstance(value, (int, float)):
        return float(value)
    return float(raw[0])


class TelemetryPoller:
    """Decides which read request is due and turns replies into samples and faults."""

    def __init__(
        self,
        profile: Profile,
        *,
        interval: float = 0.25,
        battery_floor: float | None = None,
        low_readings: int = 2,
    ) -> None:
        self.profile = profile
        self.interval = interval
        self.battery_floor = battery_floor
        self.low_readings = low_readings
        self.items = self._build_items(profile)
        self.last: dict[str, float] = {}
        self.samples = 0
        self.unsolicited = 0
        self.fault: str | None = None
        self._next = 0
        self._due = float("-inf")
        self._low = 0
        self._decoder: XgoDecoder | xarm_wire.XarmDecoder = (
            xarm_wire.XarmDecoder() if profile.family == "xarm" else XgoDecoder()
        )
        self._by_address = {item.address: item for item in self.items}

    @staticmethod
    def _build_items(profile: Profile) -> tuple[TelemetryItem, ...]:
        if profile.family == "xarm":
            reply = xarm_wire.battery_reply(0)
            return (
                TelemetryItem(
                    "battery_v",
                    int(xarm_wire.XarmCommand.GET_BATTERY_VOLTAGE),
                    (),
                    xarm_wire.get_battery_voltage(),
                    reply_bytes=len(reply),
                ),
            )
        if profile.family != "xgo":
            return ()
        out = []
        for name, reg_names in _ITEMS:
            try:
                regs = tuple(profile.register(r) for r in reg_names)
                walked = tuple(profile.walk(regs[0].address, sum(r.size for r in regs)))
            except ProfileError:
                continue
            if walked != regs or not all(r.access.readable for r in regs):
                continue
            count = sum(r.size for r in regs)
            out.append(
                TelemetryItem(name, regs[0].address, regs, read_frame(regs[0].address, count))
            )
        return tuple(out)

    @property
    def enabled(self) -> bool:
        return bool(self.items)

    @property
    def next_due(self) -> float:
        """Monotonic time the next request is due (``-inf``: now)."""
        return self._due if self.items else float("inf")

    def due(self, now: float) -> TelemetryItem | None:
        """The request to send now, if one is due."""
        if not self.items or now < self._due:
            return None
        return self.items[self._next]

    def sent(self, now: float) -> None:
        """The due request went out at ``now``: rotate to the next one."""
        self._next = (self._next + 1) % len(self.items)
        self._due = now + self.interval

    def feed(self, chunk: bytes, now: float) -> list[TelemetrySample]:
        """Parse received bytes; return the samples they complete and update ``fault``."""
        if isinstance(self._decoder, xarm_wire.XarmDecoder):
            return self._feed_xarm(self._decoder, chunk, now)
        out: list[TelemetrySample] = []
        for frame in self._decoder.feed(chunk):
            item = self._by_address.get(frame.address)
            if not frame.is_reply or item is None or len(frame.data) != item.count:
                self.unsolicited += 1
                continue
            pos = 0
            for reg in item.fields:
                value = _number(reg, frame.data[pos : pos + reg.size])
                pos += reg.size
                self.last[reg.name] = value
                out.append(TelemetrySample(reg.name, value, now))
                self._check(reg.name, value)
        self.samples += len(out)
        return out

    def _feed_xarm(
        self, decoder: xarm_wire.XarmDecoder, chunk: bytes, now: float
    ) -> list[TelemetrySample]:
        out: list[TelemetrySample] = []
        for packet in decoder.feed(chunk):
            if (
                packet.command is not xarm_wire.XarmCommand.GET_BATTERY_VOLTAGE
                or not packet.is_reply
            ):
                self.unsolicited += 1
                continue
            volts = xarm_wire.battery_mv(packet) / 1000.0
            self.last["battery_v"] = volts
            out.append(TelemetrySample("battery_v", volts, now))
            self._check("battery_v", volts)
        self.samples += len(out)
        return out

    def _check(self, name: str, value: float) -> None:
        if self.fault is not None:
            return
        fallen = FALLEN_STATUS.get(self.profile.model)
        if name == "status" and fallen is not None and int(value) == fallen:
            self.fault = f"{self.profile.model} reports status 0x{fallen:02X} (fallen)"
        if name == "battery" and self.battery_floor is not None:
            self._low = self._low + 1 if value < self.battery_floor else 0
            if self._low >= self.low_readings:
                self.fault = f"battery {value:.0f}% is below the floor of {self.battery_floor:g}%"
        if name == "battery_v" and self.battery_floor is not None:
            floor_v = battery_floor_mv(self.battery_floor) / 1000.0
            self._low = self._low + 1 if value < floor_v else 0
            if self._low >= self.low_readings:
                self.fault = (
                    f"battery {value:.2f} V is below the floor of {floor_v:.2f} V "
                    f"({self.battery_floor:g}% of the xArm's range)"
                )
