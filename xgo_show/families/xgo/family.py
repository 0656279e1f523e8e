"""The XGO family object: each hook hands over to the XGO layer that does the work.

Layers are imported inside the hooks, as the code before the families did, so that asking the
family for a client (``probe``) loads neither the compiler nor the simulator.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from xgo_show.families.base import Remerge, RobotFamily
from xgo_show.families.values import StopFrame, TelemetryItem
from xgo_show.families.xgo import posture, stop, telemetry
from xgo_show.profiles.model import Link, Profile
from xgo_show.wire.xgo import XgoDecoder, decode_one

if TYPE_CHECKING:
    from xgo_show.choreo.resolved import ResolvedTrack
    from xgo_show.client.xgo import XgoClient
    from xgo_show.compiler.frames import PlannedFrame, TrackPlan, Write
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.compiler.timeline import PerformerTimeline
    from xgo_show.runtime.preflight import PreflightRow
    from xgo_show.sim.xgo_robot import XgoRobot
    from xgo_show.transports.base import Transport

__all__ = ["ACCESSORY_REGISTERS", "XGO", "XgoFamily"]

#: Registers of the dogs' arm accessory: a performer writes them only with ``arm: true``.
ACCESSORY_REGISTERS = frozenset({"gripper", "arm_x", "arm_z", "arm_mode", "servo_52", "servo_53"})

# Cue kinds that move servos by position, which an XGO robot does not take.
_POSE_KINDS = frozenset({"pose", "pose_deg"})


class XgoFamily(RobotFamily):
    """XGO-Mini, XGO-Lite and XGO-Rider: registers read and written over the XGO protocol."""

    name = "xgo"
    protocol = "XGO"
    robots = "XGO robots"

    def decoder(self) -> XgoDecoder:
        return XgoDecoder()

    def frame_problem(self, data: bytes) -> str | None:
        used, frame = decode_one(data)
        if frame is None or used != len(data):
            return "not one valid XGO frame (bad length or checksum)"
        return None

    def refuse_cue(self, kind: str, profile: Profile) -> str | None:
        if kind in _POSE_KINDS:
            return (f"{kind} is for the xArm; the {profile.title} moves with move: (registers) "
                    "or arm: / gripper:")
        return None

    def accessory_registers(self, profile: Profile) -> frozenset[str]:
        return ACCESSORY_REGISTERS

    def after_action(self, profile: Profile, action_id: int) -> dict[str, float]:
        return posture.posture_after(profile, action_id)

    def plan_track(
        self, profile: Profile, track: ResolvedTrack, *, rate: float, link: Link, gap: float,
        details: bool,
    ) -> tuple[TrackPlan, Remerge | None]:
        from xgo_show.compiler.layout import ACTION_REGISTER
        from xgo_show.compiler.merge import merge_writes
        from xgo_show.compiler.planner import plan_xgo_track
        from xgo_show.compiler.state import layout_of

        layout = layout_of(profile)
        plan = plan_xgo_track(layout, track, rate=rate, link=link, gap=gap, details=details)
        action = layout.by_name.get(ACTION_REGISTER)
        action_address = action.address if action is not None else None

        def remerge(t_us: int, writes: list[Write]) -> list[PlannedFrame]:
            return merge_writes(layout, link, gap, t_us, writes, {},
                                action_address=action_address)

        return plan, remerge

    def frame_labels(self, profile: Profile) -> Callable[[bytes], str]:
        from xgo_show.compiler.state import FrameLabels

        return FrameLabels(profile)

    def describe_frame(self, profile: Profile, data: bytes) -> list[tuple[str, object]]:
        from xgo_show.compiler.state import describe_xgo_frame

        return describe_xgo_frame(profile, data)

    def state_at(
        self, profile: Profile, frames: Sequence[ScheduledFrame], t: float
    ) -> dict[str, bytes]:
        from xgo_show.compiler.state import xgo_state_at

        return xgo_state_at(profile, frames, t)

    def frames_to_reach(
        self, profile: Profile, state: Mapping[str, bytes], *, move_time: float
    ) -> list[ScheduledFrame]:
        from xgo_show.compiler.state import xgo_frames_to_reach

        return xgo_frames_to_reach(profile, state)

    def timeline(
        self, profile: Profile, performer: PerformerSchedule, end: float
    ) -> PerformerTimeline:
        from xgo_show.compiler.timeline import xgo_timeline

        return xgo_timeline(profile, performer, end)

    def client(self, transport: Transport, profile: Profile, *, timeout: float) -> XgoClient:
        from xgo_show.client.xgo import XgoClient

        return XgoClient(transport, profile, timeout=timeout)

    def simulator_class(self) -> type[XgoRobot]:
        from xgo_show.sim.xgo_robot import XgoRobot

        return XgoRobot

    def simulate_options(self, *, seed: int, battery: float | None) -> dict[str, Any]:
        options: dict[str, Any] = {"seed": seed}
        if battery is not None:
            options["battery"] = battery
        return options

    def rest_frames(self, profile: Profile) -> list[StopFrame]:
        return stop.rest_frames(profile)

    def stop_frames(self, profile: Profile) -> list[StopFrame]:
        return stop.stop_frames(profile)

    def unsafe_problems(self, profile: Profile, data: bytes) -> list[str]:
        return stop.unsafe_problems(profile, data)

    def telemetry_items(self, profile: Profile) -> tuple[TelemetryItem, ...]:
        return telemetry.telemetry_items(profile)

    def telemetry_values(
        self, items: Mapping[int, TelemetryItem], frame: Any
    ) -> list[tuple[str, float]] | None:
        return telemetry.telemetry_values(items, frame)

    def telemetry_fault(self, profile: Profile, name: str, value: float) -> str | None:
        return telemetry.telemetry_fault(profile, name, value)

    def battery_low(self, name: str, value: float, floor: float) -> tuple[bool, str] | None:
        return telemetry.battery_low(name, value, floor)

    def preflight(
        self, row: PreflightRow, transport: Transport, profile: Profile, floor: float,
        timeout: float,
    ) -> None:
        from xgo_show.families.xgo.preflight import check_robot

        check_robot(row, transport, profile, floor, timeout)

    def probe(self, client: Any, *, given: str | None) -> list[tuple[str, str]]:
        from xgo_show.families.xgo.preflight import probe_rows

        return probe_rows(client, given=given)

    def battery_floor_note(self, floor: float) -> str | None:
        return None


#: The one XGO family object (registered as ``"xgo"``).
XGO = XgoFamily()
