"""The README's demo (examples/drive_sim.py) runs and drives the simulated robot."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "drive_sim.py"


def load_example() -> ModuleType:
    spec = importlib.util.spec_from_file_location("drive_sim", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("model", ["mini", "rider"])
def test_drive_sim_prints_the_frames_the_robot_received(
    model: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert load_example().main(model, pace=0.05) == 0
    out = capsys.readouterr().out
    assert "the robot received 11 frames:" in out
    assert "read   firmware (10 bytes)" in out
    assert "write  vx = 0 " in out  # the stop is exactly zero
    assert "write  action = 255 reset" in out
    assert "REFUSED" not in out
