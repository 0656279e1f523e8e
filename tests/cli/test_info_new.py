"""``xgo-show info MODEL`` and ``xgo-show new``: what a model offers; a starter routine that
validates as it is and never overwrites."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.choreo import validate_file
from xgo_show.cli.main import main
from xgo_show.profiles import MODELS


def test_info_lists_actions_registers_leds_and_servos(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", "mini"]) == 0
    mini = capsys.readouterr().out
    assert "XGO-Mini (model: mini" in mini
    assert any(line.split()[:3] == ["13", "wave", "7"] for line in mini.splitlines())
    assert any(line.split()[:4] == ["pitch", "-22", "..", "22"] for line in mini.splitlines())
    assert main(["info", "rider"]) == 0
    rider = capsys.readouterr().out
    assert "not documented" in rider and "led1, led2, led3, led4" in rider
    assert main(["info", "xarm"]) == 0
    xarm = capsys.readouterr().out
    assert "1   gripper" in xarm and "6   base" in xarm


def test_info_of_an_unknown_model_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", "minni"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("xgo-show: error: ")


@pytest.mark.parametrize("model", MODELS)
def test_new_writes_a_routine_that_validates_cleanly(model: str, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "my_show.yaml"
    assert main(["new", str(path), "--model", model, "--bpm", "100"]) == 0
    assert validate_file(path) == []  # no error, no warning
    text = path.read_text()
    assert "tempo: {bpm: 100," in text and f"model: {model}" in text
    assert main(["new", str(path)]) == 2  # never overwrites
    assert "exists" in capsys.readouterr().err
    assert path.read_text() == text
