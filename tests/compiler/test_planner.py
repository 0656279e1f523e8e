"""The planner's plan of one XGO performer, tick by tick, on small hand-made tracks: what each
cue files at which microsecond (register, bytes, cue, sample or not), the state the next cue
starts from, and each refusal word for word.

The other planner tests compare the planner with itself (grouped fades with fades one by one,
the fast road with the general one); these state the plan itself. Moves are compared with
ruckig's trajectory read at each tick through :meth:`Register.to_byte` (not the byte tables the
planner bisects); fades and settings with values counted by hand.
"""

from __future__ import annotations

import dataclasses

import pytest

from tests.compiler.conftest import origin
from xgo_show.choreo.resolved import (
    ActionCue,
    ArmCue,
    Cue,
    FadeCue,
    MotionCue,
    ResolvedTrack,
    SetCue,
)
from xgo_show.compiler.frames import first_tick, tick_us
from xgo_show.compiler.planner import (
    XgoPlanner,
    _Fade,
    _limits_text,
    _round_up,
    _too_short,
    plan_xgo_track,
)
from xgo_show.compiler.sources import Samples, entry_writes
from xgo_show.compiler.state import layout_of
from xgo_show.compiler.trajectory import DofState, plan_motion
from xgo_show.errors import InfeasibleMotion
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Limits, Profile

MINI = get_profile("mini")
RIDER = get_profile("rider")
ROLL, BODY_Z, LED1, LED2 = 0x36, 0x35, 0x69, 0x6A

# One filed write: (address, bytes, cue name, cue order, sample, action duration).
Filed = tuple[int, bytes, str, int, bool, float]


def _planned(model: str, *cues: Cue, rate: float = 50.0) -> XgoPlanner:
    planner = XgoPlanner(layout_of(get_profile(model)), ResolvedTrack("p", model, cues), rate)
    planner.plan()
    return planner


def _filed(planner: XgoPlanner) -> dict[int, list[Filed]]:
    """Every tick's writes, in the order filed."""
    return {t_us: [(w.address, w.data, w.origin.cue if w.origin else "", w.order, w.sample,
                    w.duration) for w in entry_writes(entry)]
            for t_us, entry in sorted(planner.ticks.items())}


def _winners(planner: XgoPlanner, t_us: int) -> dict[int, tuple[bytes, str]]:
    """What goes out at a tick, register by register: the write of the latest cue there (a
    later cue's write of a register wins its tick), with that cue's name."""
    out: dict[int, tuple[int, bytes, str]] = {}
    for address, data, name, order, _, _ in _filed(planner)[t_us]:
        if address not in out or order >= out[address][0]:
            out[address] = (order, data, name)
    return {address: (data, name) for address, (_, data, name) in sorted(out.items())}


def _errors(planner: XgoPlanner) -> list[str]:
    return [d.format() for d in planner.diag.items]


def _move_reference(regs: list[str], start: float, current: list[DofState],
                    targets: list[float], duration: float | None, rate: float,
                    until: float | None = None, profile: Profile = MINI) -> dict[int, bytes]:
    """A move's samples as the plan must have them: ruckig's position at each tick from the
    first at or after the start, read through Register.to_byte, then the exact targets at the
    end itself (none when ``until`` cuts it: the ticks before that only)."""
    limits = [_limits(n, profile) for n in regs]
    plan = plan_motion(regs, start, current, targets, limits, duration)
    stop = plan.end if until is None else until
    out: dict[int, bytes] = {}
    k = first_tick(start, rate)
    while tick_us(k, rate) < round(stop * 1e6):
        t = k / rate
        out[tick_us(k, rate)] = bytes(profile.register(n).to_byte(s.position)
                                      for n, s in zip(regs, plan.state_at(t), strict=True))
        k += 1
    if until is None:
        out[round(plan.end * 1e6)] = bytes(profile.register(n).to_byte(x)
                                           for n, x in zip(regs, targets, strict=True))
    return out


def _limits(name: str, profile: Profile = MINI) -> Limits:
    limits = profile.register(name).limits
    assert limits is not None
    return limits


def _samples_of(planner: XgoPlanner, cue: str, addresses: tuple[int, ...]) -> dict[int, bytes]:
    """The bytes ``cue`` filed at each tick for ``addresses`` (ticks where it wrote them all)."""
    out = {}
    for t_us, writes in _filed(planner).items():
        mine = {a: d for a, d, name, _, _, _ in writes if name == cue}
        if all(a in mine for a in addresses):
            out[t_us] = b"".join(mine[a] for a in addresses)
    return out


# -- settings and actions ---------------------------------------------------------------------


def test_a_setting_goes_out_at_its_start_one_write_a_register_in_address_order() -> None:
    planner = _planned("mini", SetCue(0.5, origin("s"), {"pace": "slow", "body_z": 100.0,
                                                         "gait": "trot"}))
    assert _filed(planner) == {500000: [
        (0x09, MINI.register("gait").encode_value("trot"), "s", 0, False, 0.0),
        (BODY_Z, bytes([MINI.register("body_z").to_byte(100.0)]), "s", 0, False, 0.0),
        (0x3D, MINI.register("pace").encode_value("slow"), "s", 0, False, 0.0),
    ]}
    assert MINI.register("pace").encode_value("slow") == b"\x01"
    assert isinstance(planner.ticks[500000], list) and planner.mixed == set()
    assert planner.end == 0.5 and _errors(planner) == []


def test_an_action_goes_out_at_its_start_with_its_length_and_ends_the_part_after_it() -> None:
    planner = _planned("mini", SetCue(0.0, origin("g"), {"gait": "walk"}),
                       ActionCue(0.3, origin("a"), 13, "wave", 7.0))
    assert _filed(planner)[300000] == [(0x3E, b"\x0d", "a", 1, False, 7.0)]
    assert planner.end == pytest.approx(7.3)
    assert planner.action_ticks == [300000]
    # Out of order (cues of a phrase): the action times are kept sorted.
    late_first = _planned("mini", ActionCue(2.0, origin("b"), 13, "wave", 1.0),
                          ActionCue(1.0, origin("a"), 13, "wave", 1.0),
                          ActionCue(1.5, origin("c"), 13, "wave", 0.1))
    assert late_first.action_ticks == [1000000, 1500000, 2000000]
    assert late_first.end == 3.0  # the latest end, not the last cue's


def test_a_cue_that_fails_files_what_it_encoded_before_and_the_next_cues_are_planned() -> None:
    planner = _planned("mini", SetCue(0.5, origin("s"), {"pace": "bogus", "body_z": 100.0}),
                       SetCue(0.7, origin("t"), {"gait": "walk"}))
    # body_z (0x35) is encoded before pace (0x3d); the failed cue does not move the end.
    assert _filed(planner) == {
        500000: [(BODY_Z, bytes([MINI.register("body_z").to_byte(100.0)]), "s", 0, False, 0.0)],
        700000: [(0x09, MINI.register("gait").encode_value("walk"), "t", 1, False, 0.0)],
    }
    assert _errors(planner) == ["show.yaml:1:5: error: tracks.p: cue 's': pace: unknown value "
                                "'bogus'; one of normal, slow, fast"]
    assert planner.end == 0.7


