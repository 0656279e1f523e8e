"""The robots a relay owns: their ports, opened once for the relay's whole life.

``--map NAME=PORT`` takes the same ports and URLs as ``xgo-show run`` (``/dev/ttyUSB0``,
``sim:mini``, a pty path, ``hex+...``). The model comes from ``--model NAME=MODEL``, else from
a ``sim:`` URL, else from the robot's firmware string (XGO robots; an xArm on a serial port
needs ``--model NAME=xarm``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from xgo_show.client import XarmClient, XgoClient, open_client
from xgo_show.errors import SetupError, UsageError, XgoShowError
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Profile
from xgo_show.runtime.safety import stop_frames
from xgo_show.transports.base import Transport

__all__ = ["OwnedRobot", "close_robots", "open_robots", "parse_pairs"]


@dataclass
class OwnedRobot:
    """One robot on one open port, with what the relay last read from it."""

    name: str
    url: str
    model: str
    transport: Transport
    firmware: str = ""
    battery: float | None = None  # percent
    voltage: float | None = None  # volts (xArm)
    problems: list[str] = field(default_factory=list)

    @property
    def profile(self) -> Profile:
        return get_profile(self.model)

    def client(self, timeout: float = 0.5) -> XgoClient | XarmClient:
        """A client for the robot on the open port (reads; nothing is sent unasked)."""
        profile = self.profile
        if profile.family == "xarm":
            return XarmClient(self.transport, profile, timeout=timeout)
        return XgoClient(self.transport, profile, timeout=timeout)

    def refresh(self, timeout: float = 0.3) -> None:
        """Read firmware and battery again (only while no show runs on the port)."""
        self.problems.clear()
        profile = self.profile
        try:
            if profile.family == "xarm":
                millivolts = XarmClient(self.transport, profile, timeout=timeout).battery_mv()
                self.firmware = "xArm controller"
                self.voltage = millivolts / 1000
                from xgo_show.profiles.xarm import battery_percent

                self.battery = battery_percent(millivolts)
            else:
                client = XgoClient(self.transport, profile, timeout=timeout)
                self.firmware = client.firmware()
                self.battery = float(client.battery())
        except XgoShowError as exc:
            self.problems.append(str(exc))

    def safe_stop(self) -> str:
        """Send the model's stop sequence now (between shows); return what went wrong, or ''."""
        try:
            for frame in stop_frames(self.profile):
                self.transport.write(frame.data)
        except (XgoShowError, OSError) as exc:
            return str(exc)
        return ""

    def describe(self, state: str) -> dict[str, Any]:
        """The robot's row in the relay's description."""
        return {
            "name": self.name,
            "model": self.model,
            "port": self.url,
            "firmware": self.firmware,
            "battery": self.battery,
            "voltage": self.voltage,
            "state": state,
            "problems": list(self.problems),
        }


def parse_pairs(items: Sequence[str], option: str, example: str) -> dict[str, str]:
    """``NAME=VALUE`` options -> {name: value}; each name once."""
    out: dict[str, str] = {}
    for item in items:
        name, eq, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not eq or not name or not value:
            raise UsageError(f"{option} {item!r}: write NAME=VALUE, e.g. {example}")
        if name in out:
            raise UsageError(f"{option} {item!r}: {name} is given twice")
        out[name] = value
    return out


def open_robots(
    ports: Mapping[str, str], models: Mapping[str, str], *, timeout: float = 0.5
) -> dict[str, OwnedRobot]:
    """Open every port and identify its robot; close them all again if one fails."""
    unknown = sorted(set(models) - set(ports))
    if unknown:
        raise UsageError(f"--model for {', '.join(unknown)}, which no --map names")
    robots: dict[str, OwnedRobot] = {}
    try:
        for name, url in ports.items():
            try:
                client = open_client(url, models.get(name), timeout=timeout)
            except XgoShowError as exc:
                raise SetupError(f"{name} ({url}): {exc}") from exc
            robot = OwnedRobot(name, url, client.model, client.transport)
            robots[name] = robot
            robot.refresh(timeout)
    except BaseException:
        close_robots(robots)
        raise
    return robots


def close_robots(robots: Mapping[str, OwnedRobot]) -> None:
    """Close every port."""
    for robot in robots.values():
        robot.transport.close()
