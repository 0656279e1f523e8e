"""XarmRobot driven with a fake clock."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.errors import ProfileError, ValueRangeError
from xgo_show.sim import XarmRobot, create_robot
from xgo_show.wire.xarm import (
    XarmDecoder,
    battery_mv,
    encode_packet,
    get_battery_voltage,
    group_erase,
    group_run,
    group_run_repeat,
    group_speed,
    group_stop,
    offsets,
    positions,
    positions_reply,
    servo_move,
    servo_off,
    servo_offset_read,
    servo_offset_write,
    servo_position_read,
    servo_position_write,
)


def arm(**options: object) -> XarmRobot:
    made = create_robot("xarm", **options)
    assert isinstance(made, XarmRobot)
    return made


def ask(robot: XarmRobot, request: bytes, now: float) -> bytes:
    robot.receive(request, now)
    return robot.poll(now)


def read_positions(robot: XarmRobot, ids: list[int], now: float) -> dict[int, int]:
    (packet,) = XarmDecoder().feed(ask(robot, servo_position_read(ids), now))
    return positions(packet)


def test_position_read_reply_is_byte_exact() -> None:
    r = arm()
    # count 2, ids 1 and 6 -> count 2, {1, 500 LE}, {6, 500 LE}
    reply = ask(r, bytes.fromhex("55 55 05 15 02 01 06"), 0.0)
    assert reply == bytes.fromhex("55 55 09 15 02 01 F4 01 06 F4 01")  # length = 7 params + 2


def test_servo_move_interpolates_linearly() -> None:
    r = arm()
    r.receive(servo_move(1000, {2: 700, 3: 100}), 1.0)
    assert read_positions(r, [2, 3], 1.0) == {2: 500, 3: 500}
    assert read_positions(r, [2, 3], 1.25) == {2: 550, 3: 400}
    assert read_positions(r, [2, 3], 1.5) == {2: 600, 3: 300}
    assert read_positions(r, [2, 3], 2.0) == {2: 700, 3: 100}
    assert read_positions(r, [2, 3], 9.0) == {2: 700, 3: 100}
    (move,) = r.snapshot()["moves"]
    assert move == {"t": 1.0, "duration": 1.0, "targets": {"2": 700, "3": 100}}


def test_a_new_move_starts_from_where_the_servo_is() -> None:
    r = arm()
    r.receive(servo_move(1000, {4: 900}), 0.0)
    r.receive(servo_move(1000, {4: 500}), 0.5)  # at 700 now
    assert r.position(4, 1.0) == pytest.approx(600.0)
    assert r.position(4, 1.5) == pytest.approx(500.0)


def test_time_zero_and_position_write_jump() -> None:
    r = arm()
    r.receive(servo_move(0, {1: 10}), 0.0)
    r.receive(servo_position_write({5: 999}), 0.0)
    assert read_positions(r, [1, 5], 0.0) == {1: 10, 5: 999}


def test_group_stop_holds_servos_where_they_are() -> None:
    r = arm()
    r.receive(servo_move(2000, {1: 900, 6: 100}) + group_run(3, 0), 0.0)
    assert r.running_group == 3
    r.receive(group_stop(), 0.5)  # a quarter of the way
    for t in (0.5, 1.0, 5.0):
        assert read_positions(r, [1, 6], t) == {1: 600, 6: 400}
    snap = r.snapshot()
    assert snap["group"] is None
    assert snap["group_runs"] == [
        {"group": 3, "count": 0, "start": 0.0, "end": 0.5, "ended_by": "stop"}
    ]
    assert snap["stops"] == [0.5]
    assert snap["servos"]["1"]["moving"] is False


def test_servo_off_goes_limp_and_a_move_powers_it_again() -> None:
    r = arm()
    r.receive(servo_move(1000, {2: 1000}), 0.0)
    r.receive(servo_off([2]), 0.5)
    assert not r.is_on(2)
    assert r.is_on(3)
    assert read_positions(r, [2], 3.0) == {2: 750}
    assert r.snapshot()["servos"]["2"]["on"] is False
    r.receive(servo_move(0, {2: 500}), 3.0)
    assert r.is_on(2)


def test_battery_voltage_drains_slowly() -> None:
    r = arm(battery_mv=7600, drain_mv_per_minute=6.0)
    (packet,) = XarmDecoder().feed(ask(r, get_battery_voltage(), 0.0))
    assert battery_mv(packet) == 7600
    r.poll(600.0)  # ten minutes
    (packet,) = XarmDecoder().feed(ask(r, get_battery_voltage(), 600.0))
    assert battery_mv(packet) == 7540
    assert r.snapshot()["battery_mv"] == 7540


def test_offsets_read_and_write() -> None:
    r = arm()
    r.receive(servo_offset_write(3, -20) + servo_offset_write(4, 127), 0.0)
    (packet,) = XarmDecoder().feed(ask(r, servo_offset_read([3, 4, 5]), 0.0))
    assert offsets(packet) == {3: -20, 4: 127, 5: 0}
    assert r.offset(3) == -20


def test_groups_are_tracked_not_played() -> None:
    r = arm()
    r.receive(group_speed(2, 150) + group_run_repeat(2, 3), 0.0)
    assert r.running_group == 2
    assert r.position(1, 5.0) == 500.0  # no stored content, nothing moves
    r.receive(group_erase(255), 1.0)
    snap = r.snapshot()
    assert snap["group"] is None
    assert snap["group_speeds"] == {"2": 150}
    assert snap["groups_erased"] == [{"t": 1.0, "group": 255}]
    assert snap["group_runs"][0]["ended_by"] == "erase"


@pytest.mark.parametrize(
    ("packet", "reason"),
    [
        (servo_move(100, {7: 500}), "no servo 7"),
        (servo_position_read([0x09]), "no servo 9"),
        (bytes.fromhex("55 55 08 03 01 64 00 02 E9 03"), "1001"),  # position 1001: 0x03E9
        (positions_reply({1: 500}), "reply sent to the arm"),
        (encode_packet(28), "not supported"),
    ],
)
def test_bad_packets_are_rejected_and_change_nothing(packet: bytes, reason: str) -> None:
    r = arm()
    before = r.snapshot()
    assert ask(r, packet, 0.0) == b""
    (got,) = r.received
    assert not got.accepted
    assert reason in got.reason
    after = r.snapshot()
    assert after["servos"] == before["servos"]
    assert after["moves"] == []


def test_line_noise_is_counted_and_skipped() -> None:
    r = arm()
    r.receive(b"\x00\x55\x13" + get_battery_voltage(), 0.0)
    assert len(XarmDecoder().feed(r.poll(0.0))) == 1
    assert r.discarded_bytes == 3
    assert r.received[0].data == get_battery_voltage()


def test_packets_split_byte_by_byte() -> None:
    r = arm()
    for i, b in enumerate(servo_move(0, {6: 42})):
        r.receive(bytes([b]), i * 0.001)
    assert r.position(6) == 42.0


def test_snapshot_is_json() -> None:
    r = arm(positions={1: 100})
    r.receive(servo_move(500, {1: 200}), 0.0)
    r.poll(0.25)
    snap = json.loads(json.dumps(r.snapshot()))
    assert snap["servos"]["1"]["position"] == pytest.approx(150.0)
    assert snap["servos"]["1"]["moving"] is True
    assert snap["time"] == 0.25
    assert (snap["frames_received"], snap["frames_rejected"]) == (1, 0)


def test_bad_options() -> None:
    with pytest.raises(ProfileError, match="no servo 9"):
        arm(positions={9: 0})
    with pytest.raises(ValueRangeError):
        arm(positions={1: 1001})
    with pytest.raises(ProfileError, match="no option 'battery'"):
        arm(battery=50)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.binary(max_size=40), max_size=8))
def test_random_bytes_never_raise(chunks: list[bytes]) -> None:
    r = arm()
    for i, chunk in enumerate(chunks):
        r.receive(b"\x55\x55" + chunk if i % 2 else chunk, i * 0.01)
        r.poll(i * 0.01)
    json.dumps(r.snapshot())