def test_cues_an_xgo_cannot_play_are_refused_word_for_word() -> None:
    planner = _planned(
        "rider",
        MotionCue(0.0, origin("gait"), {"roll": 2.0, "auto_feedback": 1.0}, 1.0),
        MotionCue(0.0, origin("wave"), {"periodic_roll": 1.5}, 1.0),
        MotionCue(0.0, origin("fast"), {"roll": 2.0}, 1.0,
                  limits={"roll": Limits(1e9, 100.0, 100.0)}),
        FadeCue(0.0, origin("f"), "roll", (1, 2, 3), 1.0),
        FadeCue(0.0, origin("g"), "led1", (256, 2, 3), 1.0),
        ArmCue(0.0, origin("r"), {1: 500}, 1.0),
        SetCue(0.0, origin("s"), {"nothing": 1}),
    )
    assert _errors(planner)[:-1] == [
        "show.yaml:1:5: error: tracks.p: cue 'gait': auto_feedback cannot follow a trajectory",
        "show.yaml:1:5: error: tracks.p: cue 'wave': periodic_roll cannot follow a trajectory",
        "show.yaml:1:5: error: tracks.p: cue 'fast': roll: velocity limit 1e+09 is outside "
        "what the planner handles (0.001 to 1e+07)",
        "show.yaml:1:5: error: tracks.p: roll is not an RGB register; it cannot fade",
        "show.yaml:1:5: error: tracks.p: cue 'g': led1 takes three bytes r, g, b in 0..255",
        "show.yaml:1:5: error: tracks.p: rider is not an xArm; it takes no arm cue",
    ]
    assert _errors(planner)[-1].startswith("show.yaml:1:5: error: tracks.p: cue 's': rider has "
                                           "no register 'nothing'; valid: action, ")
    assert planner.ticks == {} and planner.runs == [] and planner.fades == []
    assert planner.end == 0.0
    assert {d.severity for d in planner.diag.items} == {"error"}


def test_a_profile_without_the_action_register_refuses_actions() -> None:
    bare = dataclasses.replace(MINI, registers=tuple(r for r in MINI.registers
                                                     if r.name != "action"))
    track = ResolvedTrack("p", "mini", (ActionCue(1.0, origin("a"), 13, "wave", 7.0),))
    planner = XgoPlanner(layout_of(bare), track, 50.0)
    planner.plan()
    assert _errors(planner) == ["show.yaml:1:5: error: tracks.p: mini has no action register"]
    assert planner.ticks == {} and planner.end == 0.0


# -- moves ------------------------------------------------------------------------------------


def test_a_move_is_sampled_on_the_grid_and_ends_with_its_targets_at_its_end() -> None:
    # Off the grid (0.01 s), registers given out of address order.
    cue = MotionCue(0.01, origin("m"), {"roll": 3.0, "body_z": 100.0}, 0.5)
    planner = _planned("mini", cue)
    rest = [DofState(MINI.register(n).to_physical(0x80)) for n in ("body_z", "roll")]
    expected = _move_reference(["body_z", "roll"], 0.01, rest, [100.0, 3.0], 0.5, 50.0)
    assert min(expected) == 20000 and max(expected) == 510000
    assert _samples_of(planner, "m", (BODY_Z, ROLL)) == expected
    assert set(planner.ticks) == set(expected)
    # One source a tick: its registers in address order, samples, the cue's order.
    for entry in planner.ticks.values():
        assert isinstance(entry, tuple)
        src, _ = entry
        assert (src.addresses, src.origin, src.order) == ((BODY_Z, ROLL), origin("m"), 0)
    assert [w[4] for ws in _filed(planner).values() for w in ws] == [True] * 2 * len(expected)
    assert planner.end == pytest.approx(0.51) and planner.mixed == set()
    assert planner.commanded["roll"] == 3.0 and planner.commanded["body_z"] == 100.0


@pytest.mark.parametrize("rate", [50.0, 60.0, 7.0])
def test_move_samples_at_other_rates_and_starts_off_the_grid(rate: float) -> None:
    cue = MotionCue(0.123, origin("m"), {"pitch": -10.0}, 0.9)
    planner = _planned("mini", cue, rate=rate)
    rest = [DofState(0.0)]
    assert MINI.register("pitch").to_physical(0x80) == 0.0
    expected = _move_reference(["pitch"], 0.123, rest, [-10.0], 0.9, rate)
    assert _samples_of(planner, "m", (0x37,)) == expected


def test_a_move_ending_a_hair_past_a_tick_sends_its_targets_there_once() -> None:
    # 0.2 + 0.8000000001: the end rounds to the microsecond of tick 50 (1.0 s), where the
    # targets go out, and not a sample first.
    cue = MotionCue(0.2, origin("m"), {"roll": 5.0}, 0.8000000001)
    planner = _planned("mini", cue)
    assert _samples_of(planner, "m", (ROLL,)) == _move_reference(
        ["roll"], 0.2, [DofState(0.0)], [5.0], 0.8000000001, 50.0)
    assert max(planner.ticks) == 1000000 and 980000 in planner.ticks
    assert planner.ticks[1000000][1] == bytes([MINI.register("roll").to_byte(5.0)])
    assert isinstance(planner.ticks[1000000], tuple) and planner.mixed == set()


def test_a_move_that_cannot_be_met_names_the_slowest_register_and_its_limits() -> None:
    # body_z comes first in address order, roll is the one that cannot make it: alone it
    # needs 0.688 s (body_z 0.187 s), said rounded up.
    planner = _planned("mini", MotionCue(0.0, origin("m"), {"roll": 20.0, "body_z": 98.0},
                                         0.3))
    assert _errors(planner) == [
        "show.yaml:1:5: error: tracks.p: the move to roll 20, body_z 98 needs at least 0.69 s "
        "under its limits (roll: velocity 60 deg/s, acceleration 300 deg/s², jerk 2000 "
        "deg/s³) but is given 0.30 s"]
    assert planner.ticks == {} and planner.end == 0.0
    # The cue's own limits, not the register's.
    slow = Limits(10.0, 300.0, 2000.0)
    planner = _planned("mini", MotionCue(0.0, origin("m"), {"roll": 20.0}, 1.0,
                                         limits={"roll": slow}))
    assert _errors(planner)[0].endswith(
        "(roll: velocity 10 deg/s, acceleration 300 deg/s², jerk 2000 deg/s³) but is given "
        "1.00 s")


def test_too_short_says_beats_and_segments_rounded_up() -> None:
    roll = MINI.register("roll")
    assert roll.limits is not None
    cue = MotionCue(0.0, origin("m"), {"roll": 20.0, "pitch": -3.5}, 0.25, segment=(2, 3),
                    given=(0.5, "beats"))
    exc = InfeasibleMotion(0.6312, 0, 0.25)
    assert _too_short(cue, roll, roll.limits, exc) == (
        "segment 2 of 3 of the move (to roll 20, pitch -3.5) needs at least 0.64 s (1.27 beats) "
        "under its limits (roll: velocity 60 deg/s, acceleration 300 deg/s², jerk 2000 deg/s³) "
        "but is given 0.5 beats (0.25 s)")
    # Given in seconds: said in seconds only; given no time at all: no unit to convert.
    plain = dataclasses.replace(cue, segment=(1, 1), given=None)
    assert _too_short(plain, roll, roll.limits, exc) == (
        "the move to roll 20, pitch -3.5 needs at least 0.64 s under its limits (roll: "
        "velocity 60 deg/s, acceleration 300 deg/s², jerk 2000 deg/s³) but is given 0.25 s")
    zero = InfeasibleMotion(0.6312, 0, 0.0)
    assert _too_short(cue, roll, roll.limits, zero).endswith("but is given 0.00 s")
    assert "beats" not in _too_short(cue, roll, roll.limits, zero)
    unitless = dataclasses.replace(roll, unit=None)
    assert _limits_text(unitless, Limits(1.5, 2.0, 3.0)) == (
        "velocity 1.5 units/s, acceleration 2 units/s², jerk 3 units/s³")


