"""Request/response client for the LewanSoul/Hiwonder xArm over any transport.

The arm answers only three requests; this client uses the two a show needs before and while
it runs: the battery voltage and the servo positions. Packets are matched by command (the
protocol has no checksum or sequence number), everything else on the line is skipped.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable

from xgo_show.client.base import DEFAULT_TIMEOUT, ClientBase
from xgo_show.errors import ProfileError, ProtocolError
from xgo_show.profiles import Profile, get_profile
from xgo_show.transports.base import Transport
from xgo_show.wire import xarm
from xgo_show.wire.xarm import XarmCommand, XarmDecoder, XarmPacket

__all__ = ["XarmClient"]


class XarmClient(ClientBase[XarmPacket]):
    """Read the xArm's battery voltage and servo positions through ``transport`` (open).

    ``profile`` defaults to the "xarm" profile (servo ids, 9600-baud link). As a context
    manager the client closes the transport at the end. Not thread-safe, like
    :class:`~xgo_show.client.XgoClient`.
    """

    family = "xarm"
    protocol = "xArm"
    robots = "the xArm"

    def __init__(
        self,
        transport: Transport,
        profile: Profile | None = None,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        super().__init__(transport, get_profile("xarm") if profile is None else profile,
                         XarmDecoder(), timeout=timeout, clock=clock, sleep=sleep)

    def battery_mv(self) -> int:
        """Battery voltage in millivolts (GetBatteryVoltage)."""
        reply = self._request(
            xarm.get_battery_voltage(), XarmCommand.GET_BATTERY_VOLTAGE, "a GetBatteryVoltage"
        )
        return xarm.battery_mv(reply)

    def positions(self, ids: Iterable[int] | None = None) -> dict[int, int]:
        """Servo id -> position (0..1000 = -125..+125 degrees) for ``ids`` (default: all).

        Raises :class:`ProtocolError` if the reply does not list exactly the servos asked for.
        """
        wanted = tuple(self.profile.xarm_servos if ids is None else ids)
        if not wanted:
            raise ProfileError("name at least one servo to read")
        unknown = sorted(set(wanted) - set(self.profile.xarm_servos))
        if unknown:
            valid = ", ".join(map(str, self.profile.xarm_servos))
            raise ProfileError(f"the xArm has no servo {unknown[0]}; valid: {valid}")
        label = f"a ServoPositionRead of servos {', '.join(map(str, wanted))}"
        reply = self._request(
            xarm.servo_position_read(wanted), XarmCommand.SERVO_POSITION_READ, label
        )
        found = xarm.positions(reply)
        if sorted(found) != sorted(wanted):
            listed = ", ".join(map(str, found)) or "none"
            raise ProtocolError(f"reply from {self.transport.url} to {label} lists servos {listed}")
        return {servo: found[servo] for servo in wanted}

    def __repr__(self) -> str:
        return f"<XarmClient on {self.transport.url}>"

    def _request(self, frame: bytes, command: XarmCommand, label: str) -> XarmPacket:
        def match(packet: XarmPacket) -> bool | str:
            return packet.command is command and packet.is_reply

        return self._exchange.request(frame, match, label=label)
