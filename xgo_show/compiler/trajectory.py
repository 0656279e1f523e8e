"""Jerk-limited multi-register trajectories with ruckig (offline, state to state).

Each MotionCue becomes one multi-DoF ruckig trajectory from the registers' current state to the
targets at rest. ruckig's default time synchronisation makes every DoF arrive together. A cue's
duration is honoured with ``InputParameter.minimum_duration``; when the limits make the move
longer than that, the cue is infeasible and :class:`InfeasibleMotion` says by how much.
:func:`min_duration` is the same computation without a duration: the shortest move, which the
resolver gives a motion cue written without one (the one place ruckig is called).

Never set ``InputParameter.intermediate_positions``: in ruckig's community build that sends the
request to a remote cloud service. The compiler must stay a pure, offline function (a test
checks that this module never touches it).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ruckig import InputParameter, Result, Ruckig, RuckigError, Trajectory

from xgo_show.errors import InfeasibleMotion, TrajectoryError
from xgo_show.profiles.model import LIMIT_RANGE, Limits

__all__ = [
    "DofState",
    "InfeasibleMotion",
    "MotionPlan",
    "TrajectoryError",
    "min_duration",
    "plan_motion",
]

# Durations within this many seconds of the requested one count as meeting it (ruckig's own
# numerical tolerance is far below a control tick).
DURATION_TOLERANCE = 1e-6
_NO_TRAJECTORY = ("the trajectory planner found no move for these limits and values (a limit "
                  "far smaller or larger than the robot's own?)")


@dataclass(frozen=True)
class DofState:
    """Position, velocity and acceleration of one register (physical units)."""

    position: float
    velocity: float = 0.0
    acceleration: float = 0.0


@dataclass(frozen=True, eq=False)
class MotionPlan:
    """A computed trajectory for registers ``names`` starting at ``start`` (show seconds)."""

    names: tuple[str, ...]
    start: float
    duration: float
    trajectory: Trajectory
    targets: list[float]  # exact target positions (ruckig's end state is within float noise)

    @property
    def end(self) -> float:
        return self.start + self.duration

    def state_at(self, t: float) -> list[DofState]:
        """Every DoF's state at show time ``t`` (clamped to the trajectory)."""
        rel = min(max(t - self.start, 0.0), self.duration)
        pos, vel, acc = self.trajectory.at_time(rel)
        return [DofState(p, v, a) for p, v, a in zip(pos, vel, acc, strict=True)]

    def positions_at(self, t: float) -> list[float]:
        """Every DoF's position at show time ``t`` (clamped to the trajectory)."""
        rel = min(max(t - self.start, 0.0), self.duration)
        pos: list[float] = self.trajectory.at_time(rel)[0]
        return pos

    def extrema(self) -> list[tuple[float, float]]:
        """(minimum, maximum) position each DoF reaches (overshoot when starting in motion)."""
        return [(e.min, e.max) for e in self.trajectory.position_extrema]


def plan_motion(
    names: Sequence[str],
    start: float,
    current: Sequence[DofState],
    targets: Sequence[float],
    limits: Sequence[Limits],
    duration: float | None = None,
) -> MotionPlan:
    """One synchronised trajectory from ``current`` to ``targets`` at rest.

    Raises :class:`InfeasibleMotion` when ``duration`` is too short for ``limits`` and
    :class:`TrajectoryError` when ruckig rejects the input.
    """
    dofs = len(names)
    low, high = LIMIT_RANGE
    for name, lim in zip(names, limits, strict=True):
        for kind, value in (("velocity", lim.velocity), ("acceleration", lim.acceleration),
                            ("jerk", lim.jerk)):
            if not low <= value <= high:  # NaN included
                raise TrajectoryError(f"{name}: {kind} limit {value:g} is outside what the "
                                      f"planner handles ({low:g} to {high:g})")
    inp = InputParameter(dofs)
    inp.current_position = [s.position for s in current]
    inp.current_velocity = [s.velocity for s in current]
    inp.current_acceleration = [s.acceleration for s in current]
    inp.target_position = list(targets)
    inp.target_velocity = [0.0] * dofs
    inp.target_acceleration = [0.0] * dofs
    inp.max_velocity = [lim.velocity for lim in limits]
    inp.max_acceleration = [lim.acceleration for lim in limits]
    inp.max_jerk = [lim.jerk for lim in limits]
    if duration is not None:
        inp.minimum_duration = duration
    traj = Trajectory(dofs)
    try:
        result = Ruckig(dofs).calculate(inp, traj)
    except RuckigError as exc:  # its message is a multi-line dump of the input: not for users
        raise TrajectoryError(_NO_TRAJECTORY) from exc
    except ValueError as exc:
        # A result code the binding's Result lacks (ruckig 0.19: -101, the trajectory's
        # duration past its numerical limits, e.g. starting far above a lower limit).
        raise TrajectoryError(f"{_NO_TRAJECTORY} ({exc})") from exc
    if result not in (Result.Working, Result.Finished):
        raise TrajectoryError(f"{_NO_TRAJECTORY} ({result.name})")
    if duration is not None and traj.duration > duration + DURATION_TOLERANCE:
        alone = list(traj.independent_min_durations)
        worst = max(range(dofs), key=lambda i: (alone[i], -i))
        raise InfeasibleMotion(traj.duration, worst, duration)
    return MotionPlan(tuple(names), start, float(traj.duration), traj, list(targets))


def min_duration(
    start: Mapping[str, float], targets: Mapping[str, float], limits: Mapping[str, Limits]
) -> float:
    """Shortest rest-to-rest time of a synchronised jerk-limited move, seconds.

    Only registers with a start, a target and limits count; 0.0 when none does or when ruckig
    finds no trajectory (the compiler then reports the cue with its reason).
    """
    names = [n for n in targets if n in limits and n in start]
    if not names:
        return 0.0
    try:
        plan = plan_motion(names, 0.0, [DofState(start[n]) for n in names],
                           [targets[n] for n in names], [limits[n] for n in names])
    except TrajectoryError:
        return 0.0
    return plan.duration