def test_round_up_is_to_the_next_hundredth_ignoring_float_noise() -> None:
    assert _round_up(0.5) == 0.5
    assert _round_up(0.5000005) == 0.5  # float noise of under a microsecond
    assert _round_up(0.500002) == 0.51
    assert _round_up(0.501) == 0.51
    assert _round_up(0.509) == 0.51
    assert _round_up(0.0) == 0.0
    assert _round_up(1.2345) == 1.24


def test_a_setting_cuts_the_move_on_its_register_and_the_next_move_starts_from_it() -> None:
    planner = _planned(
        "mini",
        MotionCue(0.0, origin("m"), {"roll": 3.0, "body_z": 100.0}, 0.5),
        SetCue(0.2, origin("s"), {"roll": -3.0}),
        SetCue(0.4, origin("t"), {"roll": -3.0}),  # the move is cut already: stays cut at 0.2
        MotionCue(0.6, origin("n"), {"roll": -1.0}, 0.5),
    )
    filed = _filed(planner)
    rest = [DofState(MINI.register(n).to_physical(0x80)) for n in ("body_z", "roll")]
    both = _move_reference(["body_z", "roll"], 0.0, rest, [100.0, 3.0], 0.5, 50.0)
    # roll's samples stop before the setting; body_z goes on to its target.
    assert _samples_of(planner, "m", (BODY_Z, ROLL)) == {t: s for t, s in both.items()
                                                         if t < 200000}
    assert _samples_of(planner, "m", (BODY_Z,)) == {t: s[:1] for t, s in both.items()}
    assert all(ROLL not in [w[0] for w in filed[t] if w[2] == "m"] for t in both
               if t >= 200000)
    # At the setting's tick, the setting (filed as it is planned) and body_z's sample (moves
    # are sampled after every cue is planned): two cues, mixed.
    assert filed[200000] == [
        (ROLL, bytes([MINI.register("roll").to_byte(-3.0)]), "s", 1, False, 0.0),
        (BODY_Z, both[200000][:1], "m", 0, True, 0.0)]
    assert 200000 in planner.mixed
    # The next move starts from the setting's value, at rest.
    after = _move_reference(["roll"], 0.6, [DofState(-3.0)], [-1.0], 0.5, 50.0)
    assert _samples_of(planner, "n", (ROLL,)) == after
    assert planner.runs[0].cuts == [None, 0.2]
    assert _errors(planner) == [] and planner.end == pytest.approx(1.1)


def test_a_move_interrupting_a_move_starts_where_and_how_fast_it_was() -> None:
    first = MotionCue(0.0, origin("m"), {"roll": 10.0}, 1.0)
    second = MotionCue(0.4, origin("n"), {"roll": -2.0}, 1.0)
    planner = _planned("mini", first, second)
    plan = plan_motion(["roll"], 0.0, [DofState(0.0)], [10.0], [_limits("roll")], 1.0)
    (reached,) = plan.state_at(0.4)
    assert reached.velocity > 1.0  # under way
    assert _samples_of(planner, "m", (ROLL,)) == _move_reference(
        ["roll"], 0.0, [DofState(0.0)], [10.0], 1.0, 50.0, until=0.4)
    assert _samples_of(planner, "n", (ROLL,)) == _move_reference(
        ["roll"], 0.4, [reached], [-2.0], 1.0, 50.0)
    assert planner.mixed == set() and planner.end == pytest.approx(1.4)
    # A move that has ended is not taken over: the next starts from its target at rest.
    later = _planned("mini", first, dataclasses.replace(second, start=1.0))
    assert _samples_of(later, "n", (ROLL,)) == _move_reference(
        ["roll"], 1.0, [DofState(10.0)], [-2.0], 1.0, 50.0)
    assert later.runs[0].cuts == [None]
    # ... and its target at 1.0 s and the next move's first sample share that tick: the
    # later cue's goes out.
    assert _winners(later, 1000000) == {
        ROLL: (bytes([MINI.register("roll").to_byte(10.0)]), "n")}


def test_an_action_cuts_the_moves_under_way_and_later_moves_start_where_they_stopped() -> None:
    planner = _planned(
        "mini",
        MotionCue(0.0, origin("m"), {"roll": 10.0}, 1.0),
        MotionCue(0.0, origin("z"), {"body_z": 100.0}, 0.45),
        ActionCue(0.5, origin("a"), 13, "wave", 0.5),
        MotionCue(1.2, origin("n"), {"roll": 0.0}, 1.0),
    )
    plan = plan_motion(["roll"], 0.0, [DofState(0.0)], [10.0], [_limits("roll")], 1.0)
    (reached,) = plan.state_at(0.5)
    assert _samples_of(planner, "m", (ROLL,)) == _move_reference(
        ["roll"], 0.0, [DofState(0.0)], [10.0], 1.0, 50.0, until=0.5)
    assert _filed(planner)[500000] == [(0x3E, b"\x0d", "a", 2, False, 0.5)]
    # The next move starts from where roll was stopped, at rest; body_z had arrived.
    assert _samples_of(planner, "n", (ROLL,)) == _move_reference(
        ["roll"], 1.2, [DofState(reached.position)], [0.0], 1.0, 50.0)
    assert planner.commanded["body_z"] == 100.0 and _errors(planner) == []
    assert planner.runs[1].cuts == [None] and planner.runs[0].cuts == [0.5]


# -- fades ------------------------------------------------------------------------------------


def _colours(planner: XgoPlanner, cue: str, address: int = LED1) -> dict[int, tuple[int, ...]]:
    return {t: tuple(data) for t, writes in _filed(planner).items()
            for a, data, name, *_ in writes if name == cue and a == address}


def test_a_slow_fade_files_each_colour_once_where_it_begins() -> None:
    # (0,0,0) to (3,0,0) over 1 s at 50 Hz: round(3 k / 50) steps at k = 9 (0.54 -> 1),
    # 25 (1.5 -> 2) and 42 (2.52 -> 3); the exact colour again at the end itself.
    planner = _planned("rider", FadeCue(0.0, origin("f"), "led1", (3, 0, 0), 1.0))
    assert _colours(planner, "f") == {0: (0, 0, 0), 180000: (1, 0, 0), 500000: (2, 0, 0),
                                      840000: (3, 0, 0), 1000000: (3, 0, 0)}
    assert all(w[4] and w[3] == 0 for ws in _filed(planner).values() for w in ws)
    assert planner.end == 1.0 and planner.colours["led1"] == (3, 0, 0)
    # Green and blue too, each channel its own steps, from a colour a setting gave.
    planner = _planned("rider", SetCue(0.0, origin("s"), {"led1": (10, 4, 200)}),
                       FadeCue(0.2, origin("f"), "led1", (10, 6, 197), 1.0))
    # From tick 10, the fraction is (k - 10) / 50: blue 200 - 3 f passes 199.5 at k = 19,
    # 198.5 at 35 (round half to even: 198) and 197.5 at 52; green 4 + 2 f passes 4.5 at 23
    # and 5.5 at 48.
    assert _colours(planner, "f") == {
        200000: (10, 4, 200), 380000: (10, 4, 199), 460000: (10, 5, 199),
        700000: (10, 5, 198), 960000: (10, 6, 198), 1040000: (10, 6, 197),
        1200000: (10, 6, 197)}


