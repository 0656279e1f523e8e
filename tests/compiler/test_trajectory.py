"""Trajectories: exact arrival, limits, synchronisation, infeasibility, chaining, offline only."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

import xgo_show.compiler.trajectory as trajectory_module
from xgo_show.choreo.resolved import MotionCue
from xgo_show.compiler import compile_show, state_at
from xgo_show.compiler.trajectory import DofState, InfeasibleMotion, min_duration, plan_motion
from xgo_show.errors import CompileError
from xgo_show.profiles import Limits, get_profile

LIM = Limits(velocity=60.0, acceleration=300.0, jerk=2000.0)
SLOW = Limits(velocity=10.0, acceleration=50.0, jerk=500.0)


def _sample(plan, step=0.001):  # type: ignore[no-untyped-def]
    n = int(plan.duration / step)
    return [plan.state_at(plan.start + i * step) for i in range(n + 1)]


def test_reaches_targets_exactly_and_respects_limits() -> None:
    plan = plan_motion(
        ["body_z", "pitch"], 1.0, [DofState(97.0), DofState(0.0)], [110.0, -12.5], [LIM, SLOW]
    )
    assert plan.positions_at(plan.end) == pytest.approx([110.0, -12.5], abs=1e-9)
    for states in _sample(plan):
        for s, lim in zip(states, (LIM, SLOW), strict=True):
            assert abs(s.velocity) <= lim.velocity * (1 + 1e-6)
            assert abs(s.acceleration) <= lim.acceleration * (1 + 1e-6)
    # at rest at the end
    end = plan.state_at(plan.end)
    assert all(abs(s.velocity) < 1e-9 and abs(s.acceleration) < 1e-9 for s in end)


def test_all_dofs_arrive_together() -> None:
    # pitch alone would need far less time than body_z; synchronised, it is still moving
    # until just before the common end.
    plan = plan_motion(
        ["body_z", "pitch"], 0.0, [DofState(80.0), DofState(0.0)], [120.0, 1.0], [LIM, LIM]
    )
    alone = list(plan.trajectory.independent_min_durations)
    assert alone[1] < alone[0] * 0.6
    near_end = plan.state_at(plan.end - 0.05)
    assert all(abs(s.velocity) > 1e-6 for s in near_end)
    assert plan.positions_at(plan.end - 0.05) != pytest.approx([120.0, 1.0])


def test_duration_is_honoured_when_feasible() -> None:
    plan = plan_motion(["roll"], 0.0, [DofState(0.0)], [5.0], [LIM], duration=2.0)
    assert plan.duration == pytest.approx(2.0)


def test_too_short_duration_is_infeasible_with_the_minimum() -> None:
    natural = plan_motion(["body_z"], 0.0, [DofState(75.0)], [120.0], [LIM]).duration
    with pytest.raises(InfeasibleMotion) as err:
        plan_motion(["body_z"], 0.0, [DofState(75.0)], [120.0], [LIM], duration=0.2)
    assert err.value.minimum == pytest.approx(natural)
    assert natural > 0.2


def test_compile_reports_every_infeasible_cue(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({
        "rex": ("mini", [
            MotionCue(0.0, o("drop", 3), {"body_z": 75.0}, duration=0.1),
            MotionCue(5.0, o("tilt", 4), {"roll": 20.0}, duration=0.1),
        ]),
    })
    with pytest.raises(CompileError) as err:
        compile_show(show)
    diags = err.value.diagnostics
    assert len(diags) == 2
    first, second = diags
    assert first.origin == o("drop", 3) and second.origin == o("tilt", 4)
    assert re.search(r"the move to body_z 75 needs at least \d\.\d\d s under its limits "
                     r"\(body_z: velocity 60 mm/s", first.message)
    assert "given 0.10 s" in first.message
    assert "the move to roll 20 " in second.message


def test_cue_limits_override_profile_limits(make_show, o) -> None:  # type: ignore[no-untyped-def]
    fast = make_show({"rex": ("mini", [MotionCue(0.0, o("m"), {"body_z": 110.0})])})
    slow = make_show({"rex": ("mini", [
        MotionCue(0.0, o("m"), {"body_z": 110.0}, limits={"body_z": SLOW})
    ])})
    assert compile_show(slow).performers[0].end > compile_show(fast).performers[0].end * 2


def test_back_to_back_chain_starts_from_previous_target(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.0, o("a"), {"body_z": 110.0}, duration=1.0),
        MotionCue(1.0, o("b"), {"body_z": 80.0}, duration=1.0),
    ])})
    perf = compile_show(show).performers[0]
    body_z = get_profile("mini").register("body_z")
    assert state_at(perf, 1.0)["body_z"] == bytes((body_z.to_byte(110.0),))
    assert state_at(perf, 2.0)["body_z"] == bytes((body_z.to_byte(80.0),))
    # continuity: consecutive samples never jump more than a velocity-limited step
    values = [body_z.to_physical(f.data[5]) for f in perf.frames]
    steps = [abs(b - a) for a, b in itertools.pairwise(values)]
    assert max(steps) <= LIM.velocity / 50 + 0.3  # one tick at max speed + one byte of rounding


def test_interrupting_chain_carries_velocity(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.0, o("up"), {"body_z": 118.0}, duration=2.0),
        MotionCue(0.8, o("down"), {"body_z": 90.0}, interrupts=True),
    ])})
    perf = compile_show(show).performers[0]
    reg = get_profile("mini").register("body_z")
    values = [(f.t, reg.to_physical(f.data[5])) for f in perf.frames]
    steps = [abs(b[1] - a[1]) for a, b in itertools.pairwise(values)]
    assert max(steps) <= LIM.velocity / 50 + 0.3  # no jump at the hand-over
    # still rising for a moment after 0.8 s (velocity carried over), then heading to 90
    after = [v for t, v in values if 0.8 <= t <= 0.9]
    before = [v for t, v in values if t < 0.8]
    assert max(after) >= before[-1]
    assert values[-1][1] == pytest.approx(90.0, abs=0.2)


def test_compiler_never_sets_intermediate_positions_in_source() -> None:
    # ruckig's community build sends requests with intermediate positions to a cloud service.
    package = Path(trajectory_module.__file__).parent
    code = re.compile(r"^[^#]*\bintermediate_positions\s*=", re.M)
    for path in package.glob("*.py"):
        text = path.read_text(encoding="utf-8")
        assert not code.search(text), path
        assert "setattr" not in text or "intermediate" not in text, path


def test_compiler_never_sets_intermediate_positions_at_run_time(
    monkeypatch: pytest.MonkeyPatch, make_show, o  # type: ignore[no-untyped-def]
) -> None:
    made = []
    real = trajectory_module.InputParameter

    def recording(dofs: int):  # type: ignore[no-untyped-def]
        inp = real(dofs)
        made.append(inp)
        return inp

    monkeypatch.setattr(trajectory_module, "InputParameter", recording)
    compile_show(make_show({"rex": ("mini", [
        MotionCue(0.0, o("a"), {"body_z": 110.0, "roll": 5.0}),
        MotionCue(2.0, o("b"), {"body_z": 90.0}, duration=1.5),
    ])}))
    assert len(made) == 2
    assert all(list(inp.intermediate_positions) == [] for inp in made)


def test_min_duration_is_the_shortest_feasible_move() -> None:
    # The resolver's duration for a move written without one: the plan with no duration, and
    # a move given exactly that long is feasible while a shorter one is not.
    start, targets = {"body_z": 97.0, "pitch": 0.0}, {"body_z": 110.0, "pitch": -12.5}
    limits = {"body_z": LIM, "pitch": SLOW}
    shortest = min_duration(start, targets, limits)
    current = [DofState(start["body_z"]), DofState(start["pitch"])]
    goals = [targets["body_z"], targets["pitch"]]
    assert shortest == plan_motion(["body_z", "pitch"], 0.0, current, goals, [LIM, SLOW]).duration
    plan_motion(["body_z", "pitch"], 0.0, current, goals, [LIM, SLOW], shortest)
    with pytest.raises(InfeasibleMotion):
        plan_motion(["body_z", "pitch"], 0.0, current, goals, [LIM, SLOW], shortest * 0.9)
    # Registers without a start or limits do not count; none left: no time at all.
    assert min_duration(start, {**targets, "yaw": 5.0}, limits) == shortest
    assert min_duration(start, {"yaw": 5.0}, limits) == 0.0
    assert min_duration(start, targets, {"body_z": Limits(-1.0, 1.0, 1.0)}) == 0.0
