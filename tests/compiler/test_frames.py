"""Frames: exact bytes of merged writes, gap filling, de-duplication, actions, fades, labels."""

from __future__ import annotations

import itertools

import pytest

from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show, describe_frame
from xgo_show.profiles import get_profile


def _frames(show):  # type: ignore[no-untyped-def]
    return compile_show(show).performers[0].frames


def test_adjacent_registers_merge_into_one_frame_golden(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        SetCue(0.0, o("pose"), {"body_x": 0.0, "body_y": 19.5, "body_z": 120.0}),
    ])})
    (frame,) = _frames(show)
    assert frame.data == bytes([
        0x55, 0x00,  # header
        0x0B,        # length: the whole frame, 8 + 3 data bytes
        0x00,        # type: write (Mini/Lite)
        0x33,        # address: body_x, first of three consecutive registers
        0x80,        # body_x 0 mm -> neutral 0x80
        0xFF,        # body_y 19.5 mm (its maximum)
        0xFF,        # body_z 120 mm (its maximum)
        0x43,        # checksum: ~(0x0B + 0x00 + 0x33 + 0x80 + 0xFF + 0xFF) & 0xFF
        0x00, 0xAA,  # tail
    ])
    assert frame.label == "body_x=0.0mm body_y=19.5mm body_z=120.0mm"
    assert frame.origin == o("pose")
    assert frame.t == 0.0


def test_rider_leds_merge_with_rider_write_type_golden(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"wheels": ("rider", [
        SetCue(1.5, o("lights"), {"led1": (255, 0, 16), "led2": (1, 2, 3)}),
    ])})
    (frame,) = _frames(show)
    assert frame.data == bytes([
        0x55, 0x00,  # header
        0x0E,        # length: 8 + 6 data bytes
        0x01,        # type: write as the Rider's vendor library sends it
        0x69,        # address: led1; the 6 bytes walk led1 (0x69) then led2 (0x6A)
        0xFF, 0x00, 0x10,  # led1 r, g, b
        0x01, 0x02, 0x03,  # led2 r, g, b
        0x72,        # checksum: ~(0x0E + 0x01 + 0x69 + 0xFF + 0x00 + 0x10 + 1 + 2 + 3) & 0xFF
        0x00, 0xAA,  # tail
    ])
    assert frame.label == "led1=#FF0010 led2=#010203"
    assert frame.t == 1.5


def test_small_gap_is_bridged_with_bytes_the_register_already_holds(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # body_z (0x35) and pitch (0x37): roll (0x36) in between still holds its initial 0x80,
    # re-sending that one byte is cheaper than a second 8-byte frame plus 1 ms of silence.
    show = make_show({"rex": ("mini", [SetCue(0.0, o("s"), {"body_z": 75.0, "pitch": 22.0})])})
    (frame,) = _frames(show)
    assert frame.data[3:8] == bytes([0x00, 0x35, 0x00, 0x80, 0xFF])
    assert frame.label == "body_z=75.0mm roll=0.0deg pitch=22.0deg"


def test_gap_over_a_setting_or_hole_is_not_bridged(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # mark_time 0x3C and action 0x3E: pace 0x3D between them is a setting, never re-sent;
    # mark_time and gripper 0x71 are far apart, with unmapped addresses in between.
    show = make_show({"rex": ("mini", [
        SetCue(0.0, o("s"), {"mark_time": 20.0, "gripper": 50.0}),
        ActionCue(0.0, o("a"), 23, "dance", 6.0),
    ])})
    frames = _frames(show)
    assert [f.data[4] for f in frames] == [0x3C, 0x71, 0x3E]
    assert all(len(f.data) == 9 for f in frames)


def test_gap_is_bridged_while_cheaper_than_a_frame(make_show, o) -> None:  # type: ignore[no-untyped-def]
    # vx 0x30 .. mark_time 0x3C: 11 state registers in between. At 115200 baud 11 bytes take
    # 955 us; a separate frame costs 8 bytes (694 us) + 1 ms of silence, so bridging wins.
    show = make_show({"rex": ("mini", [SetCue(0.0, o("s"), {"vx": 5.0, "mark_time": 20.0})])})
    (frame,) = _frames(show)
    assert frame.data[4] == 0x30 and len(frame.data) == 8 + 13
    # With 0.1 ms of silence a frame costs only 794 us: bridging 955 us no longer pays.
    show = make_show({"rex": ("mini", [SetCue(0.0, o("s"), {"vx": 5.0, "mark_time": 20.0})])},
                     gap=0.0001)
    assert [len(f.data) for f in _frames(show)] == [9, 9]


def test_unchanged_samples_are_dropped(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.0, o("slow"), {"body_z": 100.0}, duration=4.0),
    ])})
    frames = _frames(show)
    values = [f.data[5] for f in frames]
    assert all(a != b for a, b in itertools.pairwise(values))
    # 4 s at 50 Hz would be 201 samples; the byte changes far fewer times
    assert len(frames) < 60
    assert values[-1] == get_profile("mini").register("body_z").to_byte(100.0)