def test_a_quick_fade_files_the_colour_of_each_tick_that_changes() -> None:
    # Over 0.1 s: 5 ticks of 0, 0.2, 0.4, 0.6 and 0.8 of the way.
    planner = _planned("rider", FadeCue(0.0, origin("f"), "led1", (255, 0, 100), 0.1))
    assert _colours(planner, "f") == {0: (0, 0, 0), 20000: (51, 0, 20), 40000: (102, 0, 40),
                                      60000: (153, 0, 60), 80000: (204, 0, 80),
                                      100000: (255, 0, 100)}
    # A tick repeating the colour before it files nothing: 0, 0.6, 1.2, 1.8, 2.4 round to
    # 0, 1, 1, 2, 2.
    planner = _planned("rider", FadeCue(0.0, origin("f"), "led1", (3, 0, 0), 0.1))
    assert _colours(planner, "f") == {0: (0, 0, 0), 20000: (1, 0, 0), 60000: (2, 0, 0),
                                      100000: (3, 0, 0)}
    # Downwards from a setting's colour, ending off the grid (0.25 s): the end itself, not
    # the tick after it.
    planner = _planned("rider", SetCue(0.0, origin("s"), {"led1": (100, 50, 250)}),
                       FadeCue(0.1, origin("f"), "led1", (0, 0, 0), 0.15))
    assert _colours(planner, "f") == {100000: (100, 50, 250), 120000: (87, 43, 217),
                                      140000: (73, 37, 183), 160000: (60, 30, 150),
                                      180000: (47, 23, 117), 200000: (33, 17, 83),
                                      220000: (20, 10, 50), 240000: (7, 3, 17),
                                      250000: (0, 0, 0)}


def test_a_fade_starting_a_hair_after_a_tick_starts_from_its_first_colour() -> None:
    # first_tick ignores a billionth of a tick: the first tick lies before the start, where
    # the fade has not begun (its fraction clamped to 0, not past the end).
    start = 0.2 + 1e-11
    planner = _planned("rider", FadeCue(start, origin("f"), "led1", (255, 255, 255), 0.1))
    assert _colours(planner, "f")[200000] == (0, 0, 0)
    slow = _planned("rider", FadeCue(start, origin("f"), "led1", (3, 3, 3), 2.0))
    assert _colours(slow, "f")[200000] == (0, 0, 0)


def test_a_fade_of_no_length_sends_its_colour_at_its_start() -> None:
    planner = _planned("rider", FadeCue(0.3, origin("f"), "led1", (1, 2, 3), 0.0))
    assert _filed(planner) == {300000: [(LED1, b"\x01\x02\x03", "f", 0, True, 0.0)]}
    assert planner.end == 0.3


def test_a_fade_cut_stops_before_the_cut_and_the_next_starts_from_the_colour_reached() -> None:
    # (10, 200, 40) -> (110, 0, 40) over 2 s, cut at 1 s: half way, (60, 100, 40).
    planner = _planned(
        "rider",
        SetCue(0.0, origin("s"), {"led1": (10, 200, 40)}),
        FadeCue(0.0, origin("f"), "led1", (110, 0, 40), 2.0),
        FadeCue(1.0, origin("g"), "led1", (60, 100, 50), 0.1),
    )
    f, g = _colours(planner, "f"), _colours(planner, "g")
    assert max(f) < 1000000 and f[0] == (10, 200, 40)
    assert g == {1000000: (60, 100, 40), 1020000: (60, 100, 42), 1040000: (60, 100, 44),
                 1060000: (60, 100, 46), 1080000: (60, 100, 48), 1100000: (60, 100, 50)}
    assert planner.fades[0].cut == 1.0 and planner.fades[1].cut is None
    assert planner.fades[0].colour_at(1.0) == (60, 100, 40)
    # A setting cuts it too; the fade after that starts from the setting's colour.
    planner = _planned(
        "rider",
        FadeCue(0.0, origin("f"), "led1", (110, 0, 40), 2.0),
        SetCue(0.5, origin("s"), {"led1": (7, 7, 7)}),
        FadeCue(0.6, origin("g"), "led1", (7, 7, 9), 0.04),
    )
    assert max(_colours(planner, "f")) < 500000
    assert _colours(planner, "g") == {600000: (7, 7, 7), 620000: (7, 7, 8), 640000: (7, 7, 9)}
    # A cue at (or after) a fade's end does not cut it: it sends its final colour.
    planner = _planned(
        "rider",
        FadeCue(0.0, origin("f"), "led1", (4, 0, 0), 0.1),
        SetCue(0.1, origin("s"), {"led1": (9, 9, 9)}),
        FadeCue(0.1, origin("g"), "led1", (9, 9, 9), 0.1),
    )
    assert planner.fades[0].cut is None
    # (the setting is filed as it is planned, the fades' samples after every cue)
    assert _filed(planner)[100000] == [(LED1, b"\x09\x09\x09", "s", 1, False, 0.0),
                                       (LED1, b"\x04\x00\x00", "f", 0, True, 0.0),
                                       (LED1, b"\x09\x09\x09", "g", 2, True, 0.0)]
    assert 100000 in planner.mixed


def test_a_fade_cut_twice_keeps_its_first_cut() -> None:
    planner = _planned(
        "rider",
        FadeCue(0.0, origin("f"), "led1", (200, 0, 0), 2.0),
        SetCue(0.5, origin("s"), {"led1": (0, 0, 9)}),
        SetCue(1.0, origin("t"), {"led1": (0, 0, 8)}),
    )
    assert planner.fades[0].cut == 0.5
    assert max(_colours(planner, "f")) == 480000


def test_fade_colour_at_is_clamped_to_its_span() -> None:
    fade = _Fade(FadeCue(1.0, origin("f"), "led1", (100, 50, 0), 2.0), 0,
                 RIDER.register("led1"), (0, 250, 10))
    assert fade.colour_at(0.0) == (0, 250, 10)
    assert fade.colour_at(1.5) == (25, 200, 8)
    assert fade.colour_at(3.0) == fade.colour_at(9.0) == (100, 50, 0)
    instant = _Fade(FadeCue(1.0, origin("f"), "led1", (100, 50, 0), 0.0), 0,
                    RIDER.register("led1"), (0, 250, 10))
    assert instant.colour_at(1.0) == (100, 50, 0)
    short = _Fade(FadeCue(1.0, origin("f"), "led1", (100, 50, 0), 0.5), 0,
                  RIDER.register("led1"), (0, 250, 10))
    assert short.colour_at(1.25) == (50, 150, 5)


def test_an_hour_long_slow_fade_files_only_its_changes() -> None:
    # 3.6 million ticks at 1000 Hz, 3 colour changes: found by galloping (a tick by tick walk
    # runs for minutes, which the mutation run's timeout catches). Blue is 0.5 at 600 s and
    # 2.5 at 3000 s, rounded to even: the changes come a tick after those; 1.5 at 1800 s.
    planner = _planned("rider", FadeCue(0.0, origin("f"), "led1", (0, 0, 3), 3600.0),
                       rate=1000.0)
    assert _colours(planner, "f") == {0: (0, 0, 0), 600001000: (0, 0, 1),
                                      1800000000: (0, 0, 2), 3000001000: (0, 0, 3),
                                      3600000000: (0, 0, 3)}


