"""XGO telemetry: register reads polled during a show (battery, status, attitude).

Each item reads adjacent registers in one request, only where the model has them all, readable
and laid out as :meth:`Profile.walk` says; replies are matched by their first address.
"""

from __future__ import annotations

from collections.abc import Mapping

from xgo_show.errors import ProfileError
from xgo_show.families.values import TelemetryItem
from xgo_show.profiles.model import Profile, Register
from xgo_show.wire.xgo import XgoFrame, read_frame

__all__ = ["FALLEN_STATUS", "battery_low", "telemetry_fault", "telemetry_items", "telemetry_values"]

# Status register values that mean the robot has fallen over, by model (from the seed docs:
# the Rider's 0x02 "working status" reads 0x00 in the falling state).
FALLEN_STATUS: Mapping[str, int] = {"rider": 0x00}

# What is polled, as (item name, registers read in one request): read only where the model
# has the registers.
_ITEMS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("battery", ("battery",)),
    ("status", ("status",)),
    ("attitude", ("imu_roll", "imu_pitch")),
)


def telemetry_items(profile: Profile) -> tuple[TelemetryItem, ...]:
    """The read requests this model answers, in polling order."""
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
        out.append(TelemetryItem(name, regs[0].address, regs, read_frame(regs[0].address, count)))
    return tuple(out)


def _number(reg: Register, raw: bytes) -> float:
    """Register bytes -> a number: the decoded value, or the raw code for named enums."""
    value = reg.decode_value(raw)
    if isinstance(value, (int, float)):
        return float(value)
    return float(raw[0])


def telemetry_values(
    items: Mapping[int, TelemetryItem], frame: XgoFrame
) -> list[tuple[str, float]] | None:
    """(register, value) of each field of a reply to one of ``items``; None for other frames."""
    item = items.get(frame.address)
    if not frame.is_reply or item is None or len(frame.data) != item.count:
        return None
    out: list[tuple[str, float]] = []
    pos = 0
    for reg in item.fields:
        out.append((reg.name, _number(reg, frame.data[pos : pos + reg.size])))
        pos += reg.size
    return out


def telemetry_fault(profile: Profile, name: str, value: float) -> str | None:
    """A status reading that means the robot has fallen (:data:`FALLEN_STATUS`)."""
    fallen = FALLEN_STATUS.get(profile.model)
    if name == "status" and fallen is not None and int(value) == fallen:
        return f"{profile.model} reports status 0x{fallen:02X} (fallen)"
    return None


def battery_low(name: str, value: float, floor: float) -> tuple[bool, str] | None:
    """The ``battery`` register (percent) against the floor (percent)."""
    if name != "battery":
        return None
    return value < floor, f"battery {value:.0f}% is below the floor of {floor:g}%"