def test_settings_and_actions_are_always_sent(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        SetCue(0.0, o("g1"), {"gait": "walk"}),
        SetCue(1.0, o("g2"), {"gait": "walk"}),
        ActionCue(2.0, o("d1"), 23, "dance", 6.0),
        ActionCue(8.0, o("d2"), 23, "dance", 6.0),
    ])})
    frames = _frames(show)
    assert [f.label for f in frames] == ["gait=walk", "gait=walk", "action=23(dance)",
                                         "action=23(dance)"]
    assert [f.duration for f in frames] == [0.0, 0.0, 6.0, 6.0]


def test_samples_sit_on_the_tick_grid_and_settings_at_their_start(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.013, o("m"), {"roll": 10.0}, duration=1.0),
        SetCue(2.345, o("s"), {"pace": "fast"}),
    ])}, control_rate=40.0)
    frames = _frames(show)
    samples = [f for f in frames if f.origin == o("m")]
    assert samples[0].t == pytest.approx(0.025)  # first tick at or after 0.013 s
    for f in samples:
        assert round(f.t * 40_000_000) % 1_000_000 == 0  # a multiple of 1/40 s
    assert frames[-1].t == pytest.approx(2.345)
    assert frames[-1].label == "pace=fast"


def test_fade_steps_end_exactly_and_drop_unchanged(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"wheels": ("rider", [
        FadeCue(0.0, o("f"), "led3", (3, 0, 0), 1.0),
    ])})
    frames = _frames(show)
    colours = [dict(describe_frame(get_profile("rider"), f.data))["led3"] for f in frames]
    assert colours == [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)]


def test_reset_action_returns_posture_start_to_default(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        MotionCue(0.0, o("up"), {"body_z": 115.0}, duration=1.0),
        ActionCue(2.0, o("reset"), 255, "reset", 1.0),
        MotionCue(4.0, o("again"), {"body_z": 115.0}, duration=1.0),
    ])})
    frames = _frames(show)
    again = [f for f in frames if f.origin == o("again")]
    # The second move starts from the default height again, so it really moves.
    assert len(again) > 10
    assert again[0].label == "body_z=97.6mm"


def test_xarm_cue_is_one_servo_move_and_other_cues_are_errors(make_show, o) -> None:  # type: ignore[no-untyped-def]
    from xgo_show.errors import CompileError

    (frame,) = _frames(make_show({"arm": ("xarm", [ArmCue(0.25, o("r"), {2: 300, 1: 500}, 1.2)])}))
    assert frame.data == bytes([
        0x55, 0x55,  # header
        0x0B,        # length: itself, command and 9 parameter bytes
        0x03,        # ServoMove
        0x02,        # two servos
        0xB0, 0x04,  # 1200 ms, little-endian
        0x01, 0xF4, 0x01,  # servo 1 -> 500 (ids in ascending order)
        0x02, 0x2C, 0x01,  # servo 2 -> 300
    ])
    assert frame.t == 0.25 and frame.duration == 1.2
    assert frame.label == "time_ms=1200 servo_1=500 servo_2=300"
    with pytest.raises(CompileError) as err:
        compile_show(make_show({"arm": ("xarm", [SetCue(0.0, o("s", 7), {"gait": "walk"}),
                                                 ArmCue(1.0, o("r", 8), {9: 500}, 1.0)])}))
    messages = [d.message for d in err.value.diagnostics]
    assert messages == ["cue 's': an xArm only takes arm cues", "cue 'r': no xArm servo 9"]