# -- several sources at one tick --------------------------------------------------------------


def test_an_led_cue_on_two_leds_files_one_sample_of_both_a_tick() -> None:
    o = origin("glow")
    planner = _planned("rider", FadeCue(0.0, o, "led1", (250, 10, 0), 0.1),
                       FadeCue(0.0, o, "led2", (0, 10, 250), 0.1))
    expected = {0: (0, 0, 0, 0, 0, 0), 20000: (50, 2, 0, 0, 2, 50),
                40000: (100, 4, 0, 0, 4, 100), 60000: (150, 6, 0, 0, 6, 150),
                80000: (200, 8, 0, 0, 8, 200), 100000: (250, 10, 0, 0, 10, 250)}
    for entry in planner.ticks.values():
        assert isinstance(entry, tuple) and entry[0].addresses == (LED1, LED2)
        assert (entry[0].origin, entry[0].order) == (o, 0)
    # After another fade (the group is not the first fade of the track): the same.
    after = _planned("rider", FadeCue(0.0, origin("other"), "led3", (1, 1, 1), 0.0),
                     FadeCue(0.0, o, "led1", (250, 10, 0), 0.1),
                     FadeCue(0.0, o, "led2", (0, 10, 250), 0.1))
    entry = after.ticks[20000]
    assert isinstance(entry, tuple) and entry[0].addresses == (LED1, LED2)
    assert {t: entry[1] for t, entry in planner.ticks.items()
            } == {t: bytes(c) for t, c in expected.items()}


def test_fades_of_one_cue_that_differ_are_sampled_each_alone() -> None:
    o = origin("glow")
    base = (FadeCue(0.0, o, "led1", (250, 10, 0), 0.1), FadeCue(0.0, o, "led2", (0, 10, 250), 0.1))
    variants = {
        "start": (base[0], dataclasses.replace(base[1], start=0.02)),
        "length": (base[0], dataclasses.replace(base[1], duration=0.12)),
        "origin": (base[0], dataclasses.replace(base[1], origin=origin("other"))),
        "order": (base[0], SetCue(0.0, o, {"led3": (1, 1, 1)}), base[1]),
        "address order": base[::-1],
        # Slow fades (a colour held for ticks): each alone, galloping over its runs.
        "slow": (dataclasses.replace(base[0], to=(3, 0, 0), duration=1.0),
                 dataclasses.replace(base[1], to=(0, 0, 3), duration=1.0)),
    }
    for what, cues in variants.items():
        planner = _planned("rider", *cues)
        sources = {len(e[0].addresses) for e in planner.ticks.values()
                   if isinstance(e, tuple)}
        sources |= {len(s.addresses) for e in planner.ticks.values()
                    if isinstance(e, Samples) for s, _ in e}
        assert sources == {1}, what
    # A cut fade is sampled alone too (it stops at its cut).
    planner = _planned("rider", *base, SetCue(0.04, origin("s"), {"led2": (1, 1, 1)}))
    assert _colours(planner, "glow", LED1)[100000] == (250, 10, 0)
    assert max(_colours(planner, "glow", LED2)) == 20000


def test_a_fade_beside_a_move_shares_its_ticks_as_two_sources() -> None:
    planner = _planned("rider", MotionCue(0.0, origin("m"), {"roll": 5.0}, 0.5),
                       FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 0.1))
    for t in (0, 20000, 40000, 60000, 80000):
        entry = planner.ticks[t]
        assert isinstance(entry, Samples)
        assert [(src.addresses, src.origin) for src, _ in entry] == [
            ((ROLL,), origin("m")), ((LED1,), origin("f"))]
    assert _colours(planner, "f") == {0: (0, 0, 0), 20000: (51, 0, 0), 40000: (102, 0, 0),
                                      60000: (153, 0, 0), 80000: (204, 0, 0),
                                      100000: (255, 0, 0)}
    assert isinstance(planner.ticks[120000], tuple) and planner.mixed == set()
    # A slow fade beside it too (its changes filed tick by tick among the move's).
    planner = _planned("rider", MotionCue(0.0, origin("m"), {"roll": 5.0}, 0.5),
                       FadeCue(0.0, origin("f"), "led1", (2, 0, 0), 1.0))
    assert _colours(planner, "f") == {0: (0, 0, 0), 260000: (1, 0, 0), 760000: (2, 0, 0),
                                      1000000: (2, 0, 0)}
    assert isinstance(planner.ticks[260000], Samples)
    # Two fades and a move: three sources at a tick.
    planner = _planned("rider", MotionCue(0.0, origin("m"), {"roll": 5.0}, 0.5),
                       FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 0.1),
                       FadeCue(0.0, origin("g"), "led2", (0, 255, 0), 0.1))
    entry = planner.ticks[20000]
    assert isinstance(entry, Samples)
    assert [src.origin.cue for src, _ in entry if src.origin] == ["m", "f", "g"]
    assert _colours(planner, "g", LED2)[20000] == (0, 51, 0)


def test_where_samples_of_one_register_meet_the_later_cues_goes_out() -> None:
    # Two fades of led1 whose ticks meet at 0.1 s (the first's end, the second's start), and
    # a move beside them.
    planner = _planned("rider", MotionCue(0.0, origin("m"), {"roll": 5.0}, 0.5),
                       FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 0.1),
                       FadeCue(0.1, origin("g"), "led1", (0, 0, 255), 0.1))
    roll = _move_reference(["roll"], 0.0, [DofState(0.0)], [5.0], 0.5, 50.0, profile=RIDER)
    assert _winners(planner, 100000) == {ROLL: (roll[100000], "m"),
                                         LED1: (b"\xff\x00\x00", "g")}
    assert _colours(planner, "g")[120000] == (204, 0, 51)
    assert _samples_of(planner, "m", (ROLL,)) == roll
    # Two moves' samples at one tick on one register, and a fade's on another.
    planner = _planned("rider", FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 1.0),
                       MotionCue(0.0, origin("m"), {"roll": 5.0}, 0.5),
                       MotionCue(0.5, origin("n"), {"roll": 0.0}, 0.5))
    assert _winners(planner, 500000) == {
        ROLL: (bytes([RIDER.register("roll").to_byte(5.0)]), "n"),
        LED1: (bytes([round(255 * 0.5), 0, 0]), "f")}


def test_a_move_over_ticks_a_fade_holds_files_its_samples_beside_them() -> None:
    # The fade is planned first (an earlier cue's fades are sampled after every move, but
    # here the fade's set fills the ticks first): a setting at every tick the move crosses.
    cues: list[Cue] = [SetCue(k / 50, origin(f"s{k}"), {"led1": (k, 0, 0)}) for k in range(12)]
    cues.append(MotionCue(0.0, origin("m"), {"roll": 5.0}, 0.5))
    planner = _planned("rider", *cues)
    assert _samples_of(planner, "m", (ROLL,)) == _move_reference(
        ["roll"], 0.0, [DofState(0.0)], [5.0], 0.5, 50.0, profile=RIDER)
    for k in range(12):
        assert [(a, name) for a, _, name, *_ in _filed(planner)[k * 20000]] == [
            (LED1, f"s{k}"), (ROLL, "m")]
    assert planner.mixed == {k * 20000 for k in range(12)}


