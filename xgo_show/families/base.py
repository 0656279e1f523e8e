"""What a robot family provides: one object per byte protocol, asked instead of branching.

A *family* is every robot that speaks one protocol (the XGO Mini, Lite and Rider speak the XGO
register protocol; the xArm its own packet protocol). Each profile names its family
(:attr:`Profile.family <xgo_show.profiles.model.Profile.family>`), and every layer that used to
test ``profile.family == "xarm"`` asks the family object instead
(:func:`~xgo_show.families.get_family`). The family wires the existing layers together: its hooks
delegate to the wire codec, the client, the simulator and the compiler's planner of its
protocol, imported when first used (so ``xgo-show probe`` never loads the compiler).

The small value types some hooks return (:class:`~xgo_show.families.values.StopFrame`,
:class:`~xgo_show.families.values.TelemetryItem`) are in :mod:`xgo_show.families.values`.
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from xgo_show.profiles.model import Link, Profile

if TYPE_CHECKING:
    from xgo_show.choreo.resolved import ResolvedTrack
    from xgo_show.client.base import ClientBase
    from xgo_show.compiler.frames import PlannedFrame, TrackPlan, Write
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.compiler.timeline import PerformerTimeline
    from xgo_show.families.values import StopFrame, TelemetryItem
    from xgo_show.runtime.preflight import PreflightRow
    from xgo_show.sim.base import SimulatedRobot
    from xgo_show.transports.base import Transport
    from xgo_show.wire.stream import StreamDecoder

__all__ = ["Remerge", "RobotFamily"]

#: ``remerge(t_us, writes)``: frames for register writes that pacing holds back (they are merged
#: again into fewer frames), as :func:`~xgo_show.compiler.pacing.pace` takes it.
Remerge = Callable[[int, "list[Write]"], "list[PlannedFrame]"]


class RobotFamily(abc.ABC):
    """The robots of one protocol: every hook the layers above ask about a robot.

    Register an instance with :func:`~xgo_show.families.register_family` (or add it to the
    registry's built-in table); profiles whose ``family`` is :attr:`name` then use it.
    """

    #: the name profiles give in ``Profile.family`` ("xgo", "xarm")
    name: str = ""
    #: the protocol's name and the robots that speak it, for messages
    protocol: str = ""
    robots: str = ""

    # -- wire ---------------------------------------------------------------------------

    @abc.abstractmethod
    def decoder(self) -> StreamDecoder[Any]:
        """A fresh streaming decoder of this protocol (``feed`` bytes, get frames; never raises)."""

    @abc.abstractmethod
    def frame_problem(self, data: bytes) -> str | None:
        """Why ``data`` is not one valid frame a host may send (None: it is), for schedule files."""

    # -- choreography and compiler ------------------------------------------------------

    @abc.abstractmethod
    def refuse_cue(self, kind: str, profile: Profile) -> str | None:
        """Why a cue of ``kind`` ("gripper", "pose", ...) makes no sense for ``profile``.

        None: the cue is fine.

        Asked by the resolver for the cue kinds that belong to one family only.
        """

    @abc.abstractmethod
    def accessory_registers(self, profile: Profile) -> frozenset[str]:
        """Registers that need an accessory fitted (a performer's ``arm: true``) to be written."""

    @abc.abstractmethod
    def after_action(self, profile: Profile, action_id: int) -> dict[str, float]:
        """Register values (physical units) a preset action leaves the robot in (later moves
        start from them); empty when the action changes no register the show tracks."""

    @abc.abstractmethod
    def plan_track(
        self, profile: Profile, track: ResolvedTrack, *, rate: float, link: Link, gap: float,
        details: bool,
    ) -> tuple[TrackPlan, Remerge | None]:
        """Plan one performer's frames (unpaced) and how pacing may merge held-back writes
        (None: frames are never merged again)."""

    @abc.abstractmethod
    def frame_labels(self, profile: Profile) -> Callable[[bytes], str]:
        """``frame bytes -> label`` (``name=value`` pairs), the compiled frames' lazy labels."""

    @abc.abstractmethod
    def describe_frame(self, profile: Profile, data: bytes) -> list[tuple[str, object]]:
        """A scheduled frame's bytes as (name, physical value) pairs; ProtocolError if not one."""

    @abc.abstractmethod
    def state_at(
        self, profile: Profile, frames: Sequence[ScheduledFrame], t: float
    ) -> dict[str, bytes]:
        """The state (name -> bytes) the robot holds at show time ``t`` after ``frames``."""

    @abc.abstractmethod
    def frames_to_reach(
        self, profile: Profile, state: Mapping[str, bytes], *, move_time: float
    ) -> list[ScheduledFrame]:
        """The fewest frames that bring a robot at its initial state to ``state`` (t = 0)."""

    @abc.abstractmethod
    def timeline(
        self, profile: Profile, performer: PerformerSchedule, end: float
    ) -> PerformerTimeline:
        """One performer's schedule read back as curves and events for the plot and the HTML
        timeline (``--plot``, ``--timeline``); ``end`` is the show's end in seconds."""

    # -- robots: clients and simulators -------------------------------------------------

    @abc.abstractmethod
    def client(
        self, transport: Transport, profile: Profile, *, timeout: float
    ) -> ClientBase[Any]:
        """A request/reply client for the robot on ``transport`` (already open)."""

    @abc.abstractmethod
    def simulator_class(self) -> Callable[..., SimulatedRobot]:
        """The simulator class; it is called ``cls(profile, **options)`` (keyword-only options,
        which :func:`~xgo_show.sim.create_robot` checks against its signature)."""

    @abc.abstractmethod
    def simulate_options(self, *, seed: int, battery: float | None) -> dict[str, Any]:
        """Simulator options for ``xgo-show simulate --seed/--battery`` (XgoShowError: refused)."""

    # -- runtime ------------------------------------------------------------------------

    @abc.abstractmethod
    def rest_frames(self, profile: Profile) -> list[StopFrame]:
        """Frames that bring the robot to rest without changing its posture (pause, show end)."""

    @abc.abstractmethod
    def stop_frames(self, profile: Profile) -> list[StopFrame]:
        """The full safe stop (a fault, an abort)."""

    @abc.abstractmethod
    def unsafe_problems(self, profile: Profile, data: bytes) -> list[str]:
        """What is unsafe in one scheduled frame (empty: nothing); a frame that cannot be checked
        is unsafe."""

    @abc.abstractmethod
    def telemetry_items(self, profile: Profile) -> tuple[TelemetryItem, ...]:
        """The read requests polled during a show, in rotation (empty: no polling)."""

    @abc.abstractmethod
    def telemetry_values(
        self, items: Mapping[int, TelemetryItem], frame: Any
    ) -> list[tuple[str, float]] | None:
        """The (name, value) readings in one decoded frame answering one of ``items`` (by
        address), or None for a frame nobody asked for."""

    @abc.abstractmethod
    def telemetry_fault(self, profile: Profile, name: str, value: float) -> str | None:
        """The fault one reading shows by itself (a robot reporting it has fallen); None: none."""

    @abc.abstractmethod
    def battery_low(self, name: str, value: float, floor: float) -> tuple[bool, str] | None:
        """Judge a battery reading against the show's floor (percent): (below it?, the fault's
        text); None when ``name`` is not this family's battery reading."""

    @abc.abstractmethod
    def preflight(
        self, row: PreflightRow, transport: Transport, profile: Profile, floor: float,
        timeout: float,
    ) -> None:
        """Check the robot on ``transport`` (reads only) and fill ``row``: firmware, model
        detected, battery, problems. ``floor`` is the show's battery floor in percent."""

    @abc.abstractmethod
    def probe(self, client: Any, *, given: str | None) -> list[tuple[str, str]]:
        """What ``xgo-show probe`` prints about the robot ``client`` (from :meth:`client`) talks
        to: (label, value) rows. ``given``: the model the user named (None: found from the URL
        or the robot)."""

    @abc.abstractmethod
    def battery_floor_note(self, floor: float) -> str | None:
        """How this family reads a battery floor of ``floor`` percent, where it is not plain
        percent (the pre-flight table's footer); None otherwise."""
