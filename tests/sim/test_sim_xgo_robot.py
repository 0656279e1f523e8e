"""XgoRobot driven with a fake clock: the ``now`` arguments are the only time it sees."""

from __future__ import annotations

import json
import math
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.errors import ProfileError, ValueRangeError
from xgo_show.profiles import get_profile
from xgo_show.sim import XgoRobot, create_robot
from xgo_show.wire.xgo import XgoDecoder, XgoFrame, read_frame, reply_frame, write_frame


def robot(model: str = "mini", **options: object) -> XgoRobot:
    options.setdefault("imu_noise", 0.0)
    made = create_robot(model, **options)
    assert isinstance(made, XgoRobot)
    return made


def frames(data: bytes) -> list[XgoFrame]:
    return XgoDecoder().feed(data)


def byte(model: str, name: str, value: float) -> int:
    return get_profile(model).register(name).to_byte(value)


# ---------------------------------------------------------------- reads
def test_read_twelve_servos_matches_the_document_byte_for_byte() -> None:
    r = robot()
    # The document's example: read 12 servo angles from 0x50, and its reply packet.
    r.receive(bytes.fromhex("55 00 09 02 50 0C 98 00 AA"), 0.0)
    reply = bytes.fromhex("55 00 14 12 50" + " 80" * 12 + " 89 00 AA")
    assert r.poll(0.0) == reply
    assert r.received[0].accepted


@pytest.mark.parametrize(
    ("model", "firmware"), [("mini", "M-1.4.1"), ("lite", "L-1.4.1"), ("rider", "R-1.2.3")]
)
def test_firmware_read_replies_ten_ascii_bytes(model: str, firmware: str) -> None:
    r = robot(model)
    r.receive(read_frame(0x07, 10), 0.0)
    assert r.poll(0.0) == reply_frame(0x07, firmware.encode().ljust(10, b"\0"))


def test_firmware_is_configurable() -> None:
    r = robot(firmware="MW-2.0.0")
    r.receive(read_frame(0x07, 10), 0.0)
    assert frames(r.poll(0.0))[0].data == b"MW-2.0.0\0\0"


def test_multi_register_read_walks_fields() -> None:
    r = robot("rider")
    r.receive(write_frame(0x69, bytes([1, 2, 3, 4, 5, 6]), write_type=0x01), 0.0)
    r.receive(read_frame(0x69, 6), 0.0)
    (reply,) = frames(r.poll(0.0))
    assert (reply.type, reply.address, reply.data) == (0x12, 0x69, bytes([1, 2, 3, 4, 5, 6]))
    assert r.value("led1") == [1, 2, 3]
    assert r.value("led2") == [4, 5, 6]
    r.receive(read_frame(0x62, 12), 0.0)  # three float32 fields
    (angles,) = frames(r.poll(0.0))
    assert len(angles.data) == 12
    assert angles.data[:4] == r.raw("imu_roll")
    assert angles.data[8:] == r.raw("imu_yaw")


def test_reads_answer_registers_documented_as_write() -> None:
    r = robot()
    r.receive(write_frame(0x30, b"\xff"), 0.0)
    r.receive(read_frame(0x30, 3), 0.0)
    assert frames(r.poll(0.0))[0].data == b"\xff\x80\x80"


@pytest.mark.parametrize(
    ("address", "count", "reason"),
    [
        (0x10, 1, "no register at 0x10"),  # not in the table
        (0x62, 2, "imu_roll"),  # cuts the float32
        (0x4B, 6, "no register at 0x4C"),  # runs off the leg block
        (0x30, 0, "0 bytes"),
    ],
)
def test_bad_reads_get_no_reply_and_are_recorded(address: int, count: int, reason: str) -> None:
    r = robot()
    frame = XgoFrame(0x02, address, bytes([count])).encode()
    r.receive(frame, 1.5)
    assert r.poll(1.5) == b""
    (got,) = r.received
    assert (got.t, got.data, got.accepted) == (1.5, frame, False)
    assert reason in got.reason