# -- the whole track --------------------------------------------------------------------------


def test_plan_xgo_track_makes_the_frames_of_the_plan() -> None:
    track = ResolvedTrack("p", "rider", (
        SetCue(0.0, origin("s"), {"roll": 2.0}),
        FadeCue(0.0, origin("f"), "led1", (3, 0, 0), 0.1),
        ActionCue(0.5, origin("a"), 255, "reset", 1.0),
        MotionCue(0.0, origin("bad"), {"periodic_roll": 1.5}, 1.0),
    ))
    for details in (False, True):
        plan = plan_xgo_track(layout_of(RIDER), track, rate=50.0, link=RIDER.link,
                              gap=RIDER.link.gap, details=details)
        assert [(f.t_us, f.origin.cue if f.origin else None, f.droppable, f.action, f.duration)
                for f in plan.frames] == [
            (0, "s", False, False, 0.0), (0, "f", True, False, 0.0),  # roll, led1: apart
            (20000, "f", True, False, 0.0), (60000, "f", True, False, 0.0),
            (100000, "f", True, False, 0.0), (500000, "a", False, True, 1.0)]
        assert plan.samples == 4
        assert plan.end == 1.5
        assert [d.message for d in plan.diagnostics] == [
            "cue 'bad': periodic_roll cannot follow a trajectory"]
        # Without details, a tick only samples make has no fields (the first is mixed).
        assert bool(plan.frames[2].fields) is details and plan.frames[1].fields


# -- edges ------------------------------------------------------------------------------------


def test_a_setting_whose_first_register_fails_files_nothing() -> None:
    planner = _planned("mini", SetCue(0.5, origin("s"), {"pace": "bogus"}))
    assert planner.ticks == {} and len(_errors(planner)) == 1


def test_a_move_shorter_than_the_time_to_the_next_tick_sends_only_its_targets() -> None:
    # At 10 Hz, from 0.01 s for 0.13 s: tick 1 (0.1 s), then its end at 0.14 s.
    planner = _planned("rider", MotionCue(0.01, origin("m"), {"roll": 0.1}, 0.13), rate=10.0)
    assert _errors(planner) == []
    reference = _move_reference(["roll"], 0.01, [DofState(0.0)], [0.1], 0.13, 10.0,
                                profile=RIDER)
    assert _samples_of(planner, "m", (ROLL,)) == reference and set(reference) == {100000, 140000}
    # At 5 Hz, from 0.21 s: its end (0.34 s) comes before the next tick (0.4 s).
    planner = _planned("rider", MotionCue(0.21, origin("m"), {"roll": 0.1}, 0.13), rate=5.0)
    assert _filed(planner) == {340000: [(ROLL, bytes([RIDER.register("roll").to_byte(0.1)]), "m",
                                         0, True, 0.0)]}


def test_moves_to_each_end_of_the_range_are_planned_and_an_overshoot_past_one_is_refused() -> None:
    planner = _planned("mini", MotionCue(0.0, origin("down"), {"roll": -20.0}, None),
                       MotionCue(1.0, origin("up"), {"roll": 20.0}, None))
    assert _errors(planner) == [] and planner.commanded["roll"] == 20.0
    # Reaching the ends exactly is within the byte tables: samples, one source a tick.
    assert {type(e) for e in planner.ticks.values()} == {tuple}
    # Under way at 60 deg/s towards one end, a move with a tenth of the acceleration cannot
    # stop before passing it: said with where it would go, on either side.
    soft = {"roll": Limits(60.0, 50.0, 2000.0)}
    for sign in (1.0, -1.0):
        planner = _planned(
            "mini", SetCue(0.0, origin("s"), {"roll": -20.0 * sign}),
            MotionCue(0.1, origin("m"), {"roll": 20.0 * sign}, None),
            MotionCue(0.7, origin("n"), {"roll": 18.0 * sign}, None, limits=soft))
        assert _errors(planner) == [
            f"show.yaml:1:5: error: tracks.p: cue 'n': roll would overshoot to {31.0 * sign:.1f}"
            "deg (range -20..20) because it interrupts the move before it"]
        assert len(planner.runs) == 1 and planner.commanded["roll"] == 20.0 * sign
    # By less than a degree (the allowance is a millionth), and said without a unit for a
    # register that has none.
    unitless = dataclasses.replace(MINI, registers=tuple(
        dataclasses.replace(r, unit=None) if r.name == "roll" else r for r in MINI.registers))
    for sign in (1.0, -1.0):
        track = ResolvedTrack("p", "mini", (
            SetCue(0.0, origin("s"), {"roll": -20.0 * sign}),
            MotionCue(0.1, origin("m"), {"roll": 20.0 * sign}, None),
            MotionCue(0.95, origin("n"), {"roll": 19.0 * sign}, None,
                      limits={"roll": Limits(60.0, 150.0, 2000.0)})))
        planner = XgoPlanner(layout_of(unitless), track, 50.0)
        planner.plan()
        first = plan_motion(["roll"], 0.1, [DofState(-20.0 * sign)], [20.0 * sign],
                            [_limits("roll")])
        over = plan_motion(["roll"], 0.95, first.state_at(0.95), [19.0 * sign],
                           [Limits(60.0, 150.0, 2000.0)])
        (lo, hi), = over.extrema()
        worst = hi if sign > 0 else lo
        assert 20.0 < abs(worst) < 21.0
        assert _errors(planner) == [
            f"show.yaml:1:5: error: tracks.p: cue 'n': roll would overshoot to {worst:.1f} "
            "(range -20..20) because it interrupts the move before it"]


def test_registers_without_an_initial_value_are_skipped_and_an_led_starts_black() -> None:
    # A profile whose status register (the first) and led1 have no initial value: the
    # registers after them still start from theirs.
    bare = dataclasses.replace(RIDER, registers=tuple(
        dataclasses.replace(r, initial=None) if r.name in ("battery", "led1")
        else dataclasses.replace(r, initial=b"\x0a\x14\x1e") if r.name == "led3" else r
        for r in RIDER.registers))
    track = ResolvedTrack("p", "rider", (
        FadeCue(0.0, origin("f"), "led1", (5, 0, 0), 0.1),
        FadeCue(0.0, origin("g"), "led2", (5, 0, 0), 0.1),
        MotionCue(0.0, origin("m"), {"roll": 3.0}, 0.5),
    ))
    planner = XgoPlanner(layout_of(bare), track, 50.0)
    assert planner.colours == {"led2": (0, 0, 0), "led3": (10, 20, 30), "led4": (0, 0, 0)}
    assert planner.commanded["roll"] == 0.0 and "battery" not in planner.commanded
    planner.plan()
    assert _colours(planner, "f")[0] == (0, 0, 0) and _colours(planner, "f")[20000] == (1, 0, 0)
    assert _samples_of(planner, "m", (ROLL,)) == _move_reference(
        ["roll"], 0.0, [DofState(0.0)], [3.0], 0.5, 50.0, profile=RIDER)


