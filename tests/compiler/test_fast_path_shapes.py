"""The fast road for sample ticks on the shapes the random tracks of test_fast_path rarely
draw: a group of fades (one source over several 3-byte LEDs) sharing ticks with a move, sources
joining and leaving such ticks, several moves at once in both cue orders; both roads must give
the same frames. And what the de-duplication must never drop: a setting sent again, a value
after a preset action (the robot moved on its own)."""

from __future__ import annotations

import dataclasses

import pytest

from tests.compiler.conftest import origin as o
from xgo_show.choreo.resolved import ActionCue, FadeCue, MotionCue, ResolvedTrack, SetCue
from xgo_show.compiler.frames import PlannedFrame, TrackPlan
from xgo_show.compiler.planner import plan_xgo_track
from xgo_show.compiler.state import layout_of
from xgo_show.profiles import get_profile


def _plan(track: ResolvedTrack, *, details: bool) -> TrackPlan:
    profile = get_profile(track.model)
    return plan_xgo_track(layout_of(profile), track, rate=50.0, link=profile.link,
                          gap=profile.link.gap, details=details)


def _essence(f: PlannedFrame) -> tuple[object, ...]:
    return (f.t_us, f.data, f.origin, f.order, f.droppable, f.action, f.duration)


SHAPES = {
    # A group of fades (one origin, start and length: one source of two LEDs) with a move on
    # two registers: every tick is several sources, compared with their previous samples.
    "group and move": ("rider", (
        FadeCue(0.0, o("g", 2), "led1", (255, 0, 0), 2.0),
        FadeCue(0.0, o("g", 2), "led2", (0, 0, 255), 2.0),
        MotionCue(0.0, o("m", 3), {"roll": 8.0, "body_z": 0.07}, 2.0),
    )),
    # Sources joining (a fade from 1 s) and leaving (the move ends first) the shared ticks,
    # then a setting on a faded LED, then the group alone.
    "join and leave": ("rider", (
        FadeCue(0.0, o("g", 2), "led1", (255, 0, 0), 3.0),
        FadeCue(0.0, o("g", 2), "led2", (0, 90, 255), 3.0),
        MotionCue(0.3, o("m", 3), {"roll": -8.0}, 1.0),
        FadeCue(1.0, o("f", 4), "led3", (9, 200, 9), 1.5),
        SetCue(2.0, o("s", 5), {"led4": (1, 2, 3)}),
        MotionCue(2.2, o("n", 6), {"vx": 0.4}, 0.5),
    )),
    # Two moves at once, the later cue on the lower addresses, then the earlier: the frames
    # are filed by cue order, not address.
    "cue order": ("mini", (
        MotionCue(0.0, o("a", 2), {"yaw": 9.0, "pitch": -6.0}, 1.5),
        MotionCue(0.0, o("b", 3), {"body_z": 110.0, "vx": 5.0}, 1.0),
        MotionCue(0.5, o("c", 4), {"roll": 5.0}, 1.0),
        MotionCue(2.0, o("d", 5), {"leg1_x": 10.0}, 1.0),
        MotionCue(2.0, o("e", 6), {"body_y": 5.0, "leg1_z": 80.0}, 1.0),
    )),
    # A source leaving while one live before it stays (roll ends first, body_z and pitch go
    # on with vx, then alone): what roll last held must be known when it fills the gap
    # between body_z and pitch, then and in a later move.
    "leaving from between": ("mini", (
        MotionCue(0.0, o("a", 2), {"body_z": 110.0, "pitch": 8.0}, 3.0),
        MotionCue(0.0, o("b", 3), {"roll": 6.0}, 1.0),
        MotionCue(0.5, o("c", 4), {"vx": 5.0}, 1.5),
        MotionCue(4.0, o("d", 5), {"body_z": 90.0, "pitch": -6.0}, 1.0),
    )),
    # A source whose registers lie far apart (vx and leg1_x: two frames a tick, one lead)
    # beside another: frames of one lead are placed by address.
    "two frames a source": ("mini", (
        MotionCue(0.0, o("a", 2), {"vx": 5.0, "leg1_x": 10.0}, 1.5),
        MotionCue(0.0, o("b", 3), {"yaw": 9.0}, 1.0),
    )),
    # The same with no third source: the move on body_z and pitch is left alone, its own
    # ticks fill roll's gap with what roll last held.
    "left alone": ("mini", (
        MotionCue(0.0, o("a", 2), {"body_z": 110.0, "pitch": 8.0}, 3.0),
        MotionCue(0.0, o("b", 3), {"roll": 6.0}, 1.0),
    )),
    # A move and a fade on the same registers twice, the move's cue first, then the fade's:
    # the planner files the move's samples first both times, but the second time the frames
    # go out in the other cue order (a plan made for the first pair does not serve it).
    "fade listed first": ("rider", (
        MotionCue(0.0, o("m", 2), {"body_z": 100.0}, 1.0),
        FadeCue(0.0, o("f", 3), "led1", (255, 0, 0), 1.0),
        FadeCue(1.5, o("g", 4), "led1", (0, 255, 0), 1.0),
        MotionCue(1.5, o("n", 5), {"body_z": 80.0}, 1.0),
    )),
    # After a preset action nothing is known; fades of led1 and led3 then share ticks with
    # led2 unknown between them (two frames a tick), until a fade of led2 makes it known: from
    # then on one frame carries all three (led2 as that fade left it).
    "known again after an action": ("rider", (
        ActionCue(0.0, o("r", 2), 255, "reset", 1.0),
        FadeCue(1.0, o("x", 3), "led1", (255, 0, 0), 1.0),
        FadeCue(1.0, o("z", 4), "led3", (0, 0, 255), 1.0),
        FadeCue(1.4, o("y", 5), "led2", (0, 200, 0), 0.2),
    )),
    # The same move again and again: from the second on, a stretch finds the plan of every
    # tick's change code made already (none left to make).
    "the same move again": ("mini", (
        MotionCue(0.0, o("a", 2), {"body_z": 110.0}, 1.0),
        MotionCue(1.0, o("b", 3), {"body_z": 80.0}, 1.0),
        MotionCue(2.0, o("c", 4), {"body_z": 110.0}, 1.0),
    )),
    # The same for a move beside a group of fades: every channel changes every tick, both
    # ways, and the move's bytes change in the same ticks each time.
    "the same pair again": ("rider", (
        FadeCue(0.0, o("g", 2), "led1", (200, 200, 200), 1.0),
        FadeCue(0.0, o("g", 2), "led2", (200, 0, 200), 1.0),
        MotionCue(0.0, o("m", 3), {"roll": 8.0}, 1.0),
        FadeCue(1.0, o("h", 4), "led1", (0, 0, 0), 1.0),
        FadeCue(1.0, o("h", 4), "led2", (0, 0, 0), 1.0),
        MotionCue(1.0, o("n", 5), {"roll": 0.0}, 1.0),
        FadeCue(2.0, o("i", 6), "led1", (200, 200, 200), 1.0),
        FadeCue(2.0, o("i", 6), "led2", (200, 0, 200), 1.0),
        MotionCue(2.0, o("p", 7), {"roll": 8.0}, 1.0),
    )),
}


