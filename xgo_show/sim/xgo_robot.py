"""A simulated XGO robot (Mini, Lite, Rider) that speaks the real serial protocol.

The robot is a register memory laid out by its :class:`~xgo_show.profiles.model.Profile`, driven
by frames decoded with :class:`~xgo_show.wire.xgo.XgoDecoder` and an injected clock (the ``now``
arguments of :meth:`XgoRobot.receive` and :meth:`XgoRobot.poll`; nothing here reads a clock).

Behaviour, and the choices made where the documents are silent:

- **Reads** (type 0x02, one count byte) of any run of whole fields in the table are answered with
  a reply frame (type 0x12) carrying the fields' bytes; registers the documents mark "write"
  are answered too (the memory table is one memory). A read that starts outside the table, runs
  off it or cuts a field gets no reply and is recorded as rejected.
- **Writes** (type 0x00 as the document says, and 0x01 as the Rider vendor library sends) set
  consecutive fields (:meth:`Profile.walk`). A write is applied whole or not at all: one
  read-only field, an unknown address, a cut field or an enumeration value outside the
  documented choices rejects the frame (recorded with the reason) and changes nothing.
- **Frames that fail to decode** (bad checksum, tail, length) are discarded by the decoder and
  change nothing; their bytes are counted in :attr:`XgoRobot.discarded_bytes`.
- **Actions** (register ``action``): a documented action id starts a timed action that runs for
  the catalogue duration; the register reads the id while it runs and 0 afterwards. Actions the
  documents give no duration for (the Rider's) run for ``default_action_duration`` seconds
  (3 s by default, like the shortest Mini/Lite actions). A write to any motion register (speeds,
  posture, legs, servos, periodic motion, gait, arm…) interrupts the running action, as the
  document says ("The action execution process can be interrupted by other commands"); so does
  a new action. Id 255 restores the profile's default-posture registers to their initial values
  and applies the profile's safe stop (the vendor's ``reset()``: "the robot dog stops moving and
  all parameters return to the initial state"). Ids not in the catalogue are rejected.
- **Battery** drains linearly at ``drain_per_minute`` percent per minute from ``battery``; the
  register holds the level rounded up to a whole percent.
- **IMU**: roll/pitch follow the commanded attitude (posture registers converted to degrees by
  the profile) with a first-order lag of ``attitude_time_constant`` seconds; yaw integrates
  ``vyaw`` (degrees per second, positive = turning left) plus the commanded body yaw. Seeded
  Gaussian noise of ``imu_noise`` degrees is added. The angles are written as float32 LE
  (``imu_roll``..``imu_yaw``), int16 BE whole degrees (``*_i16``) and the 24-byte ``imu_block``
  packed with the profile's layout (:attr:`Profile.imu`: Mini/Lite raw int16 accelerometer and
  gyro then float32 angles, as the vendor ``unpack_imu`` decodes; Rider six float32, acceleration
  in m/s^2 then angular rate in deg/s). The accelerometer reads gravity tilted by roll and pitch;
  the gyro reads the attitude's rate of change and ``vyaw``.
- **Rider only**: ``status`` reads 1 (normal) or 0 (fallen; see :meth:`XgoRobot.fall`);
  ``set_origin`` = 1 zeroes the heading and odometer and clears itself; ``auto_feedback`` != 0
  makes :meth:`XgoRobot.poll` emit feedback at 50 Hz. The document lists the content (power,
  joint angles, 6-axis IMU, odometer) but not the packet layout, so each feedback tick is sent as
  ordinary reply frames (type 0x12) for the documented blocks the table has: ``battery`` (0x01),
  ``status`` (0x02), ``imu_roll``..``imu_yaw`` (0x62, 12 bytes) and ``imu_block`` (0x65, 24
  bytes). Joint angles and odometer have no address in the table and are not sent. When
  :meth:`poll` is called late, missed ticks are sent at once, at most one second's worth.
"""

from __future__ import annotations

import math
import random
import struct
from dataclasses import dataclass
from typing import Any

from xgo_show.errors import ProfileError, ProtocolError, ValueRangeError
from xgo_show.families.xgo.posture import RESET_ACTION
from xgo_show.profiles.model import Encoding, Profile, Register
from xgo_show.sim.base import FrameRobot, Rejected
from xgo_show.wire.xgo import XgoDecoder, XgoFrame, reply_frame

