"""A robot the package has never heard of, added by this file alone: a pan "turret".

Everything the turret needs is here — its byte protocol, a simulator, a client, a profile and
its family object — and nothing else in the package is edited: it is registered
(``register_profile``, ``register_family``) and then compiled, saved and loaded, checked for
unsafe frames, read back, polled for telemetry, probed, served on ``sim:turret`` and run by
``xgo-show dry-run`` (pre-flight table, the run, the simulators' summary), like the built-in
robots.

What it cannot do without edits elsewhere: be named in a routine file (the choreography
language lists its models), appear in the command line's ``--model`` choices, or be found by
firmware auto-detection (an XGO register read). So the show here is built as resolved cues.

The turret protocol: every frame is ``A5 cmd value check`` with ``check = (cmd + value) ^ 0xFF``.
``01 deg`` pans to 0..180 degrees, ``02 00`` halts, ``03 00`` asks for the battery (reply
``83 percent``), ``7F 00`` is a factory reset (framed, but never allowed in a show).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import pytest

from xgo_show.choreo.resolved import ArmCue, ResolvedShow, ResolvedTrack
from xgo_show.cli.main import main
from xgo_show.cli.probe import probe
from xgo_show.client import open_client
from xgo_show.client.base import ClientBase
from xgo_show.compiler import (
    compile_show,
    describe_frame,
    frames_to_reach,
    load_schedule,
    save_schedule,
    state_at,
)
from xgo_show.compiler.frames import PlannedFrame, TrackPlan, to_us
from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
from xgo_show.compiler.state import frame_label, reach_frame
from xgo_show.compiler.timeline import Curve, Lane, PerformerTimeline
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.errors import XgoShowError
from xgo_show.families import (
    Remerge,
    RobotFamily,
    register_family,
    unregister_family,
)
from xgo_show.families.values import StopFrame, TelemetryItem
from xgo_show.profiles import Link, Profile, get_profile, register_profile, unregister_profile
from xgo_show.runtime.preflight import PreflightRow
from xgo_show.runtime.safety import UnsafeScheduleError, check_unsafe
from xgo_show.runtime.telemetry import TelemetryPoller
from xgo_show.sim import create_robot
from xgo_show.sim.base import FrameRobot, Rejected
from xgo_show.transports.base import Transport
from xgo_show.wire.stream import StreamDecoder

# -- the turret's byte protocol ----------------------------------------------------------

SYNC, PAN, HALT, BATTERY, FACTORY_RESET, REPLY = 0xA5, 0x01, 0x02, 0x03, 0x7F, 0x80


@dataclass(frozen=True)
class TurretFrame:
    cmd: int
    value: int

    @property
    def is_reply(self) -> bool:
        return bool(self.cmd & REPLY)

    def encode(self) -> bytes:
        return bytes((SYNC, self.cmd, self.value, (self.cmd + self.value) & 0xFF ^ 0xFF))


def frame(cmd: int, value: int = 0) -> bytes:
    return TurretFrame(cmd, value).encode()


def decode_one(buf: bytearray) -> tuple[int, TurretFrame | None]:
    if buf[0] != SYNC:
        start = buf.find(SYNC)
        return (len(buf) if start < 0 else start), None
    if len(buf) < 4:
        return 0, None
    if (buf[1] + buf[2]) & 0xFF ^ 0xFF != buf[3]:
        return 1, None
    return 4, TurretFrame(buf[1], buf[2])


def turret_decoder() -> StreamDecoder[TurretFrame]:
    return StreamDecoder(decode_one)


# -- its simulator and client --------------------------------------------------------------


class TurretRobot(FrameRobot[TurretFrame]):
    def __init__(self, profile: Profile, *, battery: float = 90.0) -> None:
        super().__init__(turret_decoder())
        self.model = profile.model
        self.battery = battery
        self.angle = 90
        self.halts = 0

    def _elapse(self, now: float, dt: float) -> None:
        pass

    def _handle(self, f: TurretFrame, now: float) -> None:
        if f.cmd == PAN and f.value <= 180:
            self.angle = f.value
        elif f.cmd == HALT:
            self.halts += 1
        elif f.cmd == BATTERY:
            self._outbox += frame(BATTERY | REPLY, round(self.battery))
        else:
            raise Rejected(f"command 0x{f.cmd:02X} {f.value} refused")

    def snapshot(self) -> dict[str, Any]:
        return {
            "model": self.model, "battery": self.battery, "stops": [0] * self.halts,
            "servos": {"1": {"position": self.angle}},
            "frames_received": len(self.received),
            "frames_rejected": sum(not r.accepted for r in self.received),
            "discarded_bytes": self.discarded_bytes,
        }


class TurretClient(ClientBase[TurretFrame]):
    family = protocol = "turret"
    robots = "turrets"

    def __init__(self, transport: Transport, profile: Profile, *, timeout: float) -> None:
        super().__init__(transport, profile, turret_decoder(), timeout=timeout)

    def battery(self) -> int:
        def match(f: TurretFrame) -> bool:
            return f.cmd == BATTERY | REPLY

        return self._exchange.request(frame(BATTERY), match, label="a battery read").value


# -- its family: the one object the package asks ---------------------------------------------


def _pan_degrees(data: bytes) -> int:
    used, f = decode_one(bytearray(data))
    if f is None or used != len(data) or f.cmd != PAN:
        raise XgoShowError(f"not a turret pan frame: {data.hex(' ')}")
    return f.value


class TurretFamily(RobotFamily):
    name = protocol = "turret"
    robots = "turrets"

    def decoder(self) -> StreamDecoder[TurretFrame]:
        return turret_decoder()

    def frame_problem(self, data: bytes) -> str | None:
        used, f = decode_one(bytearray(data)) if data else (0, None)
        return None if f is not None and used == len(data) else "not one turret frame"

    def refuse_cue(self, kind: str, profile: Profile) -> str | None:
        return None if kind in ("pose", "pose_deg") else f"a turret only pans ({kind})"

    def accessory_registers(self, profile: Profile) -> frozenset[str]:
        return frozenset()

    def after_action(self, profile: Profile, action_id: int) -> dict[str, float]:
        return {}

    def plan_track(
        self, profile: Profile, track: ResolvedTrack, *, rate: float, link: Link, gap: float,
        details: bool,
    ) -> tuple[TrackPlan, Remerge | None]:
        frames, diags = [], []
        for order, cue in enumerate(track.cues):
            if not isinstance(cue, ArmCue) or set(cue.positions) != {1}:
                diags.append(Diagnostic("error", "a turret pans servo 1 only", cue.origin))
                continue
            data = frame(PAN, round(cue.positions[1] * 180 / 1000))
            frames.append(PlannedFrame(to_us(cue.start), data, (), (), cue.origin, order,
                                       False, False, cue.duration))
        end = max((c.start + getattr(c, "duration", 0.0) for c in track.cues), default=0.0)
        return TrackPlan(frames, end, diags, 0), None

    def frame_labels(self, profile: Profile) -> Callable[[bytes], str]:
        return partial(frame_label, profile)

    def describe_frame(self, profile: Profile, data: bytes) -> list[tuple[str, object]]:
        return [("pan", _pan_degrees(data))]

    def state_at(
        self, profile: Profile, frames: Sequence[ScheduledFrame], t: float
    ) -> dict[str, bytes]:
        pans = [f.data for f in frames if f.t <= t]
        return {"pan": bytes((_pan_degrees(pans[-1]),))} if pans else {}

    def frames_to_reach(
        self, profile: Profile, state: Mapping[str, bytes], *, move_time: float
    ) -> list[ScheduledFrame]:
        if "pan" not in state:
            return []
        return [reach_frame(profile, frame(PAN, state["pan"][0]), move_time)]

    def timeline(self, profile: Profile, performer: PerformerSchedule,
                 end: float) -> PerformerTimeline:
        pans = [float(_pan_degrees(f.data)) for f in performer.frames]
        curve = Curve("pan", "deg", (0.0, *(f.t for f in performer.frames), end),
                      (pans[0], *pans, pans[-1]))
        return PerformerTimeline(performer.name, performer.model, profile.title,
                                 (Lane("deg", (curve,)),), (), ())

    def client(self, transport: Transport, profile: Profile, *, timeout: float) -> TurretClient:
        return TurretClient(transport, profile, timeout=timeout)

    def simulator_class(self) -> type[TurretRobot]:
        return TurretRobot

    def simulate_options(self, *, seed: int, battery: float | None) -> dict[str, Any]:
        return {} if battery is None else {"battery": battery}

    def rest_frames(self, profile: Profile) -> list[StopFrame]:
        return []

    def stop_frames(self, profile: Profile) -> list[StopFrame]:
        return [StopFrame(frame(HALT), "halt")]

    def unsafe_problems(self, profile: Profile, data: bytes) -> list[str]:
        problem = self.frame_problem(data)
        if problem is not None:
            return [problem]
        return ["factory reset"] if data[1] == FACTORY_RESET else []

    def telemetry_items(self, profile: Profile) -> tuple[TelemetryItem, ...]:
        return (TelemetryItem("battery", BATTERY, (), frame(BATTERY)),)

    def telemetry_values(
        self, items: Mapping[int, TelemetryItem], f: Any
    ) -> list[tuple[str, float]] | None:
        return [("battery", float(f.value))] if f.cmd == BATTERY | REPLY else None

    def telemetry_fault(self, profile: Profile, name: str, value: float) -> str | None:
        return None

    def battery_low(self, name: str, value: float, floor: float) -> tuple[bool, str] | None:
        return (value < floor, f"turret battery at {value:g}%") if name == "battery" else None

    def preflight(self, row: PreflightRow, transport: Transport, profile: Profile,
                  floor: float, timeout: float) -> None:
        try:
            row.battery = float(TurretClient(transport, profile, timeout=timeout).battery())
        except XgoShowError as exc:
            row.problems.append(str(exc))
            return
        row.firmware, row.detected = "turret", profile.model
        if row.battery < floor:
            row.problems.append(f"battery {row.battery:.0f}% is below {floor:g}%")

    def probe(self, client: Any, *, given: str | None) -> list[tuple[str, str]]:
        return [("model", client.model), ("battery", f"{client.battery()} %")]

    def battery_floor_note(self, floor: float) -> str | None:
        return None


TURRET = Profile(model="turret", family="turret", title="Pan turret", link=Link(115200, 0.002),
                 capabilities=frozenset({"pan"}))


@pytest.fixture
def turret() -> Iterator[Profile]:
    register_profile(TURRET, aliases=["pan-turret"])
    register_family(TurretFamily())
    try:
        yield TURRET
    finally:
        unregister_family("turret")
        unregister_profile("turret")


def _show() -> ResolvedShow:
    o = Origin("turret.yaml", 1, 1)
    cues = tuple(ArmCue(t, o, {1: pos}, 0.5) for t, pos in ((0.0, 0), (0.5, 1000), (1.0, 750)))
    return ResolvedShow("turret show", "turret.yaml", (ResolvedTrack("tur", "turret", cues),),
                        control_rate=50.0)


def test_a_registered_robot_compiles_saves_and_reads_back(turret: Profile, tmp_path: Path) -> None:
    assert get_profile("Pan-Turret") is turret
    schedule = compile_show(_show())
    perf = schedule.performer("tur")
    assert [f.data for f in perf.frames] == [frame(PAN, 0), frame(PAN, 180), frame(PAN, 135)]
    assert [f.label for f in perf.frames] == ["pan=0", "pan=180", "pan=135"]
    path = tmp_path / "turret.json"
    save_schedule(schedule, path)
    assert load_schedule(path).performer("tur").frames == perf.frames
    assert describe_frame(turret, perf.frames[1].data) == [("pan", 180)]
    state = state_at(perf, 0.7)
    assert state == {"pan": bytes((180,))}
    assert [f.data for f in frames_to_reach(turret, state)] == [frame(PAN, 180)]
    # A schedule file with a frame the turret protocol does not frame is refused on loading.
    broken = replace(perf, frames=(ScheduledFrame(0.0, bytes.fromhex("a501")), *perf.frames[1:]))
    save_schedule(replace(schedule, performers=(broken,)), path)
    with pytest.raises(XgoShowError, match="not one turret frame"):
        load_schedule(path)


def test_a_registered_robot_is_checked_stopped_and_polled(turret: Profile) -> None:
    schedule = compile_show(_show())
    assert check_unsafe(schedule, {"tur": turret}) == []
    bad = PerformerSchedule("tur", "turret", turret.link,
                            (ScheduledFrame(0.0, frame(FACTORY_RESET)),), 1.0)
    with pytest.raises(UnsafeScheduleError, match="factory reset"):
        check_unsafe(type(schedule)(**{**vars(schedule), "performers": (bad,)}),
                     {"tur": turret})
    poller = TelemetryPoller(turret, battery_floor=50, low_readings=1)
    item = poller.due(0.0)
    assert item is not None and item.request == frame(BATTERY)
    assert [s.value for s in poller.feed(frame(0x99) + frame(BATTERY | REPLY, 40), 1.0)] == [40]
    assert poller.unsolicited == 1 and poller.fault == "turret battery at 40%"


def test_a_registered_robot_is_simulated_probed_and_run(turret: Profile, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    robot = create_robot("turret", battery=77)
    assert isinstance(robot, TurretRobot) and robot.battery == 77
    with open_client("sim:turret", timeout=1.0) as client:
        assert isinstance(client, TurretClient) and client.battery() == 90
    assert probe("sim:turret", timeout=1.0) == [("model", "turret"), ("battery", "90 %")]
    # The whole launch: pre-flight, the run, the end of the show, the simulators' summary.
    path = tmp_path / "turret.json"
    save_schedule(compile_show(_show()), path)
    assert main(["dry-run", str(path), "--fast"]) == 0
    out = capsys.readouterr().out
    assert "tur" in out and "turret" in out and "90%" in out  # the pre-flight row
    assert "show completed" in out
    assert "4 frames received, 0 rejected" in out  # the pre-flight read and three pans
    assert "servo_1=135" in out  # where the simulated turret ended up
