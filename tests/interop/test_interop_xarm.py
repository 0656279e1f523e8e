"""The vendor's ``xarm`` package (0.0.4) drives the simulated xArm over a pty.

``xarm.Controller`` opens a serial port only for names starting with "COM", so the test makes
a symlink ``COMsim`` to the pty in a temporary directory and runs from there.

Vendor defect: ``Controller._recv`` reads 4 header bytes and then ``length`` more, but
``length`` counts itself and the command byte, so it asks for 2 bytes that never come and every
read waits out the port's 1 s timeout (the values are still right). The test keeps its vendor
reads to two.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pytest
import xarm

from xgo_show.sim import PtyServer, XarmRobot
from xgo_show.wire.xarm import servo_move

pytestmark = pytest.mark.interop


def test_vendor_xarm_controller(
    serve: Callable[..., PtyServer],
    wait: Callable[[Callable[[], bool]], None],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    server = serve("xarm", battery_mv=7400)
    robot = server.robot
    assert isinstance(robot, XarmRobot)
    os.symlink(server.path, tmp_path / "COMsim")
    monkeypatch.chdir(tmp_path)
    arm = xarm.Controller("COMsim")
    try:

        def received() -> int:
            with server.lock:
                return len(robot.received)

        arm.setPosition([[1, 300], [2, 700]], duration=0)
        wait(lambda: received() == 1)
        with server.lock:
            assert robot.received[0].data == servo_move(0, {1: 300, 2: 700})
        arm.setPosition(3, 25.0, duration=1500)  # degrees: (25 + 125) / 250 * 1000 = 600
        arm.servoOff(4)
        wait(lambda: received() == 3)
        with server.lock:
            assert robot.snapshot()["moves"][1]["targets"] == {"3": 600}
            assert robot.snapshot()["moves"][1]["duration"] == 1.5
            assert not robot.is_on(4)
            assert robot.is_on(3)

        assert arm.getPosition(2) == 700  # one 1 s timeout (vendor defect)
        assert arm.getBatteryVoltage() == 7.4  # and another
    finally:
        arm._device.close()
    snap = server.snapshot()
    assert snap["frames_rejected"] == 0
    assert snap["servos"]["1"]["position"] == 300.0
    assert snap["servos"]["3"]["target"] == 600.0