__all__ = [
    "DEFAULT_ACTION_DURATION",
    "DEFAULT_DRAIN_PER_MINUTE",
    "FEEDBACK_RATE",
    "MOTION_GROUPS",
    "XgoRobot",
]

# Seconds an action runs when the documents give no duration (all Rider actions).
DEFAULT_ACTION_DURATION = 3.0
# Percent per minute: a full battery lasts a little over five hours of simulated time.
DEFAULT_DRAIN_PER_MINUTE = 0.3
FEEDBACK_RATE = 50.0  # Hz, Rider automatic data feedback (document: "a frequency of 50Hz")
# Register groups whose writes command motion and therefore interrupt a running action.
MOTION_GROUPS = frozenset({"speed", "posture", "periodic", "leg", "servo", "arm", "gripper"})

_G = 9.80665
_MAX_CATCH_UP = 1.0  # seconds of missed feedback ticks sent at most
_FALLEN_ROLL = 80.0  # degrees the IMU reads after fall(): lying on its side


@dataclass
class _ActionRun:
    id: int
    name: str
    start: float
    duration: float
    interrupted_at: float | None = None
    interrupted_by: str = ""

    @property
    def end(self) -> float:
        return self.start + self.duration

    def as_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "name": self.name,
            "start": self.start,
            "duration": self.duration,
            "end": self.end if self.interrupted_at is None else self.interrupted_at,
            "interrupted_at": self.interrupted_at,
            "interrupted_by": self.interrupted_by,
        }


