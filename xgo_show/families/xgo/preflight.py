"""XGO pre-flight: the firmware string names the model, the battery is above the floor."""

from __future__ import annotations

from typing import TYPE_CHECKING

from xgo_show.errors import XgoShowError
from xgo_show.profiles import Profile, model_from_firmware
from xgo_show.transports.base import Transport

if TYPE_CHECKING:
    from xgo_show.runtime.preflight import PreflightRow

__all__ = ["check_robot"]


def check_robot(
    row: PreflightRow, transport: Transport, profile: Profile, floor: float, timeout: float
) -> None:
    """Read the firmware and battery registers; a wrong model or a low battery is a problem."""
    from xgo_show.client import XgoClient

    client = XgoClient(transport, profile, timeout=timeout)
    try:
        row.firmware = client.firmware()
        row.detected = model_from_firmware(row.firmware)
        if row.detected != profile.model:
            seen = row.detected or "an unknown model"
            row.problems.append(f"firmware {row.firmware!r} is {seen}, not {profile.model}")
        row.battery = float(client.battery())
        if row.battery < floor:
            row.problems.append(f"battery {row.battery:.0f}% is below the floor of {floor:g}%")
    except XgoShowError as exc:
        row.problems.append(str(exc))