def test_read_split_into_single_bytes_still_answers() -> None:
    r = robot()
    for i, b in enumerate(read_frame(0x01, 1)):
        r.receive(bytes([b]), i * 0.001)
    assert r.poll(0.01) == reply_frame(0x01, b"\x64")


# ---------------------------------------------------------------- writes
def test_write_example_from_the_document_sets_full_forward_speed() -> None:
    r = robot()
    r.receive(bytes.fromhex("55 00 09 00 30 FF C7 00 AA"), 0.0)
    assert r.raw("vx") == b"\xff"
    assert r.value("vx") == pytest.approx(25.0)
    assert r.poll(0.0) == b""  # writes are not answered


def test_rider_write_type_and_dog_write_type_are_both_accepted() -> None:
    r = robot()
    r.receive(write_frame(0x31, b"\x10", write_type=0x01), 0.0)
    r.receive(write_frame(0x32, b"\x20", write_type=0x00), 0.0)
    assert (r.raw("vy"), r.raw("vyaw")) == (b"\x10", b"\x20")
    assert all(f.accepted for f in r.received)


def test_multi_byte_write_sets_consecutive_fields() -> None:
    r = robot()
    r.receive(write_frame(0x33, bytes([0x10, 0x20, 0x30])), 0.0)
    assert [r.raw(n)[0] for n in ("body_x", "body_y", "body_z")] == [0x10, 0x20, 0x30]


def test_read_only_register_ignores_writes() -> None:
    r = robot()
    r.receive(write_frame(0x01, b"\x05"), 0.0)
    r.receive(write_frame(0x07, b"HACKED-FW\0"), 0.0)
    assert r.raw("battery") == b"\x64"
    assert r.value("firmware") == "M-1.4.1"
    assert [f.accepted for f in r.received] == [False, False]
    assert "battery (0x01) is read-only" in r.received[0].reason


def test_rejected_write_changes_nothing_at_all() -> None:
    r = robot()
    before = r.snapshot()["raw"]
    # pace (0x3D) then action (0x3E) = 99: no such action, so pace is not written either.
    r.receive(write_frame(0x3D, bytes([0x01, 99])), 0.0)
    # gait 0x03 ("slow_trot" in the vendor library) is not a documented choice.
    r.receive(write_frame(0x09, b"\x03"), 0.0)
    # a write running off the table
    r.receive(write_frame(0x5E, b"\x01\x02"), 0.0)
    assert r.snapshot()["raw"] == before
    assert [f.accepted for f in r.received] == [False, False, False]
    assert "no action 99" in r.received[0].reason
    assert "gait" in r.received[1].reason
    assert "0x5F" in r.received[2].reason


def test_bad_frames_change_nothing_and_are_counted() -> None:
    r = robot()
    before = r.snapshot()["raw"]
    good = write_frame(0x30, b"\xff")
    bad_checksum = good[:5] + b"\xfe" + good[6:]  # data changed, checksum kept
    bad_tail = good[:-1] + b"\xab"
    r.receive(b"\x01\x02junk" + bad_checksum + bad_tail, 0.0)
    assert r.snapshot()["raw"] == before
    assert r.received == []
    assert r.discarded_bytes == 6 + len(bad_checksum) + len(bad_tail)
    r.receive(good, 0.1)  # the line recovers
    assert r.raw("vx") == b"\xff"


def test_reply_type_frames_from_the_host_are_rejected() -> None:
    r = robot()
    r.receive(reply_frame(0x30, b"\x00"), 0.0)
    assert r.raw("vx") == b"\x80"
    assert not r.received[0].accepted


# ---------------------------------------------------------------- actions
def test_action_runs_for_its_documented_duration() -> None:
    r = robot()
    r.receive(write_frame(0x3E, bytes([3])), 1.0)  # creep forward, 5 s
    r.poll(5.99)
    assert r.running_action == 3
    assert r.raw("action") == b"\x03"
    r.poll(6.0)
    assert r.running_action is None
    assert r.raw("action") == b"\x00"
    (run,) = r.snapshot()["actions"]
    assert run["id"] == 3
    assert run["name"] == "creep_forward"
    assert (run["start"], run["duration"], run["end"]) == (1.0, 5.0, 6.0)
    assert run["interrupted_at"] is None


