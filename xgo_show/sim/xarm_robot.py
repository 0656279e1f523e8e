"""A simulated LewanSoul/Hiwonder xArm that speaks the board's serial packet protocol.

Packets are decoded with :class:`~xgo_show.wire.xarm.XarmDecoder` and typed with
:func:`~xgo_show.wire.xarm.parse_request`; replies are built with the codec's builders. Time comes
only from the ``now`` arguments.

Behaviour, and the choices made where the document is silent:

- **ServoMove** moves each listed servo linearly from where it is (at ``now``) to its target
  over the packet's time; time 0 (and **ServoPositionWrite**, which has no time) jumps at once.
  A move powers a servo that was switched off.
- **ServoPositionRead** answers with each servo's interpolated position at ``now``, rounded to
  a whole position.
- **ServoOff** makes servos limp: they stop where they are at ``now`` and stay there (nothing
  pushes them in a simulation), marked off.
- **GroupStop** stops every servo where it is at ``now`` (interpolated) and holds it, and ends
  a running action group.
- **Action groups** are motion sequences stored on the real board by the vendor's software. The
  simulator has no content for them: GroupRun/GroupRunRepeat mark a group as running (until
  GroupStop, or GroupErase of that group) without moving servos, GroupErase marks groups as
  erased, GroupSpeed stores the speed; all are recorded in :meth:`XarmRobot.snapshot`.
- **Offsets** (ServoOffsetRead/Write) are stored per servo, -128..127, starting at 0; they do
  not shift simulated positions.
- **Battery**: GetBatteryVoltage answers millivolts, starting at ``battery_mv`` (7600 by default,
  two charged 2S cells under light load) and draining ``drain_mv_per_minute``.
- Packets for servos the arm does not have, values out of range, replies sent by the host and
  the bus-servo commands 26..28 (which reprogram every attached servo) are rejected: recorded
  with the reason, nothing changes, no reply. Bytes that never form a packet are counted in
  :attr:`XarmRobot.discarded_bytes`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from xgo_show.errors import ProfileError, ProtocolError, ValueRangeError
from xgo_show.profiles.model import Profile
from xgo_show.sim.base import FrameRobot, Rejected
from xgo_show.wire.xarm import (
    ALL_GROUPS,
    POSITION_MAX,
    GetBatteryVoltage,
    GroupErase,
    GroupRun,
    GroupRunRepeat,
    GroupSpeed,
    GroupStop,
    ServoMove,
    ServoOff,
    ServoOffsetRead,
    ServoOffsetWrite,
    ServoPositionRead,
    ServoPositionWrite,
    XarmDecoder,
    XarmPacket,
    XarmRequest,
    battery_reply,
    offsets_reply,
    parse_request,
    positions_reply,
)

__all__ = ["DEFAULT_BATTERY_MV", "DEFAULT_DRAIN_MV_PER_MINUTE", "HOME_POSITION", "XarmRobot"]

DEFAULT_BATTERY_MV = 7600
DEFAULT_DRAIN_MV_PER_MINUTE = 2.0
HOME_POSITION = 500  # 0 degrees; also the vendor package's default Servo position


@dataclass
class _Servo:
    """One servo's motion: linear from ``start`` at ``t0`` to ``target`` over ``duration``."""

    start: float
    target: float
    t0: float = 0.0
    duration: float = 0.0
    on: bool = True
    offset: int = 0

    def position(self, now: float) -> float:
        if self.duration <= 0 or now >= self.t0 + self.duration:
            return self.target
        if now <= self.t0:
            return self.start
        return self.start + (self.target - self.start) * (now - self.t0) / self.duration

    def moving(self, now: float) -> bool:
        return self.duration > 0 and now < self.t0 + self.duration and self.start != self.target

    def move(self, target: int, duration: float, now: float) -> None:
        self.start = self.position(now)
        self.target = float(target)
        self.t0 = now
        self.duration = duration
        self.on = True

    def hold(self, now: float) -> None:
        here = self.position(now)
        self.start = self.target = here
        self.t0 = now
        self.duration = 0.0


