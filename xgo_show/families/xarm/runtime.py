"""xArm at run time: GroupStop, unsafe commands, battery telemetry, pre-flight and probe.

The xArm has one telemetry item, GetBatteryVoltage (a 4-byte request, a 6-byte reply: 4.2 + 6.3
ms at 9600 baud). How the controller treats a command that arrives while it is answering is not
documented, so the item carries the reply's length (:attr:`TelemetryItem.reply_bytes`) and the
executor sends nothing while the board answers. The reading is ``battery_v`` (volts). The
battery floor, a percentage, is mapped onto the servos' 6.0..8.4 V range
(:func:`xgo_show.profiles.xarm.battery_floor_mv`). The xArm has no firmware string: an answer in
its protocol is what identifies it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from xgo_show.errors import XgoShowError
from xgo_show.families.values import StopFrame, TelemetryItem
from xgo_show.profiles.model import Profile
from xgo_show.profiles.xarm import (
    BATTERY_MV_EMPTY,
    BATTERY_MV_FULL,
    UNSAFE_COMMANDS,
    battery_floor_mv,
    battery_percent,
    position_to_degrees,
)
from xgo_show.wire import xarm as xarm_wire

if TYPE_CHECKING:
    from xgo_show.client.xarm import XarmClient
    from xgo_show.runtime.preflight import PreflightRow
    from xgo_show.transports.base import Transport

__all__ = [
    "battery_low",
    "check_robot",
    "floor_text",
    "probe_rows",
    "stop_frames",
    "telemetry_items",
    "telemetry_values",
    "unsafe_problems",
]


def stop_frames() -> list[StopFrame]:
    """GroupStop: the controller stops running action groups (servos hold where they are)."""
    return [StopFrame(xarm_wire.group_stop(), "GroupStop")]


def unsafe_problems(data: bytes) -> list[str]:
    """What is unsafe about one xArm frame: not one valid request packet, or an unsafe command
    (:data:`xgo_show.profiles.xarm.UNSAFE_COMMANDS`)."""
    from xgo_show.compiler.artifact import xarm_frame_problem

    problem = xarm_frame_problem(data)
    if problem is not None:
        return [f"unknown packet: {problem}"]
    _, packet = xarm_wire.decode_one(data)
    assert packet is not None  # xarm_frame_problem found one whole packet
    why = UNSAFE_COMMANDS.get(int(packet.command))
    if why is None:
        return []
    return [f"sends unsafe command {packet.command.label} ({int(packet.command)}: {why})"]


def telemetry_items() -> tuple[TelemetryItem, ...]:
    """GetBatteryVoltage, the one reading the xArm gives."""
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


def telemetry_values(
    items: Mapping[int, TelemetryItem], packet: xarm_wire.XarmPacket
) -> list[tuple[str, float]] | None:
    """``[("battery_v", volts)]`` for a battery reply; None for any other packet."""
    if packet.command is not xarm_wire.XarmCommand.GET_BATTERY_VOLTAGE or not packet.is_reply:
        return None
    return [("battery_v", xarm_wire.battery_mv(packet) / 1000.0)]


def battery_low(name: str, value: float, floor: float) -> tuple[bool, str] | None:
    """``battery_v`` (volts) against the floor mapped onto the servos' 6.0..8.4 V range."""
    if name != "battery_v":
        return None
    floor_v = battery_floor_mv(floor) / 1000.0
    return value < floor_v, (
        f"battery {value:.2f} V is below the floor of {floor_v:.2f} V "
        f"({floor:g}% of the xArm's range)"
    )


def floor_text(floor: float) -> str:
    """The xArm's battery floor in volts, with where it comes from: ``6.48 V (20% of ...)``."""
    return (
        f"{battery_floor_mv(floor) / 1000:.2f} V = {floor:g}% of "
        f"{BATTERY_MV_EMPTY / 1000:.2f}..{BATTERY_MV_FULL / 1000:.2f} V"
    )


def check_robot(
    row: PreflightRow, transport: Transport, profile: Profile, floor: float, timeout: float
) -> None:
    """Read the battery voltage (the answer identifies the arm) and check it against the floor."""
    from xgo_show.client import XarmClient

    try:
        millivolts = XarmClient(transport, profile, timeout=timeout).battery_mv()
    except XgoShowError as exc:
        row.problems.append(str(exc))
        return
    row.firmware = "xArm controller"
    row.detected = profile.model
    row.voltage = millivolts / 1000
    row.battery = battery_percent(millivolts)
    if millivolts < battery_floor_mv(floor):
        row.problems.append(
            f"battery {row.voltage:.2f} V is below the floor of {floor_text(floor)}"
        )


def probe_rows(client: XarmClient, *, given: str | None) -> list[tuple[str, str]]:
    """``xgo-show probe``: port, model, battery voltage and every servo's position."""
    millivolts = client.battery_mv()
    rows = [
        ("port", client.transport.url),
        ("model", "xarm" if given else "xarm (from the URL)"),
        ("battery", f"{millivolts / 1000:.2f} V"),
    ]
    for servo, position in client.positions().items():
        rows.append(
            (f"servo {servo}", f"{position:4d}  ({position_to_degrees(position):+.1f} deg)")
        )
    return rows