def test_rider_actions_without_documented_duration_use_the_default() -> None:
    r = robot("rider")
    r.receive(write_frame(0x3E, b"\x02", write_type=0x01), 0.0)
    r.poll(2.9)
    assert r.running_action == 2
    r.poll(3.0)
    assert r.running_action is None
    fast = robot("rider", default_action_duration=0.5)
    fast.receive(write_frame(0x3E, b"\x02", write_type=0x01), 0.0)
    fast.poll(0.5)
    assert fast.running_action is None


def test_motion_write_interrupts_an_action_other_writes_and_reads_do_not() -> None:
    r = robot()
    r.receive(write_frame(0x3E, bytes([19])), 0.0)  # shake hands, 10 s
    r.receive(write_frame(0x61, b"\x01"), 1.0)  # imu_mode: a setting
    r.receive(read_frame(0x62, 12), 1.5)
    assert r.running_action == 19
    r.receive(write_frame(0x36, b"\x90"), 2.0)  # roll: motion
    assert r.running_action is None
    assert r.raw("action") == b"\x00"
    (run,) = r.actions
    assert (run["interrupted_at"], run["interrupted_by"], run["end"]) == (2.0, "write roll", 2.0)


def test_new_action_interrupts_the_running_one() -> None:
    r = robot()
    r.receive(write_frame(0x3E, bytes([19])), 0.0)
    r.receive(write_frame(0x3E, bytes([1])), 1.0)
    first, second = r.actions
    assert first["interrupted_at"] == 1.0
    assert (second["id"], second["start"]) == (1, 1.0)
    assert r.running_action == 1


def test_action_255_restores_the_default_posture_and_stops() -> None:
    r = robot()
    r.receive(write_frame(0x30, bytes([0xF0, 0x10, 0x90, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06])), 0)
    r.receive(write_frame(0x39, b"\x40"), 0.0)  # periodic roll
    r.receive(write_frame(0x3E, b"\xff"), 1.0)
    for name in ("vx", "vy", "vyaw", "body_x", "body_y", "body_z", "roll", "pitch", "yaw"):
        assert r.raw(name) == b"\x80", name
    assert r.raw("periodic_roll") == b"\x00"
    assert r.running_action == 255
    r.poll(2.0)  # "restore default posture": 1 s
    assert r.running_action is None


def test_unknown_action_is_rejected() -> None:
    r = robot("rider")
    r.receive(write_frame(0x3E, b"\x07", write_type=0x01), 0.0)
    assert r.running_action is None
    assert not r.received[0].accepted


# ---------------------------------------------------------------- IMU, battery, heading
def test_imu_follows_the_commanded_attitude() -> None:
    r = robot("mini", imu_noise=0.0)
    r.poll(0.0)
    roll, pitch = byte("mini", "roll", 10.0), byte("mini", "pitch", -11.0)
    r.receive(write_frame(0x36, bytes([roll, pitch])), 0.0)
    r.poll(0.05)
    assert 0.0 < r.value("imu_roll") < 10.0  # on its way, not there at once
    r.poll(2.0)
    # The commanded angles are what the bytes mean (10.08 and -11.0 deg), not what was asked.
    want_roll = get_profile("mini").register("roll").to_physical(roll)
    want_pitch = get_profile("mini").register("pitch").to_physical(pitch)
    assert r.value("imu_roll") == pytest.approx(want_roll, abs=0.01)
    assert r.value("imu_pitch") == pytest.approx(want_pitch, abs=0.01)
    assert r.value("imu_roll_i16") == 10
    assert r.value("imu_pitch_i16") == -11
    block = get_profile("mini").imu
    assert block is not None
    imu = block.unpack(r.raw("imu_block"))
    assert imu["roll"] == pytest.approx(want_roll, abs=0.01)
    assert imu["pitch"] == pytest.approx(want_pitch, abs=0.01)
    g, rr, pp = 9.80665, math.radians(want_roll), math.radians(want_pitch)
    assert imu["acc_y"] == pytest.approx(g * math.sin(rr) * math.cos(pp), abs=0.01)
    assert imu["acc_x"] == pytest.approx(-g * math.sin(pp), abs=0.01)
    assert imu["gyro_x"] == pytest.approx(0.0, abs=0.1)  # settled: no more rotation