class XarmRobot(FrameRobot[XarmPacket]):
    """A simulated xArm (see the module docstring for its behaviour).

    ``profile`` must be the xArm profile (family "xarm"). Options (keyword-only):
    ``battery_mv`` start voltage, ``drain_mv_per_minute``, ``positions`` (servo id -> start
    position 0..1000; default 500 for every servo).
    """

    def __init__(
        self,
        profile: Profile,
        *,
        battery_mv: float = DEFAULT_BATTERY_MV,
        drain_mv_per_minute: float = DEFAULT_DRAIN_MV_PER_MINUTE,
        positions: Mapping[int, int] | None = None,
    ) -> None:
        if profile.family != "xarm":
            raise ProfileError(f"XarmRobot simulates the xArm, not {profile.model!r}")
        if not 0 <= battery_mv <= 0xFFFF or drain_mv_per_minute < 0:
            raise ValueRangeError(
                f"battery_mv = {battery_mv:g} must be 0..65535 and the drain >= 0 mV/min"
            )
        start = dict(positions or {})
        for servo, pos in start.items():
            if servo not in profile.xarm_servos:
                raise ProfileError(
                    f"{profile.model} has no servo {servo}; valid: "
                    f"{', '.join(map(str, profile.xarm_servos))}"
                )
            if not 0 <= pos <= POSITION_MAX:
                raise ValueRangeError(f"servo {servo} position {pos} must be 0..{POSITION_MAX}")
        self.profile = profile
        self.model = profile.model
        self._battery = float(battery_mv)
        self._drain = drain_mv_per_minute / 60.0
        self._servos = {
            sid: _Servo(float(start.get(sid, HOME_POSITION)), float(start.get(sid, HOME_POSITION)))
            for sid in profile.xarm_servos
        }
        super().__init__(XarmDecoder())
        self._moves: list[dict[str, Any]] = []
        self._group_running: dict[str, Any] | None = None
        self._group_runs: list[dict[str, Any]] = []
        self._group_speeds: dict[int, int] = {}
        self._erased: list[dict[str, Any]] = []
        self._stops: list[float] = []

    # ------------------------------------------------------------------ SimulatedRobot
    def snapshot(self) -> dict[str, Any]:
        """State as JSON-able data.

        Keys: ``model``, ``time`` (last ``now`` seen, or None), ``servos`` (id as a string ->
        ``position`` float at ``time``, ``target``, ``moving``, ``on``, ``offset``), ``moves``
        (every ServoMove/ServoPositionWrite: ``t``, ``duration``, ``targets`` id -> position),
        ``stops`` (GroupStop times), ``group`` (the running group: ``group``, ``count``,
        ``start``; or None), ``group_runs``, ``group_speeds``, ``groups_erased``,
        ``frames_received``, ``frames_rejected``, ``discarded_bytes``, ``battery_mv``.
        """
        now = self._t if self._t is not None else 0.0
        return {
            "model": self.model,
            "time": self._t,
            "servos": {
                str(sid): {
                    "position": servo.position(now),
                    "target": servo.target,
                    "moving": servo.moving(now),
                    "on": servo.on,
                    "offset": servo.offset,
                }
                for sid, servo in self._servos.items()
            },
            "moves": [dict(m) for m in self._moves],
            "stops": list(self._stops),
            "group": dict(self._group_running) if self._group_running else None,
            "group_runs": [dict(r) for r in self._group_runs],
            "group_speeds": {str(g): p for g, p in self._group_speeds.items()},
            "groups_erased": [dict(e) for e in self._erased],
            "frames_received": len(self._received),
            "frames_rejected": sum(1 for f in self._received if not f.accepted),
            "discarded_bytes": self.discarded_bytes,
            "battery_mv": self.battery_mv,
        }

    # ------------------------------------------------------------------ inspection
    def position(self, servo: int, now: float | None = None) -> float:
        """Servo ``servo``'s position at ``now`` (default: the last time seen)."""
        when = now if now is not None else (self._t if self._t is not None else 0.0)
        return self._servo(servo).position(when)

    def is_on(self, servo: int) -> bool:
        """False after ServoOff until the next move of that servo."""
        return self._servo(servo).on

    def offset(self, servo: int) -> int:
        return self._servo(servo).offset

    @property
    def battery_mv(self) -> int:
        """Battery voltage in whole millivolts."""
        return round(self._battery)

    @property
    def running_group(self) -> int | None:
        """The action group marked running, or None."""
        return None if self._group_running is None else int(self._group_running["group"])

    def _servo(self, servo: int) -> _Servo:
        try:
            return self._servos[servo]
        except KeyError:
            valid = ", ".join(map(str, self._servos))
            raise ProfileError(f"{self.model} has no servo {servo}; valid: {valid}") from None

    # ------------------------------------------------------------------ packets
    def _handle(self, packet: XarmPacket, now: float) -> None:
        if packet.is_reply:
            raise Rejected(f"{packet.command.label} reply sent to the arm")
        try:
            request = parse_request(packet)
        except ProtocolError as exc:
            raise Rejected(str(exc)) from exc
        self._apply(request, now)

    def _apply(self, req: XarmRequest, now: float) -> None:
        if isinstance(req, (ServoMove, ServoPositionWrite)):
            duration = req.time_ms / 1000 if isinstance(req, ServoMove) else 0.0
            self._known(req.positions)
            for sid, pos in req.positions.items():
                self._servos[sid].move(pos, duration, now)
            targets = {str(sid): pos for sid, pos in req.positions.items()}
            self._moves.append({"t": now, "duration": duration, "targets": targets})
        elif isinstance(req, ServoPositionRead):
            self._known(req.ids)
            reply = {sid: round(self._servos[sid].position(now)) for sid in req.ids}
            self._outbox += positions_reply(reply)
        elif isinstance(req, ServoOff):
            self._known(req.ids)
            for sid in req.ids:
                self._servos[sid].hold(now)
                self._servos[sid].on = False
        elif isinstance(req, GetBatteryVoltage):
            self._outbox += battery_reply(self.battery_mv)
        elif isinstance(req, ServoOffsetRead):
            self._known(req.ids)
            self._outbox += offsets_reply({sid: self._servos[sid].offset for sid in req.ids})
        elif isinstance(req, ServoOffsetWrite):
            self._known((req.servo_id,))
            self._servos[req.servo_id].offset = req.offset
        elif isinstance(req, GroupStop):
            for servo in self._servos.values():
                servo.hold(now)
            self._stops.append(now)
            self._end_group(now, "stop")
        else:
            self._apply_group(req, now)

    def _apply_group(self, req: XarmRequest, now: float) -> None:
        if isinstance(req, (GroupRun, GroupRunRepeat)):
            self._end_group(now, "replaced")
            count = req.count if isinstance(req, GroupRun) else req.times
            run = {"group": req.group, "count": count, "start": now, "end": None, "ended_by": ""}
            self._group_runs.append(run)
            self._group_running = run
        elif isinstance(req, GroupErase):
            self._erased.append({"t": now, "group": req.group})
            if self._group_running is not None and req.group in (
                ALL_GROUPS,
                self._group_running["group"],
            ):
                self._end_group(now, "erase")
        elif isinstance(req, GroupSpeed):
            self._group_speeds[req.group] = req.percent

    def _end_group(self, now: float, cause: str) -> None:
        if self._group_running is not None:
            self._group_running["end"] = now
            self._group_running["ended_by"] = cause
            self._group_running = None

    def _known(self, ids: Mapping[int, int] | tuple[int, ...]) -> None:
        for sid in ids:
            if sid not in self._servos:
                valid = ", ".join(map(str, self._servos))
                raise Rejected(f"{self.model} has no servo {sid}; valid: {valid}")

    # ------------------------------------------------------------------ time
    def _elapse(self, now: float, dt: float) -> None:
        self._battery = max(0.0, self._battery - self._drain * dt)
