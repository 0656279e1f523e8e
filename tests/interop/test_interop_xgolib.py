"""The vendor's own ``xgolib`` (XGO_DOG, XGO_RIDER) drives our simulated XGO robots over a pty.

The simulator records exactly what the vendor library sends, defects included:

- zero speed: ``conver2u8(0, 25)`` = ``int(255 / 50 * 25)`` = 127 = 0x7F, one step below the
  documented neutral 0x80, so the vendor's ``move_x(0)``/``stop()`` leaves a slow creep
  backwards (xgo-show writes 0x80);
- every conversion truncates instead of rounding (``attitude('r', 10)`` sends 191, not 192);
- ``XGO_RIDER.read_imu`` decodes the Rider's six-float block with the dog's int16 layout
  (``unpack_imu``), so its numbers are garbage; ``XGO_DOG.read_imu`` picks ``unpack_imu_r``
  for "R" firmware and reads the block correctly.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from xgolib import XGO_DOG, XGO_RIDER

from xgo_show.sim import PtyServer, XgoRobot
from xgo_show.wire.xgo import write_frame

pytestmark = pytest.mark.interop

Wait = Callable[[Callable[[], bool]], None]


def robot_of(server: PtyServer) -> XgoRobot:
    assert isinstance(server.robot, XgoRobot)
    return server.robot


def running(server: PtyServer) -> int | None:
    with server.lock:
        return robot_of(server).running_action


def last_frame(server: PtyServer) -> bytes:
    with server.lock:
        return server.robot.received[-1].data


def count(server: PtyServer) -> int:
    with server.lock:
        return len(server.robot.received)


def raw(server: PtyServer, name: str) -> bytes:
    with server.lock:
        return robot_of(server).raw(name)


def test_xgo_dog_connects_reads_and_writes(serve: Callable[..., PtyServer], wait: Wait) -> None:
    server = serve("mini", battery=77.0, imu_noise=0.0, attitude_time_constant=0.0)
    dog = XGO_DOG(server.path)  # reads firmware and yaw while connecting
    try:
        assert dog.version == "M-1.4.1"
        assert dog.read_firmware() == "M-1.4.1"
        assert dog.read_battery() == 77

        n = count(server)
        dog.move_x(0)
        wait(lambda: count(server) == n + 1)
        # The vendor defect, recorded exactly as sent: 0x7F, not the neutral 0x80.
        assert last_frame(server) == write_frame(0x30, b"\x7f")
        assert raw(server, "vx") == b"\x7f"
        with server.lock:
            assert robot_of(server).value("vx") < 0  # a slow creep backwards

        dog.move_x(25)
        wait(lambda: raw(server, "vx") == b"\xff")
        dog.translation("z", 100)  # int(255 / 45 * 25) = 141
        wait(lambda: raw(server, "body_z") == bytes([141]))
        dog.attitude("r", 10)  # int(255 / 40 * 30) = 191
        wait(lambda: raw(server, "roll") == bytes([191]))
        roll = (191 - 0x80) / 0x7F * 20.0  # what byte 191 means on the robot
        assert dog.read_roll() == pytest.approx(roll, abs=0.01)
        assert dog.read_imu_int16("roll") == round(roll)
        imu = dog.read_imu()  # acc (m/s²), gyro (deg/s), then angles converted to radians
        assert len(imu) == 9
        assert imu[6] == pytest.approx(roll / 180 * 3.14, abs=1e-3)
        assert imu[1] == pytest.approx(9.8 * math.sin(math.radians(roll)), abs=0.01)
    finally:
        dog.ser.close()
    assert server.snapshot()["frames_rejected"] == 0


def test_xgo_dog_action_and_reset(serve: Callable[..., PtyServer], wait: Wait) -> None:
    server = serve("lite")
    dog = XGO_DOG(server.path)
    try:
        assert dog.version == "L-1.4.1"
        dog.action(19)  # shake hands, 10 s
        wait(lambda: running(server) == 19)
        dog.attitude("p", 5)  # interrupts, as the document says
        wait(lambda: running(server) is None)
        dog.reset()  # action 255: default posture, robot stops
        wait(lambda: running(server) == 255)
        assert raw(server, "pitch") == b"\x80"
        dog.stop()  # move_x(0), move_y(0), mark_time(0), turn(0)
        wait(lambda: raw(server, "vyaw") == b"\x7f")
        assert (raw(server, "vx"), raw(server, "vy")) == (b"\x7f", b"\x7f")
    finally:
        dog.ser.close()
    with server.lock:
        runs = robot_of(server).actions
    # stop()'s speed writes interrupt the 1 s posture reset too.
    assert [(r["id"], r["interrupted_by"]) for r in runs] == [
        (19, "write pitch"),
        (255, "write vx"),
    ]


def test_xgo_rider_connects_and_drives(serve: Callable[..., PtyServer], wait: Wait) -> None:
    server = serve("rider", battery=64.0, imu_noise=0.0, attitude_time_constant=0.0)
    rider = XGO_RIDER(server.path)  # reads firmware, sends reset (255), reads yaw
    try:
        assert rider.version == "R-1.2.3"
        assert rider.rider_read_battery() == 64
        n = count(server)
        rider.rider_move_x(0)
        wait(lambda: count(server) == n + 1)
        # Rider library: write type 0x01, and the same 0x7F zero-speed defect.
        assert last_frame(server) == write_frame(0x30, b"\x7f", write_type=0x01)
        rider.rider_led(2, [10, 20, 30])
        wait(lambda: raw(server, "led2") == bytes([10, 20, 30]))
        rider.rider_roll(17)
        wait(lambda: raw(server, "roll") == b"\xff")
        assert rider.rider_read_roll() == pytest.approx(17.0, abs=0.01)
        rider.rider_turn(360)
        wait(lambda: raw(server, "vyaw") == b"\xff")
        wait(lambda: abs(rider.rider_read_yaw()) > 5)  # yaw integrates the turn speed
        rider.rider_turn(0)
        rider.rider_reset_odom()  # set_origin: heading back to 0
        wait(lambda: abs(rider.rider_read_yaw()) < 5)
    finally:
        rider.ser.close()
    snap = server.snapshot()
    assert snap["frames_rejected"] == 0
    assert snap["actions"][0]["id"] == 255  # the vendor's __init__ resets the robot


def test_vendor_dog_client_decodes_the_rider_imu_block(serve: Callable[..., PtyServer]) -> None:
    server = serve("rider", imu_noise=0.0)
    client = XGO_DOG(server.path)  # firmware "R..." -> read_imu uses unpack_imu_r
    try:
        acc_x, acc_y, acc_z, gyro_x, gyro_y, gyro_z = client.read_imu()
    finally:
        client.ser.close()
    assert (acc_x, acc_y) == (pytest.approx(0.0, abs=1e-6), pytest.approx(0.0, abs=1e-6))
    assert acc_z == pytest.approx(9.80665, abs=1e-4)
    assert (gyro_x, gyro_y, gyro_z) == (0.0, 0.0, 0.0)