def test_imu_float_registers_are_little_endian_as_the_vendor_reads_them() -> None:
    r = robot("mini", imu_noise=0.0)
    r.poll(0.0)
    r.receive(write_frame(0x36, bytes([byte("mini", "roll", -20.0)])), 0.0)
    r.poll(3.0)
    r.receive(read_frame(0x62, 4), 3.0)
    data = frames(r.poll(3.0))[0].data
    # xgolib Byte2Float: reverse the four bytes and unpack big-endian.
    assert struct.unpack("!f", data[::-1])[0] == pytest.approx(-20.0, abs=0.01)
    r.receive(read_frame(0x66, 2), 3.0)
    assert struct.unpack(">h", frames(r.poll(3.0))[0].data)[0] == -20


def test_rider_imu_block_is_six_floats() -> None:
    r = robot("rider", imu_noise=0.0)
    r.poll(0.0)
    r.receive(write_frame(0x36, bytes([byte("rider", "roll", 17.0)]), write_type=0x01), 0.0)
    r.poll(2.0)
    acc_x, acc_y, acc_z, *_ = struct.unpack("<6f", r.raw("imu_block"))
    assert acc_x == pytest.approx(0.0, abs=0.01)
    assert acc_y == pytest.approx(9.80665 * math.sin(math.radians(17.0)), abs=0.01)
    assert acc_z == pytest.approx(9.80665 * math.cos(math.radians(17.0)), abs=0.01)


def test_noise_is_seeded() -> None:
    a, b, c = robot(imu_noise=0.1, seed=1), robot(imu_noise=0.1, seed=1), robot(imu_noise=0.1)
    for t in (0.0, 0.5, 1.0):
        for x in (a, b, c):
            x.poll(t)
    assert a.raw("imu_block") == b.raw("imu_block") != c.raw("imu_block")
    assert abs(a.value("imu_roll")) < 0.6


def test_yaw_integrates_turn_speed_and_set_origin_zeroes_it() -> None:
    r = robot("rider", imu_noise=0.0)
    r.poll(0.0)
    vyaw = get_profile("rider").register("vyaw")
    b = vyaw.to_byte(30.0)
    r.receive(write_frame(0x32, bytes([b]), write_type=0x01), 0.0)
    r.poll(1.0)
    r.poll(2.0)
    assert r.value("imu_yaw") == pytest.approx(2 * vyaw.to_physical(b), abs=0.01)
    assert r.snapshot()["heading"] == pytest.approx(2 * vyaw.to_physical(b))
    r.receive(write_frame(0x32, b"\x80", write_type=0x01), 2.0)
    r.receive(write_frame(0x06, b"\x01", write_type=0x01), 2.0)
    assert r.value("imu_yaw") == 0.0
    assert r.raw("set_origin") == b"\x00"  # one-shot: clears itself
    assert r.snapshot()["odometer"] == 0.0


def test_heading_wraps_around() -> None:
    r = robot(imu_noise=0.0)
    r.poll(0.0)
    r.receive(write_frame(0x32, b"\xff"), 0.0)  # 100 deg/s
    r.poll(2.0)  # 200 deg -> -160 deg
    assert r.value("imu_yaw") == pytest.approx(-160.0, abs=0.01)


def test_battery_drains_and_is_configurable() -> None:
    r = robot(battery=50.0, drain_per_minute=1.0)
    r.poll(0.0)
    r.poll(60.0)
    assert r.battery == pytest.approx(49.0)
    r.receive(read_frame(0x01, 1), 60.0)
    assert frames(r.poll(60.0))[0].data == b"\x31"  # 49 %
    r.poll(90.0)
    assert r.raw("battery") == b"\x31"  # 48.5 % reads 49 (rounded up)
    r.set_battery(5.0)
    assert r.raw("battery") == b"\x05"
    r.poll(10_000.0)
    assert r.battery == 0.0