def test_only_single_byte_linear_registers_with_limits_follow_a_trajectory() -> None:
    limits = Limits(10.0, 50.0, 500.0)
    cases = {
        "periodic_roll": {"periodic_roll": limits},  # limits given, but a period's encoding
        "steering_hold": {"steering_hold": limits},  # a one-byte choice, not linear
        "action": {"action": limits},  # one byte, a number, not linear
    }
    for name, given in cases.items():
        planner = _planned("rider", MotionCue(0.0, origin("m"), {name: 1.0}, 1.0, limits=given))
        assert _errors(planner) == [
            f"show.yaml:1:5: error: tracks.p: cue 'm': {name} cannot follow a trajectory"]
    # A linear one-byte register without limits of its own, and none given.
    free = dataclasses.replace(RIDER, registers=tuple(
        dataclasses.replace(r, limits=None) if r.name == "roll" else r for r in RIDER.registers))
    track = ResolvedTrack("p", "rider", (MotionCue(0.0, origin("m"), {"roll": 1.0}, 1.0),))
    planner = XgoPlanner(layout_of(free), track, 50.0)
    planner.plan()
    assert _errors(planner) == [
        "show.yaml:1:5: error: tracks.p: cue 'm': roll cannot follow a trajectory"]
    # ... given limits in the cue, it moves.
    track = ResolvedTrack("p", "rider", (MotionCue(0.0, origin("m"), {"roll": 1.0}, 1.0,
                                                   limits={"roll": limits}),))
    planner = XgoPlanner(layout_of(free), track, 50.0)
    planner.plan()
    assert _errors(planner) == [] and len(planner.runs) == 1


def test_a_quick_fade_running_past_a_move_shares_its_ticks_then_has_its_own() -> None:
    planner = _planned("rider", MotionCue(0.0, origin("m"), {"roll": 5.0}, 0.5),
                       FadeCue(0.4, origin("f"), "led1", (255, 255, 255), 0.4))
    colours = _colours(planner, "f")
    # A twentieth of the way a tick (12.75 a channel), as _Fade.colour_at reckons it.
    assert colours == {20000 * k: (round(255 * ((k / 50 - 0.4) / 0.4)),) * 3
                       for k in range(20, 41)}
    for t in colours:
        entry = planner.ticks[t]
        if t < 500000:
            assert isinstance(entry, Samples)
        elif t == 500000:  # the move's target and the fade's sample
            assert isinstance(entry, Samples) and len(entry) == 2
        else:
            assert isinstance(entry, tuple) and entry[0].addresses == (LED1,)
    assert planner.mixed == set()


def test_two_fades_of_one_led_meeting_at_a_tick_send_the_later() -> None:
    planner = _planned("rider", FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 0.1),
                       FadeCue(0.1, origin("g"), "led1", (0, 0, 255), 0.1))
    assert _winners(planner, 100000) == {LED1: (b"\xff\x00\x00", "g")}
    assert _colours(planner, "g") == {100000: (255, 0, 0), 120000: (204, 0, 51),
                                      140000: (153, 0, 102), 160000: (102, 0, 153),
                                      180000: (51, 0, 204), 200000: (0, 0, 255)}
    # A fade after one that ended (not cut) starts from its final colour.
    planner = _planned("rider", FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 0.1),
                       FadeCue(0.5, origin("g"), "led1", (255, 0, 100), 0.1))
    assert _colours(planner, "g")[500000] == (255, 0, 0)
    assert _colours(planner, "g")[520000] == (255, 0, 20)


def test_moves_side_by_side_on_other_registers_share_every_tick_as_two_sources() -> None:
    planner = _planned("mini", MotionCue(0.0, origin("z"), {"body_z": 100.0}, 1.0),
                       MotionCue(0.2, origin("r"), {"roll": 3.0}, 0.5))
    body_z = _move_reference(["body_z"], 0.0, [DofState(MINI.register("body_z").to_physical(0x80))],
                             [100.0], 1.0, 50.0)
    roll = _move_reference(["roll"], 0.2, [DofState(0.0)], [3.0], 0.5, 50.0)
    assert _samples_of(planner, "z", (BODY_Z,)) == body_z
    assert _samples_of(planner, "r", (ROLL,)) == roll
    for t in roll:
        entry = planner.ticks[t]
        assert isinstance(entry, Samples)
        assert [src.origin for src, _ in entry] == [origin("z"), origin("r")]
    assert planner.mixed == set()


def test_a_move_cut_on_one_register_samples_the_others_at_their_own_times() -> None:
    # From 0.3 s for 1.2 s; roll is taken over at 0.6 s, pitch and body_z go on to the end.
    regs = ["body_z", "roll", "pitch"]
    targets = {"body_z": 105.0, "roll": 4.0, "pitch": -6.0}
    planner = _planned("mini", MotionCue(0.3, origin("m"), targets, 1.2),
                       SetCue(0.6, origin("s"), {"roll": 1.0}))
    rest = [DofState(MINI.register(n).to_physical(0x80)) for n in regs]
    full = _move_reference(regs, 0.3, rest, [targets[n] for n in regs], 1.2, 50.0)
    assert _samples_of(planner, "m", (BODY_Z, ROLL, 0x37)) == {
        t: s for t, s in full.items() if t < 600000}
    assert _samples_of(planner, "m", (BODY_Z, 0x37)) == {
        t: s[:1] + s[2:] for t, s in full.items()}
    assert max(full) == 1500000 and 1480000 in full


def test_a_move_starting_a_hair_after_a_tick_samples_its_start_there() -> None:
    # first_tick ignores a billionth of a tick: tick 10 (0.2 s) lies before the start.
    planner = _planned("mini", MotionCue(0.2 + 1e-11, origin("m"), {"roll": 5.0}, 0.5))
    assert _errors(planner) == []
    assert planner.ticks[200000][1] == bytes([MINI.register("roll").to_byte(0.0)])
    assert _samples_of(planner, "m", (ROLL,)) == _move_reference(
        ["roll"], 0.2 + 1e-11, [DofState(0.0)], [5.0], 0.5, 50.0)


def test_a_fade_ending_a_microsecond_after_a_tick_samples_that_tick() -> None:
    planner = _planned("rider", FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 1.000001))
    colours = _colours(planner, "f")
    assert max(colours) == 1000001 and colours[1000000] == (255, 0, 0)
    assert len(colours) == 52  # ticks 0..50, then the end itself
    slow = _planned("rider", FadeCue(0.0, origin("f"), "led1", (2, 0, 0), 1.000001))
    assert _colours(slow, "f") == {0: (0, 0, 0), 260000: (1, 0, 0), 760000: (2, 0, 0),
                                   1000001: (2, 0, 0)}


def test_samples_holding_any_byte_value_are_filed_whole() -> None:
    # Bytes 0x0a (a newline) and 0x0d in the samples of a two-register move and of a group
    # of fades: every value is a byte like another.
    body_z = MINI.register("body_z")
    low = body_z.to_physical(5)
    planner = _planned("mini", SetCue(0.0, origin("s"), {"body_z": low}),
                       MotionCue(0.1, origin("m"), {"body_z": body_z.to_physical(20),
                                                    "roll": -19.0}, 1.5))
    rest = [DofState(low), DofState(0.0)]
    expected = _move_reference(["body_z", "roll"], 0.1, rest,
                               [body_z.to_physical(20), -19.0], 1.5, 50.0)
    assert {b"\n"[0], 0x0D} <= {s[0] for s in expected.values()}
    assert _samples_of(planner, "m", (BODY_Z, ROLL)) == expected
    o = origin("glow")
    group = _planned("rider", FadeCue(0.0, o, "led1", (20, 20, 20), 0.2),
                     FadeCue(0.0, o, "led2", (0, 13, 10), 0.2))
    assert {t: entry[1] for t, entry in group.ticks.items()} == {
        20000 * k: bytes([2 * k] * 3 + [0, round(13 * (k / 50 / 0.2)), k]) for k in range(11)}


