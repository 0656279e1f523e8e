"""A trajectory ruckig cannot compute is a TrajectoryError with a clear message, whatever the
binding returns (a result code its Result does not name included)."""

from __future__ import annotations

import pytest

from xgo_show.compiler.trajectory import DofState, TrajectoryError, plan_motion
from xgo_show.profiles.model import Limits


def test_a_result_code_the_binding_does_not_name_is_a_trajectory_error() -> None:
    # A move interrupted at an acceleration far above the next move's limits: ruckig 0.19
    # returns -101 (duration past its numerical limits), which its Python Result lacks.
    current = [DofState(-35.93659684502354, 0.0, 1753.2700944313178),
               DofState(6.069396759103739, 89.72845228038909, 1314.9767788013637)]
    limits = [Limits(23.490725528087253, 194.46844262510507, 212.17467592339466),
              Limits(114.45343526699565, 694.8733996276284, 807.7275432288063)]
    try:
        plan = plan_motion(["body_z", "roll"], 0.0, current, [-48.8364650990619,
                                                              -25.84692251609313], limits)
    except TrajectoryError as exc:
        assert "the trajectory planner found no move" in str(exc)
    else:  # a ruckig that computes it: then it is a move like any other
        assert plan.duration > 0


def test_a_value_error_from_the_binding_becomes_a_trajectory_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import xgo_show.compiler.trajectory as trajectory

    class Refusing:
        def __init__(self, dofs: int) -> None:
            pass

        def calculate(self, inp: object, traj: object) -> object:
            raise ValueError("-101 is not a valid Result.")

    monkeypatch.setattr(trajectory, "Ruckig", Refusing)
    with pytest.raises(TrajectoryError, match=r"found no move .*-101 is not a valid Result"):
        plan_motion(["roll"], 0.0, [DofState(0.0)], [5.0], [Limits(40.0, 200.0, 1500.0)])
