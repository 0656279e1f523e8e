"""Reading schedules back: describe_frame, state_at, frames_to_reach (checked on a simulator)."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.choreo.resolved import ActionCue, ArmCue, MotionCue, SetCue
from xgo_show.compiler import compile_show, describe_frame, frames_to_reach, state_at
from xgo_show.compiler import state as state_module
from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.compiler.state import (
    FrameLabels,
    format_fields,
    format_value,
    frame_label,
    frame_labels,
    layout_of,
    link_use,
    xgo_state_at,
)
from xgo_show.errors import ProtocolError
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Access, Link, Profile, Register
from xgo_show.sim.xgo_robot import XgoRobot
from xgo_show.wire.xgo import MAX_DATA, read_frame, write_frame

MINI = get_profile("mini")


def test_describe_frame_decodes_physical_values() -> None:
    data = write_frame(0x3C, bytes([0x00, 0x02, 0x17]))
    assert describe_frame(MINI, data) == [("mark_time", 0.0), ("pace", "fast"), ("action", 23)]
    assert describe_frame(MINI, write_frame(0x35, b"\xff")) == [("body_z", 120.0)]
    with pytest.raises(ProtocolError):
        describe_frame(MINI, b"\x55\x00\x09")
    with pytest.raises(ProtocolError, match="register layout"):
        describe_frame(MINI, write_frame(0x0E, b"\x00"))


def test_describe_xarm_servo_move() -> None:
    from xgo_show.wire.xarm import servo_move

    arm = get_profile("xarm")
    data = servo_move(1500, {1: 500, 3: 120})
    assert describe_frame(arm, data) == [("time_ms", 1500), ("servo_1", 500), ("servo_3", 120)]


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(["mini", "lite", "rider"]), st.data())
def test_frame_labels_say_what_describe_frame_says(model: str, data: st.DataObject) -> None:
    # FrameLabels (the compiler's lazy labels) cuts frames with a cached walk and caches each
    # field's text: any run of consecutive registers, any bytes, says the same.
    profile = get_profile(model)
    regs = sorted(profile.registers, key=lambda r: r.address)
    first = data.draw(st.integers(0, len(regs) - 1))
    run = [regs[first]]
    for reg in regs[first + 1:first + data.draw(st.integers(1, 6))]:
        if reg.address != run[-1].address + run[-1].size:
            break
        run.append(reg)
    payload = b"".join(data.draw(st.binary(min_size=r.size, max_size=r.size)) for r in run)
    # Also the same frame with one byte changed (and back): the caches must tell them apart.
    at = data.draw(st.integers(0, len(payload) - 1))
    other = payload[:at] + bytes(((payload[at] + 1) % 256,)) + payload[at + 1:]
    labels = FrameLabels(profile)
    for body in (payload, other, payload):
        frame = write_frame(run[0].address, body, write_type=profile.write_type)
        try:
            expected = format_fields(profile, describe_frame(profile, frame))
        except ProtocolError:
            return  # a run of fields the layout does not walk (not a frame the compiler makes)
        assert labels(frame) == expected


def test_frame_labels_of_other_bytes_are_describe_frames() -> None:
    from xgo_show.wire.xarm import servo_move

    arm = get_profile("xarm")
    assert frame_labels(arm)(servo_move(1500, {1: 500})) == "time_ms=1500 servo_1=500"
    # Read while a show runs, a frame's label never raises: it says what is wrong with the bytes.
    with pytest.raises(ProtocolError, match="register layout"):
        FrameLabels(MINI)(write_frame(0x0E, b"\x00"))
    assert frame_labels(MINI)(write_frame(0x0E, b"\x00")) == (
        "(1 bytes at 0x0E do not match the mini register layout)")
    assert frame_labels(arm)(b"\x55\x55").startswith("(")


@pytest.fixture
def schedule(make_show, o):  # type: ignore[no-untyped-def]
    return compile_show(make_show({
        "rex": ("mini", [
            SetCue(0.0, o("setup"), {"gait": "walk", "pace": "slow"}),
            MotionCue(0.5, o("crouch"), {"body_z": 90.0, "pitch": 10.0}, duration=1.0),
            ActionCue(3.0, o("dance"), 23, "dance", 6.0),
            SetCue(10.0, o("walk"), {"vx": 12.0}),
        ]),
        "arm": ("xarm", [
            ArmCue(0.0, o("a1"), {1: 500, 2: 300}, 1.0),
            ArmCue(2.0, o("a2"), {2: 700, 3: 100}, 1.0),
        ]),
    }))


def test_state_at_replays_writes_and_running_action(schedule) -> None:  # type: ignore[no-untyped-def]
    rex = schedule.performer("rex")
    assert state_at(rex, -1.0) == {}
    mid = state_at(rex, 1.0)
    assert mid["gait"] == b"\x01" and mid["pace"] == b"\x01"
    assert 90.0 < MINI.register("body_z").to_physical(mid["body_z"][0]) < 97.6
    assert "action" not in mid
    assert state_at(rex, 4.0)["action"] == b"\x17"  # dance runs 3 .. 9 s
    late = state_at(rex, 11.0)
    assert "action" not in late
    assert late["vx"] == bytes((MINI.register("vx").to_byte(12.0),))
    assert late["body_z"] == bytes((MINI.register("body_z").to_byte(90.0),))


def test_state_at_for_the_xarm(schedule) -> None:  # type: ignore[no-untyped-def]
    arm = schedule.performer("arm")
    state = state_at(arm, 2.5)
    assert state == {"servo_1": (500).to_bytes(2, "little"), "servo_2": (700).to_bytes(2, "little"),
                     "servo_3": (100).to_bytes(2, "little")}
    (frame,) = frames_to_reach(get_profile("xarm"), state)
    assert describe_frame(get_profile("xarm"), frame.data) == [
        ("time_ms", 1000), ("servo_1", 500), ("servo_2", 700), ("servo_3", 100)]


@pytest.mark.parametrize("t", [1.0, 4.0, 11.0])
def test_frames_to_reach_bring_a_fresh_robot_to_the_state(schedule, t: float) -> None:  # type: ignore[no-untyped-def]
    state = state_at(schedule.performer("rex"), t)
    frames = frames_to_reach(MINI, state)
    robot = XgoRobot(MINI)
    for i, f in enumerate(frames):
        robot.receive(f.data, 0.01 * i)
        assert f.label == " ".join(f.label.split())  # labelled like scheduled frames
    for name, raw in state.items():
        if name != "action":
            assert robot.raw(name) == raw, name
    assert robot.running_action == (23 if "action" in state else None)
    if "action" in state:
        assert frames[-1].label == "action=23(dance)"  # the action goes last


def test_frames_to_reach_skips_initial_values_and_merges() -> None:
    initial = {"body_z": b"\x80", "roll": b"\x80"}
    assert frames_to_reach(MINI, initial) == []
    frames = frames_to_reach(MINI, {"body_z": b"\x90", "pitch": b"\x70"})
    (frame,) = frames
    assert frame.data == write_frame(0x35, b"\x90\x80\x70")  # roll bridged with its initial


def test_compiled_frames_derive_their_labels_from_their_bytes(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # A frame stores no label: it says what its bytes say, through its model's one FrameLabels.
    from xgo_show.compiler import ScheduledFrame

    show = make_show({"rex": ("mini", [
        SetCue(0.0, o("setup", 2), {"gait": "walk"}),
        MotionCue(0.1, o("crouch", 3), {"body_z": 90.0, "pitch": 8.0}, duration=0.8),
        ActionCue(1.0, o("wave", 4), 13, "wave", 7.0),
    ])})
    frames = compile_show(show).performers[0].frames
    assert len(frames) > 3
    for f in frames:
        assert not hasattr(f, "__dict__")
        assert f.labels is frame_labels(MINI)
        assert f.label == format_fields(MINI, describe_frame(MINI, f.data))
        assert f == ScheduledFrame(f.t, f.data, f.origin, f.duration)  # labels aside
    assert frames[-1].label == "action=13(wave)"
    assert ScheduledFrame(0.0, frames[0].data).label == ""  # no labels given: no label


# --- labels: malformed bytes, the field cache, one labeller a profile ------------------------

def test_frame_labels_refuse_bytes_that_are_not_one_write_frame() -> None:
    good = write_frame(0x35, b"\x90")
    bad_length = good[:2] + bytes((good[2] + 1,)) + good[3:]  # the length byte disagrees
    for data in (good[:5], bad_length):
        with pytest.raises(ProtocolError, match="not a single XGO write frame"):
            FrameLabels(MINI)(data)
        assert frame_labels(MINI)(data).startswith("(not a single XGO write frame")
    assert frame_label(MINI, good) == FrameLabels(MINI)(good) == "body_z=100.4mm"


def test_frame_labels_make_each_distinct_fields_text_once(monkeypatch: pytest.MonkeyPatch) -> None:
    made: list[tuple[int, bytes]] = []
    real = state_module.field_label

    def counting(profile, address, raw):  # type: ignore[no-untyped-def]
        made.append((address, bytes(raw)))
        return real(profile, address, raw)

    monkeypatch.setattr(state_module, "field_label", counting)
    labels = FrameLabels(get_profile("rider"))
    one = write_frame(0x35, b"\x90\x70", write_type=0x01)  # body_z, roll: one byte each
    leds = write_frame(0x69, b"\x01\x02\x03\x04\x05\x06", write_type=0x01)  # led1, led2
    for data in (one, leds, one, leds):
        labels(data)
    assert made == [(0x35, b"\x90"), (0x36, b"\x70"), (0x69, b"\x01\x02\x03"),
                    (0x6A, b"\x04\x05\x06")]
    labels(write_frame(0x35, b"\x90\x71", write_type=0x01))  # a new roll byte only
    assert made[4:] == [(0x36, b"\x71")]


def test_each_profile_has_one_labeller_and_a_new_profile_object_its_own() -> None:
    assert frame_labels(MINI) is frame_labels(MINI)
    copy = dataclasses.replace(MINI, title="Mini (a copy)")
    labels = frame_labels(copy)
    assert labels is frame_labels(copy) and labels is not frame_labels(MINI)
    assert labels(write_frame(0x35, b"\x90")) == "body_z=100.4mm"


# --- state_at: up to and including t; an action ends at its end -------------------------------

def test_state_at_includes_a_frame_at_exactly_t_and_drops_an_action_at_its_end() -> None:
    frames = [ScheduledFrame(1.0, write_frame(0x35, b"\x90")),
              ScheduledFrame(2.0, write_frame(0x3E, b"\x17"), duration=3.0)]
    assert xgo_state_at(MINI, frames, 0.999999) == {}
    assert xgo_state_at(MINI, frames, 1.0) == {"body_z": b"\x90"}
    assert xgo_state_at(MINI, frames, 2.0) == {"body_z": b"\x90", "action": b"\x17"}
    assert xgo_state_at(MINI, frames, 4.999999)["action"] == b"\x17"
    assert xgo_state_at(MINI, frames, 5.0) == {"body_z": b"\x90"}


# --- frames_to_reach: what is written, how it is grouped ----------------------------------------

def test_frames_to_reach_write_only_safe_writable_registers_and_the_action_last() -> None:
    state = {"battery": b"\x10", "calibration": b"\x01", "leg1_x": b"\x90",
             "action": b"\x17", "body_z": b"\x70"}
    frames = frames_to_reach(MINI, state)
    assert [f.data for f in frames] == [write_frame(0x35, b"\x70"), write_frame(0x40, b"\x90"),
                                        write_frame(0x3E, b"\x17")]
    assert all(f.t == 0.0 and f.duration == 0.0 for f in frames)


def test_frames_to_reach_use_the_profiles_write_type() -> None:
    rider = get_profile("rider")
    frames = frames_to_reach(rider, {"body_z": b"\x70", "action": b"\x01"})
    assert [f.data for f in frames] == [write_frame(0x35, b"\x70", write_type=0x01),
                                        write_frame(0x3E, b"\x01", write_type=0x01)]


@pytest.mark.parametrize(("names", "frames"), [
    # body_y and roll are bridged with their initial bytes: one frame for all three.
    (("body_x", "body_z", "pitch"), 1),
    # seven leg registers between: bridged (shorter than a frame's 8 bytes of overhead) ...
    (("leg1_x", "leg3_z"), 1),
    # ... eight are not: two frames
    (("leg1_x", "leg4_x"), 2),
    # servo_speed (a setting) is never re-sent to bridge a gap
    (("servo_43", "servo_52"), 2),
])
def test_frames_to_reach_bridge_short_gaps_of_state_registers(names: tuple[str, ...],
                                                              frames: int) -> None:
    state = {name: b"\x90" for name in names}
    got = frames_to_reach(MINI, state)
    assert len(got) == frames
    robot = XgoRobot(MINI)
    for i, f in enumerate(got):
        robot.receive(f.data, 0.01 * i)
    for reg in MINI.registers:
        if reg.access.writable and not reg.unsafe and reg.name != "action":
            assert robot.raw(reg.name) == state.get(reg.name, reg.initial), reg.name


# 250 one-byte state registers at 0x00..0xF9, initial 0: more than one frame's worth.
LONG = Profile("long", "xgo", "Long", Link(115200, 0.001), tuple(
    Register(a, f"r{a}", Access.READ_WRITE, initial=b"\x00", group="posture")
    for a in range(250)))


def test_frames_to_reach_cut_runs_at_max_data_bytes_and_no_sooner() -> None:
    frames = frames_to_reach(LONG, {f"r{a}": b"\x01" for a in range(250)})
    assert [len(f.data) - 8 for f in frames] == [MAX_DATA, 250 - MAX_DATA]
    bridged = frames_to_reach(LONG, {f"r{a}": b"\x01" for a in range(0, 250, 2)})
    assert all(len(f.data) - 8 <= MAX_DATA for f in bridged)
    # r0..r246 (r1, r3, ... bridged), then r248 alone
    assert [len(f.data) - 8 for f in bridged] == [MAX_DATA, 1]


def test_link_use_of_a_part_of_no_duration_is_zero() -> None:
    frames = [ScheduledFrame(0.0, write_frame(0x35, b"\x90"))]
    assert link_use(MINI.link, frames, 0.0) == 0.0
    assert link_use(MINI.link, frames, 1.0) == pytest.approx(9 * 10 / 115200)


def test_one_layout_a_profile_and_a_new_profile_object_gets_its_own() -> None:
    assert layout_of(MINI) is layout_of(MINI) and layout_of(MINI).profile is MINI
    copy = dataclasses.replace(MINI, registers=MINI.registers[:10])
    assert layout_of(copy).profile is copy and len(layout_of(copy).by_address) == 10
    assert layout_of(copy) is layout_of(copy)
    assert layout_of(MINI).profile is MINI  # asked again: the table's own profile


@pytest.mark.parametrize("data", [
    read_frame(0x35, 1),  # a whole frame, but a read
    write_frame(0x35, b"\x90") + b"\x00",  # a write and a byte more
    b"\x00\x01\x02",  # no frame at all
])
def test_only_one_whole_write_frame_is_described(data: bytes) -> None:
    with pytest.raises(ProtocolError, match="not a single XGO write frame"):
        describe_frame(MINI, data)


def test_values_as_a_transcript_shows_them() -> None:
    assert format_value(MINI, "roll", 5.04) == "5.0deg"
    assert format_value(MINI, "roll", -0.01) == "0.0deg"  # no negative zero
    assert format_value(MINI, "not_a_register", 2.5) == "2.5"  # a float without a unit
    assert format_value(MINI, "action", 13) == "13(wave)"
    assert format_value(MINI, "battery", 13) == "13"  # an int elsewhere is not an action