def test_where_a_move_or_fade_hands_over_to_the_next_the_tick_stays_one_sample() -> None:
    # The first move's target and the next's first sample share 1.0 s: the later sample takes
    # the earlier's place (the tick's frames are its alone), and the tick stays a sample.
    planner = _planned("mini", MotionCue(0.0, origin("m"), {"roll": 10.0}, 1.0),
                       MotionCue(1.0, origin("n"), {"roll": -2.0}, 1.0))
    entry = planner.ticks[1000000]
    assert isinstance(entry, tuple) and entry[0].origin == origin("n")
    assert planner.mixed == set()
    # A next move on more registers takes the place too; one on fewer cannot (the first
    # move's other register must still go out): the tick becomes Writes.
    wider = _planned("mini", MotionCue(0.0, origin("m"), {"roll": 10.0}, 1.0),
                     MotionCue(1.0, origin("n"), {"roll": -2.0, "pitch": 3.0}, 1.0))
    entry = wider.ticks[1000000]
    assert isinstance(entry, tuple) and entry[0].origin == origin("n")
    narrower = _planned("mini", MotionCue(0.0, origin("m"), {"roll": 10.0, "pitch": 3.0}, 1.0),
                        MotionCue(1.0, origin("n"), {"roll": -2.0}, 1.0))
    assert isinstance(narrower.ticks[1000000], list) and narrower.mixed == {1000000}
    assert _winners(narrower, 1000000) == {
        ROLL: (bytes([MINI.register("roll").to_byte(10.0)]), "n"),
        0x37: (bytes([MINI.register("pitch").to_byte(3.0)]), "m")}
    # Beside a fade (a tick of two sources): the move's sample is replaced, the fade's kept.
    beside = _planned("rider", FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 2.0),
                      MotionCue(0.0, origin("m"), {"roll": 5.0}, 0.5),
                      MotionCue(0.5, origin("n"), {"roll": 0.0}, 0.5))
    entry = beside.ticks[500000]
    assert isinstance(entry, Samples)
    assert [src.origin for src, _ in entry] == [origin("n"), origin("f")]
    assert beside.mixed == set()
    # Two fades of one LED handing over at 0.1 s: the second's first colour alone.
    fades = _planned("rider", FadeCue(0.0, origin("f"), "led1", (255, 0, 0), 0.1),
                     FadeCue(0.1, origin("g"), "led1", (0, 0, 255), 0.1))
    entry = fades.ticks[100000]
    assert isinstance(entry, tuple) and entry == (entry[0], b"\xff\x00\x00")
    assert entry[0].origin == origin("g") and fades.mixed == set()


def test_a_move_handing_over_beside_another_move_replaces_only_its_own_sample() -> None:
    # body_z moves all along; roll hands over from r to n at 0.5 s, a tick both moves hold.
    planner = _planned("mini", MotionCue(0.0, origin("z"), {"body_z": 100.0}, 1.0),
                       MotionCue(0.0, origin("r"), {"roll": 5.0}, 0.5),
                       MotionCue(0.5, origin("n"), {"roll": 0.0}, 0.5))
    entry = planner.ticks[500000]
    assert isinstance(entry, Samples)
    assert [src.origin for src, _ in entry] == [origin("z"), origin("n")]
    assert planner.mixed == set()
    # n's samples at every tick after it, beside body_z's.
    assert _samples_of(planner, "n", (ROLL,)) == _move_reference(
        ["roll"], 0.5, [DofState(5.0)], [0.0], 0.5, 50.0)
    for t in range(520000, 1000000, 20000):
        entry = planner.ticks[t]
        assert isinstance(entry, Samples)
        assert [src.origin for src, _ in entry] == [origin("z"), origin("n")]
    # A move on the registers of two others there replaces neither: the tick becomes Writes,
    # the later cue's bytes going out on both.
    both = _planned("mini", MotionCue(0.0, origin("r"), {"roll": 5.0}, 0.5),
                    MotionCue(0.0, origin("p"), {"pitch": 5.0}, 0.5),
                    MotionCue(0.5, origin("n"), {"roll": 0.0, "pitch": 0.0}, 0.5))
    assert isinstance(both.ticks[500000], list) and both.mixed == {500000}
    assert _winners(both, 500000) == {ROLL: (bytes([MINI.register("roll").to_byte(5.0)]), "n"),
                                      0x37: (bytes([MINI.register("pitch").to_byte(5.0)]), "n")}


def test_rows_of_any_width_and_any_bytes_are_cut_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    from xgo_show.compiler import frames
    from xgo_show.compiler import planner as module

    monkeypatch.setattr(frames, "_CUTS", {})  # the patterns made here, none from another test
    columns = [[10, 13, 0, 255], [10, 10, 46, 1], [0, 10, 13, 10]]
    assert module._rows(columns, 4) == [bytes(row) for row in zip(*columns, strict=True)]
    assert module._rows(columns[:2], 4) == [bytes(row) for row in zip(*columns[:2],
                                                                        strict=True)]
    assert module._rows(columns[:1], 4) == [b"\n", b"\r", b"\x00", b"\xff"]
    assert sorted(frames._CUTS) == [2, 3]  # one byte a row needs no pattern
    assert module._rows(columns, 4) == [bytes(row) for row in zip(*columns, strict=True)]
    with pytest.raises(ValueError):  # a column shorter than the count
        module._rows([[1, 2, 3, 4], [1, 2, 3]], 4)


def test_a_move_to_an_end_interrupted_by_another_to_that_end_is_planned() -> None:
    # Under way to 20 deg, a second move to 20 with a duration: ruckig's path passes the end
    # by float noise (up to 1e-8 deg), which goes out as the end's byte (Register.to_byte,
    # tolerating 1e-9, refused it: "roll = 20 deg is out of range [-20, 20] deg").
    cases = [(5.9299944989944535, 20.0, 0.585, 0.61, 50.0),
             (-18.653971399428553, -20.0, 0.254, 0.28, 50.0),
             (-2.668881002108712, 20.0, 0.719, 0.73, 50.0),
             (13.409041268034905, -20.0, 0.886, 0.91, 100.0)]
    roll = MINI.register("roll")
    for start, end, at, duration, rate in cases:
        planner = _planned("mini", SetCue(0.0, origin("s"), {"roll": start}),
                           MotionCue(0.0, origin("m"), {"roll": end}, None),
                           MotionCue(at, origin("n"), {"roll": end}, duration), rate=rate)
        assert _errors(planner) == []
        (lo, hi), = planner.runs[1].plan.extrema()
        assert lo < -20.0 - 1e-9 or hi > 20.0 + 1e-9  # past the end by more than to_byte allows
        samples = _samples_of(planner, "n", (ROLL,))
        assert samples[max(samples)] == bytes([roll.to_byte(end)])
        assert {s[0] for s in samples.values()} <= set(range(roll.to_byte(-20.0),
                                                             roll.to_byte(20.0) + 1))
