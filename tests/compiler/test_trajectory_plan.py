"""plan_motion and MotionPlan on hand-made states, to exact values: a plan that starts late in
the show, each limit kind refused in its own words and accepted at the range's ends, the
duration tolerance at its edge, which register an infeasible move names, and the refusals of
a binding that finds no move."""

from __future__ import annotations

import math

import pytest

import xgo_show.compiler.trajectory as trajectory
from xgo_show.compiler.trajectory import (
    DURATION_TOLERANCE,
    DofState,
    InfeasibleMotion,
    TrajectoryError,
    plan_motion,
)
from xgo_show.profiles.model import LIMIT_RANGE, Limits

LIM = Limits(velocity=60.0, acceleration=300.0, jerk=2000.0)
NO_MOVE = ("the trajectory planner found no move for these limits and values (a limit far "
           "smaller or larger than the robot's own?)")


def test_a_plan_starting_late_is_read_in_show_time() -> None:
    plan = plan_motion(["body_z", "pitch"], 3.0, [DofState(80.0), DofState(0.0, 5.0, 10.0)],
                       [110.0, -10.0], [LIM, LIM])
    assert plan.names == ("body_z", "pitch")
    assert plan.start == 3.0 and plan.end == 3.0 + plan.duration
    assert plan.targets == [110.0, -10.0]
    mid = plan.duration / 3
    pos, vel, acc = plan.trajectory.at_time(mid)
    # Show time 3 + mid is the trajectory's own time mid: position, velocity, acceleration.
    got = plan.state_at(3.0 + mid)
    flat = [x for s in got for x in (s.position, s.velocity, s.acceleration)]
    assert flat == pytest.approx([x for row in zip(pos, vel, acc) for x in row], rel=1e-9)
    assert plan.positions_at(3.0 + mid) == pytest.approx(pos, rel=1e-9)
    assert any(abs(a) > 1.0 for a in acc)  # the acceleration is read back, not left at 0
    # Before its start: where it starts (the current state); after its end: at the targets.
    for t in (0.0, 2.5, 3.0):
        assert plan.state_at(t) == [DofState(80.0, 0.0, 0.0), DofState(0.0, 5.0, 10.0)]
        assert plan.positions_at(t) == [80.0, 0.0]
    assert plan.positions_at(plan.end + 5.0) == pytest.approx([110.0, -10.0], abs=1e-9)
    # Just after the start it has barely moved (not a second into the move).
    assert plan.positions_at(3.0 + 1e-4)[0] == pytest.approx(80.0, abs=1e-6)


@pytest.mark.parametrize("kind", ["velocity", "acceleration", "jerk"])
@pytest.mark.parametrize("value", [0.0, 9e-4, 1.1e7, math.nan])
def test_each_limit_outside_the_range_is_refused_by_name(kind: str, value: float) -> None:
    low, high = LIMIT_RANGE
    limits = {"velocity": 60.0, "acceleration": 300.0, "jerk": 2000.0, kind: value}
    with pytest.raises(TrajectoryError) as err:
        plan_motion(["roll", "yaw"], 0.0, [DofState(0.0), DofState(0.0)], [5.0, 5.0],
                    [LIM, Limits(**limits)])
    assert str(err.value) == (f"yaw: {kind} limit {value:g} is outside what the planner "
                              f"handles ({low:g} to {high:g})")
    assert str(err.value).endswith("(0.001 to 1e+07)")


def test_limits_at_the_ends_of_the_range_are_planned() -> None:
    low, high = LIMIT_RANGE
    for lim in (Limits(low, low, low), Limits(high, high, high)):
        plan = plan_motion(["roll"], 0.0, [DofState(0.0)], [0.001], [lim])
        assert plan.positions_at(plan.end) == pytest.approx([0.001], abs=1e-9)


def test_names_and_limits_pair_one_to_one() -> None:
    # A caller's mismatch is a programming error, never a plan that ignores a limit.
    with pytest.raises(ValueError, match="zip"):
        plan_motion(["roll"], 0.0, [DofState(0.0)], [5.0], [LIM, LIM])
    with pytest.raises(ValueError, match="zip"):
        plan_motion(["roll", "yaw"], 0.0, [DofState(0.0)] * 2, [5.0, 5.0], [LIM])


def test_a_duration_within_the_tolerance_of_the_shortest_is_met() -> None:
    shortest = plan_motion(["body_z"], 0.0, [DofState(75.0)], [120.0], [LIM]).duration
    # The largest requested duration whose tolerance reaches exactly the shortest move.
    asked = shortest - DURATION_TOLERANCE
    while asked + DURATION_TOLERANCE < shortest:
        asked = math.nextafter(asked, math.inf)
    while asked + DURATION_TOLERANCE > shortest:
        asked = math.nextafter(asked, -math.inf)
    assert asked + DURATION_TOLERANCE == shortest
    plan = plan_motion(["body_z"], 0.0, [DofState(75.0)], [120.0], [LIM], duration=asked)
    assert plan.duration == shortest
    shorter = math.nextafter(asked, -math.inf)
    with pytest.raises(InfeasibleMotion) as err:
        plan_motion(["body_z"], 0.0, [DofState(75.0)], [120.0], [LIM], duration=shorter)
    assert err.value.minimum == shortest and err.value.requested == shorter


def test_an_infeasible_move_names_the_register_slowest_alone() -> None:
    slow = Limits(10.0, 50.0, 500.0)
    current = [DofState(0.0), DofState(0.0), DofState(0.0)]
    # The first register is the slowest alone (not the last, not the first by chance).
    for targets, limits, worst in (
        ([30.0, 1.0, 1.0], [slow, LIM, LIM], 0),
        ([1.0, 30.0, 1.0], [LIM, slow, LIM], 1),
        ([1.0, 1.0, 30.0], [LIM, LIM, slow], 2),
        ([30.0, 30.0, 1.0], [slow, slow, LIM], 0),  # a tie: the first of them
        ([1.0, 30.0, 30.0], [LIM, slow, slow], 1),
    ):
        with pytest.raises(InfeasibleMotion) as err:
            plan_motion(["a", "b", "c"], 0.0, current, targets, limits, duration=0.5)
        assert err.value.dof == worst, targets
        assert err.value.requested == 0.5
        assert str(err.value) == f"needs at least {err.value.minimum:.2f} s, given 0.50 s"


def test_a_move_ruckig_refuses_is_one_plain_sentence() -> None:
    # ruckig's own message dumps its whole input: the user gets one sentence instead.
    with pytest.raises(TrajectoryError) as err:
        plan_motion(["roll"], 0.0, [DofState(math.nan)], [5.0], [LIM])
    assert str(err.value) == NO_MOVE


def test_an_error_result_from_the_binding_is_named(monkeypatch: pytest.MonkeyPatch) -> None:
    class Failing:
        def __init__(self, dofs: int) -> None:
            pass

        def calculate(self, inp: object, traj: object) -> object:
            return trajectory.Result.ErrorExecutionTimeCalculation

    monkeypatch.setattr(trajectory, "Ruckig", Failing)
    with pytest.raises(TrajectoryError) as err:
        plan_motion(["roll"], 0.0, [DofState(0.0)], [5.0], [LIM])
    assert str(err.value) == f"{NO_MOVE} (ErrorExecutionTimeCalculation)"
