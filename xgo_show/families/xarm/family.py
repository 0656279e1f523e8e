"""The xArm family object: each hook hands over to the xArm layer that does the work.

Layers are imported inside the hooks (the compiler, the client, the simulator), so asking for
the family loads only the xArm codec.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

from xgo_show.errors import UsageError
from xgo_show.families.base import Remerge, RobotFamily
from xgo_show.families.values import StopFrame, TelemetryItem
from xgo_show.families.xarm import runtime
from xgo_show.profiles.model import Link, Profile

if TYPE_CHECKING:
    from xgo_show.choreo.resolved import ResolvedTrack
    from xgo_show.client.xarm import XarmClient
    from xgo_show.compiler.frames import TrackPlan
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.compiler.timeline import PerformerTimeline
    from xgo_show.runtime.preflight import PreflightRow
    from xgo_show.sim.xarm_robot import XarmRobot
    from xgo_show.transports.base import Transport
    from xgo_show.wire.xarm import XarmDecoder

__all__ = ["XARM", "XarmFamily"]


class XarmFamily(RobotFamily):
    """The xArm: servo positions moved by the controller over a given time (ServoMove)."""

    name = "xarm"
    protocol = "xArm"
    robots = "the xArm"

    def decoder(self) -> XarmDecoder:
        from xgo_show.wire.xarm import XarmDecoder

        return XarmDecoder()

    def frame_problem(self, data: bytes) -> str | None:
        from xgo_show.compiler.artifact import xarm_frame_problem

        return xarm_frame_problem(data)

    def refuse_cue(self, kind: str, profile: Profile) -> str | None:
        if kind == "gripper":
            return "on the xArm the gripper is servo 1: use pose: {1: POSITION}"
        return None

    def accessory_registers(self, profile: Profile) -> frozenset[str]:
        return frozenset()

    def after_action(self, profile: Profile, action_id: int) -> dict[str, float]:
        return {}

    def plan_track(
        self, profile: Profile, track: ResolvedTrack, *, rate: float, link: Link, gap: float,
        details: bool,
    ) -> tuple[TrackPlan, Remerge | None]:
        from xgo_show.compiler.xarm import plan_xarm_track

        return plan_xarm_track(profile, track), None

    def frame_labels(self, profile: Profile) -> Callable[[bytes], str]:
        from xgo_show.compiler.state import frame_label

        return partial(frame_label, profile)

    def describe_frame(self, profile: Profile, data: bytes) -> list[tuple[str, object]]:
        from xgo_show.compiler.xarm import describe_xarm_frame

        return describe_xarm_frame(data)

    def state_at(
        self, profile: Profile, frames: Sequence[ScheduledFrame], t: float
    ) -> dict[str, bytes]:
        from xgo_show.compiler.xarm import xarm_state_at

        return xarm_state_at(frames, t)

    def frames_to_reach(
        self, profile: Profile, state: Mapping[str, bytes], *, move_time: float
    ) -> list[ScheduledFrame]:
        from xgo_show.compiler.xarm import xarm_frames_to_reach

        return xarm_frames_to_reach(profile, state, move_time=move_time)

    def timeline(
        self, profile: Profile, performer: PerformerSchedule, end: float
    ) -> PerformerTimeline:
        from xgo_show.compiler.timeline import xarm_timeline

        return xarm_timeline(profile, performer, end)

    def client(self, transport: Transport, profile: Profile, *, timeout: float) -> XarmClient:
        from xgo_show.client.xarm import XarmClient

        return XarmClient(transport, profile, timeout=timeout)

    def simulator_class(self) -> type[XarmRobot]:
        from xgo_show.sim.xarm_robot import XarmRobot

        return XarmRobot

    def simulate_options(self, *, seed: int, battery: float | None) -> dict[str, Any]:
        if battery is not None:
            raise UsageError(
                "--battery is a percentage for XGO robots; the xArm reports millivolts "
                "(its simulator starts at 7600 mV)"
            )
        return {}

    def rest_frames(self, profile: Profile) -> list[StopFrame]:
        return []

    def stop_frames(self, profile: Profile) -> list[StopFrame]:
        return runtime.stop_frames()

    def unsafe_problems(self, profile: Profile, data: bytes) -> list[str]:
        return runtime.unsafe_problems(data)

    def telemetry_items(self, profile: Profile) -> tuple[TelemetryItem, ...]:
        return runtime.telemetry_items()

    def telemetry_values(
        self, items: Mapping[int, TelemetryItem], frame: Any
    ) -> list[tuple[str, float]] | None:
        return runtime.telemetry_values(items, frame)

    def telemetry_fault(self, profile: Profile, name: str, value: float) -> str | None:
        return None

    def battery_low(self, name: str, value: float, floor: float) -> tuple[bool, str] | None:
        return runtime.battery_low(name, value, floor)

    def preflight(
        self, row: PreflightRow, transport: Transport, profile: Profile, floor: float,
        timeout: float,
    ) -> None:
        runtime.check_robot(row, transport, profile, floor, timeout)

    def probe(self, client: Any, *, given: str | None) -> list[tuple[str, str]]:
        return runtime.probe_rows(client, given=given)

    def battery_floor_note(self, floor: float) -> str | None:
        return f"xArm: {runtime.floor_text(floor)}"


#: The one xArm family object (registered as ``"xarm"``).
XARM = XarmFamily()