def test_bad_options_raise() -> None:
    with pytest.raises(ValueRangeError):
        robot(battery=120.0)
    with pytest.raises(ProfileError, match="valid: mini, lite, rider, xarm"):
        create_robot("xgo-max")


# ---------------------------------------------------------------- Rider specifics
def test_rider_falls_and_recovers() -> None:
    r = robot("rider", imu_noise=0.0)
    r.poll(0.0)
    r.receive(read_frame(0x02, 1), 0.0)
    assert frames(r.poll(0.0))[0].data == b"\x01"
    r.fall()
    r.poll(2.0)
    r.receive(read_frame(0x02, 1), 2.0)
    assert frames(r.poll(2.0))[0].data == b"\x00"
    assert r.value("status") == "fallen"
    assert r.value("imu_roll") > 45.0
    assert r.snapshot()["fallen"] is True
    r.recover()
    assert r.value("status") == "normal"
    # A Mini has no fall status: its IMU says it lies on its side.
    mini = robot("mini", imu_noise=0.0)
    mini.poll(0.0)
    mini.fall()
    mini.poll(2.0)
    assert mini.value("imu_roll") > 45.0


def test_rider_feedback_streams_at_50_hz() -> None:
    r = robot("rider")
    r.poll(0.0)
    r.receive(write_frame(0x08, b"\x01", write_type=0x01), 0.0)
    out = bytearray(r.poll(0.0))  # the first tick is immediate
    for i in range(1, 101):
        out += r.poll(i * 0.01)
    got = frames(bytes(out))
    by_address = {a: [f for f in got if f.address == a] for a in {f.address for f in got}}
    assert sorted(by_address) == [0x01, 0x02, 0x62, 0x65]
    assert all(f.type == 0x12 for f in got)
    assert len(by_address[0x01]) == 51  # t = 0, 0.02, ..., 1.0
    assert len(by_address[0x65][0].data) == 24
    assert len(by_address[0x62][0].data) == 12
    r.receive(write_frame(0x08, b"\x00", write_type=0x01), 1.0)
    assert r.poll(2.0) == b""


def test_rider_feedback_catch_up_is_bounded() -> None:
    r = robot("rider")
    r.receive(write_frame(0x08, b"\x01", write_type=0x01), 0.0)
    got = frames(r.poll(10.0))
    assert len([f for f in got if f.address == 0x01]) == 51  # one second's worth at most
    assert r.snapshot()["feedback_dropped"] == 450


def test_dog_has_no_feedback_register() -> None:
    r = robot()
    r.receive(write_frame(0x08, b"\x01"), 0.0)
    assert not r.received[0].accepted
    assert r.poll(1.0) == b""


# ---------------------------------------------------------------- snapshot and robustness
def test_snapshot_is_json_and_complete() -> None:
    r = robot("rider")
    r.receive(write_frame(0x69, b"\x01\x02\x03", write_type=0x01) + b"\x00junk", 0.25)
    r.receive(write_frame(0x01, b"\x01", write_type=0x01), 0.5)
    snap = json.loads(json.dumps(r.snapshot()))
    assert snap["model"] == "rider"
    assert snap["firmware"] == "R-1.2.3"
    assert snap["registers"]["led1"] == [1, 2, 3]
    assert snap["registers"]["status"] == "normal"
    assert snap["registers"]["vx"] == 0.0
    assert snap["raw"]["vx"] == "80"
    assert (snap["frames_received"], snap["frames_rejected"]) == (2, 1)
    assert snap["discarded_bytes"] == 5
    assert snap["battery"] == pytest.approx(100.0, abs=0.01)
    assert snap["time"] == 0.5


def test_time_running_backwards_changes_nothing() -> None:
    r = robot(battery=50.0, drain_per_minute=60.0)
    r.poll(10.0)
    r.poll(5.0)
    assert r.battery == 50.0


@settings(max_examples=150, deadline=None)
@given(st.lists(st.binary(max_size=64), max_size=8))
def test_random_bytes_never_raise(chunks: list[bytes]) -> None:
    r = robot("rider")
    for i, chunk in enumerate(chunks):
        r.receive(chunk, i * 0.01)
        r.poll(i * 0.01)
    json.dumps(r.snapshot())
