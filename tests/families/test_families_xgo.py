"""The XGO family's own rules: the reset action and the posture it restores (one home)."""

from __future__ import annotations

import pytest

from xgo_show.families.xgo.posture import RESET_ACTION, posture_after
from xgo_show.profiles import get_profile
from xgo_show.sim import create_robot
from xgo_show.wire.xgo import write_frame


@pytest.mark.parametrize("model", ["mini", "lite", "rider"])
def test_reset_restores_every_default_posture_register(model: str) -> None:
    # The resolver, the planner and the simulator all read this one rule; it must cover every
    # register the profile lists (a posture register without an initial value would be skipped).
    profile = get_profile(model)
    after = posture_after(profile, RESET_ACTION)
    assert list(after) == list(profile.default_posture)
    assert posture_after(profile, 1) == {}
    assert any(a.id == RESET_ACTION and a.name == "reset" for a in profile.actions)
    # The simulator, told to reset after a posture change, holds those values.
    robot = create_robot(model)
    action = profile.register("action")
    for name in profile.default_posture:
        reg = profile.register(name)
        assert reg.minimum is not None and reg.maximum is not None
        robot.receive(write_frame(reg.address, reg.encode_value(reg.minimum),
                                  write_type=profile.write_type), 0.0)
    robot.receive(write_frame(action.address, bytes((RESET_ACTION,)),
                              write_type=profile.write_type), 0.1)
    registers = robot.snapshot()["registers"]
    for name, value in after.items():
        assert registers[name] == pytest.approx(value, abs=1.0), name
