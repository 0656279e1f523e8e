"""Planning an xArm performer (compiler/xarm.py): one ServoMove per arm cue, and reading it back."""

from __future__ import annotations

import pytest

from xgo_show.choreo.resolved import ActionCue, ArmCue, ResolvedTrack
from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.compiler.xarm import (
    MAX_MOVE_MS,
    describe_xarm_frame,
    plan_xarm_track,
    xarm_frames_to_reach,
    xarm_state_at,
)
from xgo_show.diagnostics import Origin
from xgo_show.errors import ProtocolError
from xgo_show.profiles import get_profile
from xgo_show.wire.xarm import encode_packet, servo_move

XARM = get_profile("xarm")


def _o(line: int, cue: str = "") -> Origin:
    return Origin("arm.yaml", line, 3, cue)


def _plan(*cues: object):  # type: ignore[no-untyped-def]
    return plan_xarm_track(XARM, ResolvedTrack("arm", "xarm", cues))  # type: ignore[arg-type]


def test_one_servo_move_per_arm_cue_in_time_order() -> None:
    plan = _plan(ArmCue(1.5, _o(2), {6: 900, 1: 100}, 0.5),
                 ArmCue(0.25, _o(3), {3: 500}, 2.0),
                 ArmCue(1.5, _o(4), {2: 0}, 0.0))  # fmt: skip
    assert plan.diagnostics == [] and plan.samples == 0
    assert [(f.t_us, f.order) for f in plan.frames] == [(250_000, 1), (1_500_000, 0),
                                                         (1_500_000, 2)]  # fmt: skip
    first, second, third = plan.frames
    assert first.data == servo_move(2000, {3: 500})
    assert second.data == servo_move(500, {1: 100, 6: 900})  # servos in id order
    assert third.data == servo_move(0, {2: 0})
    assert (second.origin, second.duration, second.droppable, second.action) == (
        _o(2), 0.5, False, False)
    assert (second.fields, second.written) == ((), ())
    assert plan.end == 2.25  # the latest move's end, not the last cue's


def test_a_move_of_any_length_up_to_65535_ms() -> None:
    plan = _plan(ArmCue(0.0, _o(2), {1: 500}, MAX_MOVE_MS / 1000))
    assert plan.diagnostics == [] and plan.frames[0].data == servo_move(65535, {1: 500})
    assert MAX_MOVE_MS == 65535


@pytest.mark.parametrize(("cue", "message"), [
    (ActionCue(0.0, _o(7, "bow"), 1, "bow", 1.0), "cue 'bow': an xArm only takes arm cues"),
    (ArmCue(0.0, _o(7), {1: 500}, 65.536), "the cue at line 7: an xArm move takes 0..65535 ms, "
     "not 65536 ms"),
    (ArmCue(0.0, _o(7), {1: 500}, -0.001), "an xArm move takes 0..65535 ms, not -1 ms"),
    (ArmCue(0.0, _o(7), {9: 500, 7: 1, 1: 2}, 1.0), "the cue at line 7: no xArm servo 7"),
    (ArmCue(0.0, _o(7, "reach"), {1: 1001}, 1.0), "cue 'reach': "),
])  # fmt: skip
def test_what_an_xarm_cannot_do_is_an_error_and_the_rest_is_planned(
    cue: object, message: str
) -> None:
    ok = ArmCue(2.0, _o(9), {1: 500}, 1.0)
    plan = _plan(cue, ok)
    (diag,) = plan.diagnostics
    assert diag.severity == "error" and message in diag.message
    assert diag.origin == cue.origin  # type: ignore[attr-defined]
    assert diag.path == "tracks.arm"
    assert [f.data for f in plan.frames] == [servo_move(1000, {1: 500})]
    assert plan.end == 3.0


def test_an_empty_track_ends_at_zero() -> None:
    plan = _plan()
    assert (plan.frames, plan.end, plan.diagnostics) == ([], 0.0, [])


def test_describe_reads_a_servo_move_back() -> None:
    assert describe_xarm_frame(servo_move(1500, {6: 900, 1: 100})) == [
        ("time_ms", 1500), ("servo_1", 100), ("servo_6", 900)]  # fmt: skip
    with pytest.raises(ProtocolError, match="not a single xArm packet: 55 55"):
        describe_xarm_frame(servo_move(10, {1: 1}) + b"\x55\x55")
    with pytest.raises(ProtocolError, match="not a single xArm packet"):
        describe_xarm_frame(servo_move(10, {1: 1})[:-1])
    with pytest.raises(ProtocolError, match="not an xArm ServoMove: 55 55 02 0f"):
        describe_xarm_frame(encode_packet(15))


def test_state_is_the_last_target_of_each_servo_moved_by_then() -> None:
    frames = [ScheduledFrame(0.0, servo_move(500, {1: 100, 2: 200})),
              ScheduledFrame(1.0, servo_move(500, {2: 700})),
              ScheduledFrame(2.0, servo_move(500, {1: 1000}))]  # fmt: skip
    assert xarm_state_at(frames, -0.1) == {}
    assert xarm_state_at(frames, 0.0) == {"servo_1": (100).to_bytes(2, "little"),
                                          "servo_2": (200).to_bytes(2, "little")}  # fmt: skip
    assert xarm_state_at(frames, 1.0)["servo_2"] == b"\xbc\x02"  # 700, from the move at 1.0
    assert xarm_state_at(frames, 1.99) == {"servo_1": b"\x64\x00", "servo_2": b"\xbc\x02"}
    assert xarm_state_at(frames, 5.0) == {"servo_1": b"\xe8\x03", "servo_2": b"\xbc\x02"}


def test_reaching_a_state_is_one_move_of_the_given_time() -> None:
    state = {"servo_6": (900).to_bytes(2, "little"), "servo_1": (5).to_bytes(2, "little"),
             "battery": b"\x00\x00"}  # fmt: skip
    (frame,) = xarm_frames_to_reach(XARM, state, move_time=1.2345)
    assert frame.data == servo_move(1234, {1: 5, 6: 900})  # servos in id order, ms rounded
    assert (frame.t, frame.duration) == (0.0, 1.2345)
    assert frame.label  # labelled from its bytes
    assert xarm_frames_to_reach(XARM, {}, move_time=1.0) == []
    assert xarm_frames_to_reach(XARM, {"battery": b"\x01\x02"}, move_time=1.0) == []
