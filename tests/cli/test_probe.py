"""probe with a --model the robot's firmware contradicts still reports the robot."""

from __future__ import annotations

import pytest

from xgo_show.cli.main import main


def test_probe_rider_given_as_mini_reads_with_the_riders_table(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # The Mini's status register is not in the Rider's table: read with the Mini's, the
    # simulated Rider would ignore the request and the probe would time out.
    assert main(["probe", "sim:rider", "--model", "mini", "--timeout", "0.3"]) == 0
    out = capsys.readouterr().out
    assert "model     mini (given; the firmware names a rider)" in out
    assert "battery   100 %" in out
    assert "status" in out