@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_crowded_shapes_give_the_same_frames_on_both_roads(shape: str) -> None:
    model, cues = SHAPES[shape]
    track = ResolvedTrack("p", model, cues)
    reference = _plan(track, details=True)
    fast = _plan(track, details=False)
    assert len(fast.frames) > 20
    assert [_essence(f) for f in fast.frames] == [_essence(f) for f in reference.frames]
    assert fast.samples == reference.samples
    assert {f.origin for f in fast.frames} <= {c.origin for c in cues}


def test_a_setting_sent_again_is_sent_again() -> None:
    # Settings are commands, not samples: the same value twice goes out twice.
    track = ResolvedTrack("p", "mini", (
        SetCue(0.0, o("a"), {"gait": "trot"}),
        SetCue(1.0, o("b"), {"gait": "trot"}),
    ))
    for details in (True, False):
        frames = _plan(track, details=details).frames
        assert [(f.t_us, f.origin) for f in frames] == [(0, o("a")), (1_000_000, o("b"))]
        assert frames[0].data == frames[1].data


def test_after_a_preset_action_a_value_is_sent_even_if_sent_before() -> None:
    # The action moves the robot on its own: the setting before it no longer holds.
    track = ResolvedTrack("p", "mini", (
        SetCue(0.0, o("a"), {"pitch": 4.0}),
        ActionCue(1.0, o("w"), 13, "wave", 2.0),
        MotionCue(4.0, o("m"), {"pitch": 4.0}, 1.0),
    ))
    for details in (True, False):
        frames = _plan(track, details=details).frames
        after = [f for f in frames if f.origin == o("m")]
        assert after and after[0].t_us == 4_000_000


def test_the_frames_holding_only_samples_are_counted_exactly() -> None:
    # A move alone: every frame is its samples; a setting's frame is not one.
    move = MotionCue(0.0, o("m"), {"body_z": 110.0}, 1.0)
    alone = ResolvedTrack("p", "mini", (move,))
    with_setting = ResolvedTrack("p", "mini", (move, SetCue(3.0, o("s"), {"gait": "trot"})))
    for details in (True, False):
        plan = _plan(alone, details=details)
        assert plan.samples == len(plan.frames) > 10
        plan = _plan(with_setting, details=details)
        assert plan.samples == len(plan.frames) - 1


def test_a_register_between_two_moved_ones_is_filled_with_what_it_holds() -> None:
    # roll (0x36) lies between body_z and pitch: one frame carries all three, roll with its
    # initial value (what the robot holds), on both roads.
    mini = get_profile("mini")
    roll = mini.register("roll")
    track = ResolvedTrack("p", "mini", (MotionCue(0.0, o("m"), {"body_z": 110.0,
                                                               "pitch": -6.0}, 1.0),))
    for details in (True, False):
        first = _plan(track, details=details).frames[0].data
        assert first[4] == mini.register("body_z").address and first[2] == len(first) == 8 + 3
        assert first[6:7] == roll.initial


def test_a_profile_without_preset_actions_plans_its_moves() -> None:
    # A robot model (a profile made for it) need not have the action register.
    mini = get_profile("mini")
    bare = dataclasses.replace(mini, model="bare", registers=tuple(
        r for r in mini.registers if r.name != "action"))
    track = ResolvedTrack("p", "bare", (MotionCue(0.0, o("m"), {"body_z": 110.0}, 1.0),))
    frames = [
        plan_xgo_track(layout_of(bare), track, rate=50.0, link=bare.link, gap=bare.link.gap,
                       details=details).frames
        for details in (True, False)
    ]
    assert [_essence(f) for f in frames[0]] == [_essence(f) for f in frames[1]]
    assert len(frames[0]) > 10