class XgoRobot(FrameRobot[XgoFrame]):
    """A simulated XGO Mini, Lite or Rider (see the module docstring for its behaviour).

    ``profile`` must be an XGO-family profile. Options (keyword-only): ``battery`` start level
    in percent, ``drain_per_minute`` percent, ``seed`` for the IMU noise, ``firmware`` string
    (default per model, e.g. ``"M-1.4.1"``), ``imu_noise`` degrees (standard deviation),
    ``attitude_time_constant`` seconds, ``default_action_duration`` seconds.
    """

    def __init__(
        self,
        profile: Profile,
        *,
        battery: float = 100.0,
        drain_per_minute: float = DEFAULT_DRAIN_PER_MINUTE,
        seed: int = 0,
        firmware: str | None = None,
        imu_noise: float = 0.05,
        attitude_time_constant: float = 0.15,
        default_action_duration: float = DEFAULT_ACTION_DURATION,
    ) -> None:
        if profile.family != "xgo":
            raise ProfileError(f"XgoRobot simulates XGO robots, not {profile.model!r}")
        if not 0.0 <= battery <= 100.0:
            raise ValueRangeError(f"battery = {battery:g} % is out of range [0, 100] %")
        if drain_per_minute < 0 or imu_noise < 0 or attitude_time_constant < 0:
            raise ValueRangeError("drain_per_minute, imu_noise and attitude_time_constant >= 0")
        if default_action_duration <= 0:
            raise ValueRangeError("default_action_duration must be > 0 s")
        self.profile = profile
        self.model = profile.model
        self.firmware = firmware if firmware is not None else profile.firmware_default
        self._drain = drain_per_minute / 60.0
        self._battery = float(battery)
        self._rng = random.Random(seed)
        self._noise = imu_noise
        self._tau = attitude_time_constant
        self._default_duration = default_action_duration

        super().__init__(XgoDecoder())
        self._memory: dict[int, bytes] = {}
        self._by_name: dict[str, Register] = {reg.name: reg for reg in profile.registers}
        for reg in profile.registers:
            self._memory[reg.address] = self._initial(reg)

        self._actions: list[_ActionRun] = []
        self._running: _ActionRun | None = None
        self._fallen = False
        self._heading = 0.0  # degrees, integrated vyaw
        self._odometer = 0.0  # integrated vx, in the vx register's unit times seconds
        self._roll = 0.0  # filtered attitude, degrees
        self._pitch = 0.0
        self._rates = (0.0, 0.0, 0.0)  # deg/s about x, y, z
        self._feedback_start: float | None = None  # Rider auto feedback: time of tick 0
        self._feedback_k = 0  # index of the next feedback tick
        self._feedback_ticks = 0
        self._feedback_dropped = 0
        self._write_battery()
        self._write_status()
        self._write_imu(0.0, 0.0, 0.0)

    # ------------------------------------------------------------------ SimulatedRobot
    def snapshot(self) -> dict[str, Any]:
        """State as JSON-able data.

        Keys: ``model``, ``firmware``, ``time`` (last ``now`` seen, or None), ``registers``
        (name -> physical value: float for linear registers, choice name for enumerations,
        float/int for IMU angles, [r, g, b], str, hex string for blocks), ``raw`` (name -> hex
        of the register bytes), ``actions`` (every action started: id, name, start, duration,
        end, interrupted_at, interrupted_by), ``action`` (the running one or None),
        ``frames_received``, ``frames_rejected``, ``discarded_bytes``, ``battery`` (percent,
        float), ``heading`` (degrees), ``odometer``, ``fallen``, ``feedback_ticks``,
        ``feedback_dropped``.
        """
        running = self._running.as_dict() if self._running is not None else None
        return {
            "model": self.model,
            "firmware": self.firmware,
            "time": self._t,
            "registers": {reg.name: self.value(reg.name) for reg in self.profile.registers},
            "raw": {reg.name: self._memory[reg.address].hex() for reg in self.profile.registers},
            "actions": [run.as_dict() for run in self._actions],
            "action": running,
            "frames_received": len(self._received),
            "frames_rejected": sum(1 for f in self._received if not f.accepted),
            "discarded_bytes": self.discarded_bytes,
            "battery": self._battery,
            "heading": self._heading,
            "odometer": self._odometer,
            "fallen": self._fallen,
            "feedback_ticks": self._feedback_ticks,
            "feedback_dropped": self._feedback_dropped,
        }

    # ------------------------------------------------------------------ inspection
    def raw(self, name: str) -> bytes:
        """The bytes register ``name`` holds (unknown names raise :class:`ProfileError`)."""
        return self._memory[self.profile.register(name).address]

    def value(self, name: str) -> Any:
        """Register ``name`` as a JSON-able value: :meth:`Register.decode_value`, with RGB as
        a list and blocks as hex."""
        reg = self.profile.register(name)
        value = reg.decode_value(self._memory[reg.address])
        if isinstance(value, tuple):
            return list(value)
        if isinstance(value, bytes):
            return value.hex()
        return value

    @property
    def battery(self) -> float:
        """Battery level in percent (not rounded)."""
        return self._battery

    @property
    def running_action(self) -> int | None:
        """Id of the action running at the last time seen, or None."""
        return self._running.id if self._running is not None else None

    @property
    def actions(self) -> list[dict[str, Any]]:
        """Every action started so far (as in :meth:`snapshot`)."""
        return [run.as_dict() for run in self._actions]

    # ------------------------------------------------------------------ fault injection
    def fall(self) -> None:
        """Make the robot fall over: the IMU reads it lying on its side (through its attitude
        filter), and a fall-detecting ``status`` register (the Rider's) reads "fallen" at once.
        """
        self._fallen = True
        self._write_status()

    def recover(self) -> None:
        """Stand a fallen robot up again (``status`` reads 1)."""
        self._fallen = False
        self._write_status()

    def set_battery(self, percent: float) -> None:
        """Set the battery level (percent), e.g. to provoke a low-battery fault."""
        if not 0.0 <= percent <= 100.0:
            raise ValueRangeError(f"battery = {percent:g} % is out of range [0, 100] %")
        self._battery = float(percent)
        self._write_battery()

    # ------------------------------------------------------------------ frames
    def _handle(self, frame: XgoFrame, now: float) -> None:
        if frame.is_read:
            self._handle_read(frame)
        elif frame.is_write:
            self._handle_write(frame, now)
        else:
            raise Rejected(f"frame type 0x{frame.type:02X} is not a read or write request")

    def _handle_read(self, frame: XgoFrame) -> None:
        if len(frame.data) != 1:
            raise Rejected(f"read frame carries {len(frame.data)} data bytes; expected 1 count")
        count = frame.data[0]
        if count == 0:
            raise Rejected("read of 0 bytes")
        fields = self._walk(frame.address, count)
        data = b"".join(self._memory[reg.address] for reg in fields)
        try:
            self._outbox += reply_frame(frame.address, data)
        except ProtocolError as exc:
            raise Rejected(str(exc)) from exc

    def _handle_write(self, frame: XgoFrame, now: float) -> None:
        if not frame.data:
            raise Rejected("write frame carries no data")
        fields = self._walk(frame.address, len(frame.data))
        chunks: list[tuple[Register, bytes]] = []
        offset = 0
        for reg in fields:
            chunk = frame.data[offset : offset + reg.size]
            offset += reg.size
            if not reg.access.writable:
                raise Rejected(f"{reg.name} (0x{reg.address:02X}) is read-only")
            if reg.encoding is Encoding.ENUM and chunk[0] not in reg.choices.values():
                raise Rejected(
                    f"{reg.name} (0x{reg.address:02X}): 0x{chunk[0]:02X} is not one of "
                    f"{dict(reg.choices)}"
                )
            if reg.name == "action":
                self._check_action(chunk[0])
            chunks.append((reg, chunk))
        for reg, chunk in chunks:
            self._memory[reg.address] = bytes(chunk)
        motion = [reg.name for reg, _ in chunks if reg.group in MOTION_GROUPS]
        if motion and self._running is not None:
            self._interrupt(now, f"write {motion[0]}")
        for reg, chunk in chunks:
            self._after_write(reg, chunk[0], now)

    def _walk(self, address: int, nbytes: int) -> list[Register]:
        try:
            return self.profile.walk(address, nbytes)
        except ProfileError as exc:
            raise Rejected(str(exc)) from exc

    def _check_action(self, action_id: int) -> None:
        if action_id in (0, RESET_ACTION):
            return
        try:
            self.profile.action(action_id)
        except ProfileError as exc:
            raise Rejected(str(exc)) from exc

    def _after_write(self, reg: Register, first: int, now: float) -> None:
        if reg.name == "action":
            self._start_action(first, now)
        elif reg.name == "set_origin" and first != 0:
            self._heading = 0.0
            self._odometer = 0.0
            self._memory[reg.address] = bytes(reg.size)  # the document: a one-shot command
            self._write_imu(self._roll, self._pitch, self._physical("yaw"))
        elif reg.name == "auto_feedback":
            if first == 0:
                self._feedback_start = None
            elif self._feedback_start is None:
                self._feedback_start, self._feedback_k = now, 0

    # ------------------------------------------------------------------ actions
    def _start_action(self, action_id: int, now: float) -> None:
        if self._running is not None:
            self._interrupt(now, f"action {action_id}")
        if action_id == 0:
            return
        if action_id == RESET_ACTION:
            # "Restore default posture"; the vendor's reset() adds that the robot stops moving
            # and its parameters return to their initial state: posture back, safe stop applied.
            for name in self.profile.default_posture:
                reg = self.profile.register(name)
                self._memory[reg.address] = self._initial(reg)
            for name, value in self.profile.safe_stop:
                reg = self.profile.register(name)
                self._memory[reg.address] = reg.encode_value(value)
        try:
            act = self.profile.action(action_id)
            name, duration = act.name, act.duration
        except ProfileError:
            name, duration = "restore_posture", None  # 255 when the catalogue omits it
        run = _ActionRun(action_id, name, now, duration or self._default_duration)
        self._actions.append(run)
        self._running = run
        self._set("action", bytes((action_id,)))

    def _interrupt(self, now: float, cause: str) -> None:
        assert self._running is not None
        self._running.interrupted_at = now
        self._running.interrupted_by = cause
        self._finish_action()

    def _finish_action(self) -> None:
        self._running = None
        action = self._by_name.get("action")
        if action is not None:
            self._memory[action.address] = bytes(action.size)

    # ------------------------------------------------------------------ time
    def _elapse(self, now: float, dt: float) -> None:
        if self._running is not None and now >= self._running.end:
            self._finish_action()
        self._battery = max(0.0, self._battery - self._drain * dt)
        self._write_battery()
        vyaw = self._physical("vyaw")
        vx = self._physical("vx")
        self._heading = _wrap(self._heading + vyaw * dt)
        self._odometer += vx * dt
        target_roll, target_pitch = self._attitude_target()
        alpha = 1.0 if self._tau == 0 else 1.0 - math.exp(-dt / self._tau)
        roll = self._roll + (target_roll - self._roll) * alpha
        pitch = self._pitch + (target_pitch - self._pitch) * alpha
        # Instantaneous rates of the first-order response at ``now`` (the gyro's reading).
        if self._tau == 0:
            self._rates = (0.0, 0.0, vyaw)
        else:
            self._rates = (
                (target_roll - roll) / self._tau,
                (target_pitch - pitch) / self._tau,
                vyaw,
            )
        self._roll, self._pitch = roll, pitch
        self._write_imu(self._roll, self._pitch, _wrap(self._heading + self._physical("yaw")))

    def _attitude_target(self) -> tuple[float, float]:
        if self._fallen:
            return _FALLEN_ROLL, 0.0
        return self._physical("roll"), self._physical("pitch")

    def _physical(self, name: str) -> float:
        """A linear register's physical value, 0 if the model has no such register."""
        reg = self._by_name.get(name)
        if reg is None or not reg.linear:
            return 0.0
        return reg.to_physical(self._memory[reg.address][0])

    # ------------------------------------------------------------------ derived registers
    def _initial(self, reg: Register) -> bytes:
        if reg.name == "firmware":
            return reg.encode_value(self.firmware)
        if reg.initial is not None:
            return bytes(reg.initial)
        return bytes(reg.size)

    def _set(self, name: str, data: bytes) -> None:
        reg = self._by_name.get(name)
        if reg is not None:
            self._memory[reg.address] = data

    def _write_battery(self) -> None:
        self._set("battery", bytes((min(100, math.ceil(self._battery - 1e-9)),)))

    def _status_register(self) -> Register | None:
        reg = self._by_name.get("status")
        # Only a status register with a "fallen" code (the Rider's) reports falls.
        return reg if reg is not None and "fallen" in reg.choices else None

    def _write_status(self) -> None:
        reg = self._status_register()
        if reg is not None:
            code = reg.choices["fallen"] if self._fallen else reg.choices.get("normal", 1)
            self._memory[reg.address] = bytes((code,))

    def _write_imu(self, roll: float, pitch: float, yaw: float) -> None:
        roll += self._gauss()
        pitch += self._gauss()
        yaw = _wrap(yaw + self._gauss())
        for name, angle in (("imu_roll", roll), ("imu_pitch", pitch), ("imu_yaw", yaw)):
            self._set(name, struct.pack("<f", angle))
            self._set(f"{name}_i16", struct.pack(">h", _clamp16(round(angle))))
        layout = self.profile.imu
        if layout is None:
            return
        r, p = math.radians(roll), math.radians(pitch)
        values = {
            "acc_x": -_G * math.sin(p),
            "acc_y": _G * math.sin(r) * math.cos(p),
            "acc_z": _G * math.cos(r) * math.cos(p),
            "gyro_x": self._rates[0] + self._gauss(),
            "gyro_y": self._rates[1] + self._gauss(),
            "gyro_z": self._rates[2] + self._gauss(),
            "roll": roll,
            "pitch": pitch,
            "yaw": yaw,
        }
        # The layout (Profile.imu) names the fields this model's block carries.
        self._set("imu_block", layout.pack({k: v for k, v in values.items() if k in layout.names}))

    def _gauss(self) -> float:
        return self._rng.gauss(0.0, self._noise) if self._noise else 0.0

    # ------------------------------------------------------------------ feedback
    def _emit(self, now: float) -> None:
        """Queue the Rider's automatic feedback frames due by ``now`` (when switched on)."""
        start = self._feedback_start
        if start is None:
            return
        period = 1.0 / FEEDBACK_RATE
        # Tick k is due at start + k * period (no accumulated rounding).
        first_kept = math.ceil((now - _MAX_CATCH_UP - start) / period - 1e-6)
        if first_kept > self._feedback_k:
            self._feedback_dropped += first_kept - self._feedback_k
            self._feedback_k = first_kept
        while start + self._feedback_k * period <= now + 1e-9:
            self._outbox += self._feedback_frames()
            self._feedback_ticks += 1
            self._feedback_k += 1

    def _feedback_frames(self) -> bytes:
        out = bytearray()
        for first, last in (
            ("battery", "battery"),
            ("status", "status"),
            ("imu_roll", "imu_yaw"),
            ("imu_block", "imu_block"),
        ):
            start, end = self._by_name.get(first), self._by_name.get(last)
            if start is None or end is None:
                continue
            data = b"".join(
                self._memory[a] for a in range(start.address, end.address + 1) if a in self._memory
            )
            out += reply_frame(start.address, data)
        return bytes(out)


def _wrap(angle: float) -> float:
    """Angle in degrees wrapped to [-180, 180)."""
    return (angle + 180.0) % 360.0 - 180.0


def _clamp16(value: int) -> int:
    return max(-32768, min(32767, value))
