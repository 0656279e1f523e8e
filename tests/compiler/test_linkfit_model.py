"""validate's short cut (compiler/linkfit.py), step by step on small hand-made tracks.

test_linkfit.py checks the whole proof against full compiles of random shows (minutes under
mutation testing); these state each step's exact result on tracks small enough to count by
hand, in milliseconds: what the model says a performer writes when, and what each write
costs; the sweep's bound on hand-made models; and where the short cut answers and where it
leaves the performer to the full compile.
"""

from __future__ import annotations

import math

import pytest

from tests.compiler.conftest import origin
from xgo_show.choreo.resolved import ActionCue, Cue, FadeCue, MotionCue, ResolvedTrack, SetCue
from xgo_show.compiler.frames import tick_us
from xgo_show.compiler.linkfit import (
    LinkModel,
    _CueWalk,
    _sweep,
    late_bound_us,
    link_model,
    quick_track_diagnostics,
)
from xgo_show.compiler.planner import XgoPlanner
from xgo_show.compiler.state import layout_of
from xgo_show.diagnostics import Diagnostic
from xgo_show.profiles import Link, get_profile

MINI = get_profile("mini")
RIDER = get_profile("rider")
GAP_US = 1200
# At 115200 baud and 10 bits a byte a byte takes 86.8 us, the 9 bytes of a 1-byte write
# 781.25 us exactly: a 1-byte register costs that, the gap and 2 us of rounding.
ONE_BYTE = 781.25 + GAP_US + 2
SMALLEST = 781.25 + GAP_US


def _move(start: float, targets: dict[str, float], duration: float | None = 1.0,
          name: str = "m") -> MotionCue:
    return MotionCue(start, origin(name), targets, duration, interrupts=True)


def _walk(cues: list[Cue], model: str = "mini", rate: float = 50.0,
          walker: type[XgoPlanner] = _CueWalk) -> XgoPlanner:
    walk = walker(layout_of(get_profile(model)), ResolvedTrack("p", model, tuple(cues)), rate)
    walk.plan()
    return walk


def _model(cues: list[Cue], model: str = "mini", rate: float = 50.0,
           link: Link | None = None, gap_us: int = GAP_US) -> LinkModel | None:
    profile = get_profile(model)
    return link_model(_walk(cues, model, rate), rate=rate, link=link or profile.link,
                      gap_us=gap_us)


def _addr(name: str, model: str = "mini") -> int:
    return get_profile(model).register(name).address


def _plain(model: LinkModel) -> tuple[dict[int, list[tuple[int, int]]], dict[int, set[int]]]:
    return ({k: sorted(v) for k, v in model.spans.items()}, dict(model.points))


# -- what a write costs ---------------------------------------------------------------------


def test_a_write_costs_its_frame_bytes_the_silence_after_it_and_two_us_of_rounding() -> None:
    model = _model([_move(0.0, {"body_z": 100.0}), SetCue(0.5, origin("s"), {"bt_name": "a"})])
    assert model is not None
    assert model.cost == {_addr("body_z"): ONE_BYTE, _addr("bt_name"): 28 * 1e6 / 11520 + 1202}
    assert model.smallest == SMALLEST
    # Another link: the byte time follows its baud and bits a byte, the silence its gap.
    slow = Link(57600, 0.002, 11)
    model = _model([_move(0.0, {"body_z": 100.0})], link=slow, gap_us=2000)
    assert model is not None
    per_byte = 11 * 1e6 / 57600
    assert model.cost == {_addr("body_z"): pytest.approx(9 * per_byte + 2002)}
    assert model.smallest == pytest.approx(9 * per_byte + 2000)


def test_an_action_and_a_setting_cost_their_registers_at_their_start() -> None:
    model = _model([ActionCue(0.25, origin("a"), 13, "wave", 7.0, interrupts=True),
                    SetCue(0.3, origin("s"), {"gait": "trot", "pace": "slow"})])
    assert model is not None
    action, gait, pace = _addr("action"), _addr("gait"), _addr("pace")
    assert model.spans == {}
    assert model.points == {250_000: {action}, 300_000: {gait, pace}}
    assert model.cost == {action: ONE_BYTE, gait: ONE_BYTE, pace: ONE_BYTE}


# -- when a move or a fade writes -----------------------------------------------------------


def test_a_move_writes_at_each_tick_from_its_start_to_before_its_end_and_at_its_end() -> None:
    z = _addr("body_z")
    model = _model([_move(0.0, {"body_z": 100.0})])
    assert model is not None
    assert _plain(model) == ({0: [(z, 1)], 50: [(z, -1)]}, {1_000_000: {z}})
    # Off the grid: from the first tick at or after the start; the end at the end itself.
    model = _model([_move(0.01, {"body_z": 100.0})])
    assert model is not None
    assert _plain(model) == ({1: [(z, 1)], 51: [(z, -1)]}, {1_010_000: {z}})
    # An end a hair past a tick: that tick is the end's, not a sample's.
    model = _model([_move(0.0, {"body_z": 100.0}, 1.0000001)])
    assert model is not None
    assert _plain(model) == ({0: [(z, 1)], 50: [(z, -1)]}, {1_000_000: {z}})
    # Shorter than a tick: only its end.
    model = _model([_move(0.05, {"body_z": 100.0}, 0.4)], rate=2.0)
    assert model is not None
    assert _plain(model) == ({}, {450_000: {z}})


def test_a_register_another_move_takes_over_stops_before_that_move_without_its_end() -> None:
    z, roll = _addr("body_z"), _addr("roll")
    model = _model([_move(0.01, {"body_z": 100.0}),
                    _move(0.5, {"body_z": 90.0, "roll": 3.0}, name="n")])
    assert model is not None
    assert _plain(model) == (
        {1: [(z, 1)], 25: [(z, -1), (z, 1), (roll, 1)], 75: [(z, -1), (roll, -1)]},
        {1_500_000: {z, roll}})
    # Taken over off the grid: its last sample is the tick before the take-over.
    model = _model([_move(0.0, {"body_z": 100.0, "roll": 5.0}),
                    _move(0.51, {"body_z": 90.0}, name="n")])
    assert model is not None
    assert _plain(model) == (
        {0: [(z, 1), (roll, 1)], 26: [(z, -1), (z, 1)], 50: [(roll, -1)], 76: [(z, -1)]},
        {1_000_000: {roll}, 1_510_000: {z}})


def test_a_fade_writes_its_led_at_each_tick_of_its_span_and_at_its_end() -> None:
    led = _addr("led1", "rider")
    model = _model([FadeCue(0.0, origin("f"), "led1", (200, 0, 40), 1.0)], "rider")
    assert model is not None
    assert _plain(model) == ({0: [(led, 1)], 50: [(led, -1)]}, {1_000_000: {led}})
    assert model.cost == {led: 11 * 1e6 / 11520 + 1202}
    model = _model([FadeCue(0.01, origin("f"), "led1", (200, 0, 40), 1.0)], "rider")
    assert model is not None
    assert _plain(model) == ({1: [(led, 1)], 51: [(led, -1)]}, {1_010_000: {led}})
    # Shorter than a tick (2 Hz): only its end.
    model = _model([FadeCue(0.05, origin("f"), "led1", (200, 0, 40), 0.4)], "rider", rate=2.0)
    assert model is not None
    assert _plain(model) == ({}, {450_000: {led}})
    # At 144 Hz tick 2 rounds up to 13889 us: a fade ending there has ticks 0 and 1 only.
    assert tick_us(2, 144.0) == 13_889
    model = _model([FadeCue(0.0, origin("f"), "led1", (200, 0, 40), 0.013889)], "rider",
                   rate=144.0)
    assert model is not None
    assert _plain(model) == ({0: [(led, 1)], 2: [(led, -1)]}, {13_889: {led}})
    # No duration: only its colour, at its start.
    model = _model([FadeCue(0.3, origin("f"), "led1", (200, 0, 40), 0.0)], "rider")
    assert model is not None
    assert _plain(model) == ({}, {300_000: {led}})
    # Cut by a setting of its LED: its ticks stop before the setting, which sends its own.
    model = _model([FadeCue(0.0, origin("f"), "led1", (200, 0, 40), 1.0),
                    SetCue(0.5, origin("s"), {"led1": (1, 2, 3)})], "rider")
    assert model is not None
    assert _plain(model) == ({0: [(led, 1)], 25: [(led, -1)]}, {500_000: {led}})
    model = _model([FadeCue(0.0, origin("f"), "led1", (200, 0, 40), 1.0),
                    SetCue(0.51, origin("s"), {"led1": (1, 2, 3)})], "rider")
    assert model is not None
    assert _plain(model) == ({0: [(led, 1)], 26: [(led, -1)]}, {510_000: {led}})


def test_a_move_sampled_at_one_tick_and_a_move_to_its_tables_ends_are_modelled() -> None:
    z = _addr("body_z")
    # At 2 Hz a move over 0.05..0.55 s is sampled at tick 1 (0.5 s) only.
    model = _model([_move(0.05, {"body_z": 100.0}, 0.5)], rate=2.0)
    assert model is not None
    assert _plain(model) == ({1: [(z, 1)], 2: [(z, -1)]}, {550_000: {z}})
    # Right to the byte table's ends (75 and 120 mm): within it, so modelled.
    for target in (75.0, 120.0):
        assert _model([_move(0.0, {"body_z": target})]) is not None


class _Overshooting:
    """A planned move whose path leaves its register's range though its target is inside."""

    def __init__(self, plan: object) -> None:
        self._plan = plan

    def __getattr__(self, name: str) -> object:
        return getattr(self._plan, name)

    def extrema(self) -> list[tuple[float, float]]:
        return [(lo, hi + 100.0) for lo, hi in self._plan.extrema()]  # type: ignore[attr-defined]


def test_a_move_whose_path_leaves_the_byte_table_is_left_to_the_full_compile() -> None:
    walk = _walk([_move(0.0, {"body_z": 100.0})])
    walk.runs[0].plan = _Overshooting(walk.runs[0].plan)  # type: ignore[assignment]
    assert link_model(walk, rate=50.0, link=MINI.link, gap_us=GAP_US) is None


@pytest.mark.parametrize("target", [120.0000005, 74.9999995])
def test_a_move_past_its_registers_byte_table_is_left_to_the_full_compile(target: float) -> None:
    # Within the planner's 1e-6 tolerance of the range, but past the byte table's edge:
    # sampling it raises (the compile's error), so the model does not claim it fits.
    assert _model([_move(0.0, {"body_z": target})]) is None
    assert _model([_move(0.0, {"body_z": 100.0, "roll": 3.0}),
                   _move(0.2, {"body_z": target}, name="n")]) is None
    walk = _walk([_move(0.0, {"body_z": target})])
    assert late_bound_us(walk, rate=50.0, link=MINI.link, gap_us=GAP_US, limit=math.inf) is None
    assert quick_track_diagnostics(
        walk.track, MINI, rate=50.0, link=MINI.link, gap_us=GAP_US, period_us=20_000,
        decimate=False) is None


def test_a_walk_that_filed_samples_is_not_modelled() -> None:
    # The planner's own walk samples moves and fades: the model counts only settings and
    # actions in its ticks, so a sample there (alone, or beside another source's) means None.
    move = _walk([_move(0.0, {"body_z": 100.0})], walker=XgoPlanner)
    assert link_model(move, rate=50.0, link=MINI.link, gap_us=GAP_US) is None
    both = _walk([_move(0.0, {"body_z": 100.0}),
                  FadeCue(0.0, origin("f"), "led1", (200, 0, 40), 1.0)], "rider",
                 walker=XgoPlanner)
    assert link_model(both, rate=50.0, link=RIDER.link, gap_us=GAP_US) is None
    assert link_model(_walk([_move(0.0, {"body_z": 100.0}),
                             FadeCue(0.0, origin("f"), "led1", (200, 0, 40), 1.0)], "rider"),
                      rate=50.0, link=RIDER.link, gap_us=GAP_US) is not None


# -- the sweep --------------------------------------------------------------------------------


def _hand(spans: dict[int, list[tuple[int, int]]], points: dict[int, set[int]],
          cost: dict[int, float], smallest: float = 100.0) -> LinkModel:
    return LinkModel(spans, points, cost, smallest)


def test_one_instants_frames_make_its_last_frame_late_by_their_cost_less_the_smallest() -> None:
    model = _hand({}, {0: {1, 2}}, {1: 1000.0, 2: 500.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 1400.0
    # Between two ticks, the same.
    model = _hand({}, {5000: {1}}, {1: 1000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 900.0
    assert _sweep(_hand({}, {}, {}), rate=100.0, limit=math.inf) == 0.0


def test_lateness_carries_to_the_next_instant_only_while_the_link_is_busy() -> None:
    # 12 ms of frames at tick 0 (0 us), then 1 ms at tick 1 (10 ms): it waits 2 ms.
    model = _hand({}, {0: {1}, 10_000: {2}}, {1: 12_000.0, 2: 15_000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 2_000 + 15_000 - 100
    # Between ticks (5 ms): 7 ms late.
    model = _hand({}, {0: {1}, 5_000: {2}}, {1: 12_000.0, 2: 15_000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 7_000 + 15_000 - 100
    # ... and the link is busy 7 + 15 ms after it: an instant at 20 ms waits 7 ms.
    model = _hand({}, {0: {1}, 5_000: {2}, 20_000: {3}}, {1: 12_000.0, 2: 15_000.0,
                                                          3: 30_000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 7_000 + 30_000 - 100
    # 6 ms, nearer tick 1 than tick 0, is still between them.
    model = _hand({}, {0: {1}, 6_000: {2}}, {1: 12_000.0, 2: 15_000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 6_000 + 15_000 - 100
    # A link free again before the next instant: nothing carries.
    model = _hand({}, {0: {1}, 10_000: {2}}, {1: 8_000.0, 2: 15_000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 15_000 - 100
    # A point on a tick 144 Hz rounds to (6944 us) is that tick's; one a microsecond later
    # falls between ticks 1 and 2.
    assert tick_us(1, 144.0) == 6944
    for at in (6944, 6945):
        model = _hand({}, {0: {1}, at: {2}}, {1: 7_000.0, 2: 15_000.0})
        assert _sweep(model, rate=144.0, limit=math.inf) == 7_000 - at + 15_000 - 100


def test_a_window_dearer_than_a_tick_grows_lateness_by_the_excess_a_tick() -> None:
    # Ticks 0..9 at 100 Hz each cost 15 ms: 5 ms more a tick (the sweep counts the shortest
    # spacing, 9999 us: 5001), the last frame of tick 9 9 x 5001 us late plus its tick's.
    model = _hand({0: [(1, 1)], 10: [(1, -1)]}, {}, {1: 15_000.0})
    exact = 9 * 5_000 + 15_000 - 100
    assert _sweep(model, rate=100.0, limit=math.inf) == 9 * 5_001 + 15_000 - 100
    assert exact <= _sweep(model, rate=100.0, limit=math.inf) <= exact + 9
    # The link is then free 9 x 5001 us after tick 9 ends: a point at tick 10 waits that.
    model = _hand({0: [(1, 1)], 10: [(1, -1)]}, {100_000: {2}}, {1: 15_000.0, 2: 60_000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 9 * 5_001 + 5_000 + 60_000 - 100


def test_a_point_between_ticks_comes_after_the_ticks_before_it_and_before_those_after() -> None:
    # Ticks 0..2 cost 15 ms; 100 ms at 15 ms (between ticks 1 and 2): it waits for ticks 0
    # and 1 only (15 001 us late), tick 2 then for it.
    model = _hand({0: [(1, 1)], 3: [(1, -1)]}, {15_000: {2}}, {1: 15_000.0, 2: 100_000.0})
    tick2 = (15_000 + 15_001 + 100_000) - 20_000
    assert _sweep(model, rate=100.0, limit=math.inf) == tick2 + 15_000 - 100


def test_at_one_hertz_a_tick_is_a_second_less_a_microsecond() -> None:
    model = _hand({0: [(1, 1)], 10: [(1, -1)]}, {}, {1: 1_500_000.0})
    assert _sweep(model, rate=1.0, limit=math.inf) == 9 * 500_001 + 1_500_000 - 100


def test_a_window_cheaper_than_a_tick_drains_lateness_by_the_slack_a_tick() -> None:
    # 50 ms at tick 0; ticks 1..3 cost 2 ms each (8 ms of slack a tick; the sweep, 7999 us);
    # then 60 ms at tick 4, which starts 40 - 2 x 7999 - 10 + 2 ms late.
    model = _hand({1: [(1, 1)], 4: [(1, -1)]}, {0: {2}, 40_000: {3}},
                  {1: 2_000.0, 2: 50_000.0, 3: 60_000.0})
    late = (50_000 - 10_000) - 2 * 7_999 + 2_000 - 10_000
    assert _sweep(model, rate=100.0, limit=math.inf) == late + 60_000 - 100
    # Drained to nothing: never below zero.
    model = _hand({1: [(1, 1)], 20: [(1, -1)]}, {0: {2}, 200_000: {3}},
                  {1: 2_000.0, 2: 50_000.0, 3: 60_000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 60_000 - 100
    # ... so a point 1.5 ms after the last drained tick waits only for that tick's 2 ms.
    model = _hand({1: [(1, 1)], 20: [(1, -1)]}, {0: {2}, 191_500: {3}},
                  {1: 2_000.0, 2: 50_000.0, 3: 60_000.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 500 + 60_000 - 100


def test_a_register_counts_once_an_instant_however_many_cues_write_it() -> None:
    # Two moves sample register 1 over ticks 0..9 and 5..14; a setting writes it at tick 7
    # and register 2 beside it: tick 7 costs 1 + 2, never 1 twice or three times.
    model = _hand({0: [(1, 1)], 5: [(1, 1)], 10: [(1, -1)], 15: [(1, -1)]}, {70_000: {1, 2}},
                  {1: 1_000.0, 2: 300.0})
    assert _sweep(model, rate=100.0, limit=math.inf) == 1_300 - 100
    # Once both stop sampling it, it costs nothing more: a point after them pays only itself.
    # Ticks 0..14 cost 20 ms (10001 us more a tick within a window, 10000 from one window
    # to the next: [0, 5), [5, 10), [10, 15)); tick 15 waits for tick 14's frames.
    model = _hand({0: [(1, 1)], 5: [(1, 1)], 10: [(1, -1)], 15: [(1, -1)]}, {150_000: {2}},
                  {1: 20_000.0, 2: 100_000.0})
    late14 = 12 * 10_001 + 2 * 10_000
    late15 = late14 + 20_000 - 10_000
    assert _sweep(model, rate=100.0, limit=math.inf) == late15 + 100_000 - 100


def test_the_sweep_stops_counting_once_past_its_limit() -> None:
    model = _hand({}, {0: {1}, 10_000: {2}}, {1: 100_000.0, 2: 200_000.0})
    full = _sweep(model, rate=100.0, limit=math.inf)
    assert full == 90_000 + 200_000 - 100
    assert _sweep(model, rate=100.0, limit=20_000) == 100_000 - 100
    assert _sweep(model, rate=100.0, limit=full) == full
    # Reaching the limit is not past it: the count goes on.
    assert _sweep(model, rate=100.0, limit=100_000 - 100) == full


# -- the short cut ----------------------------------------------------------------------------

FIVE = {"body_x": 1.0, "body_y": 1.0, "body_z": 100.0, "roll": 3.0, "pitch": 2.0}


def _quick(cues: list[Cue], *, period_us: int, decimate: bool) -> list[Diagnostic] | None:
    track = ResolvedTrack("p", "mini", tuple(cues))
    found = quick_track_diagnostics(track, MINI, rate=50.0, link=MINI.link, gap_us=GAP_US,
                                    period_us=period_us, decimate=decimate)
    return None if found is None else list(found)


def test_the_short_cut_answers_while_no_frame_can_start_more_than_a_period_late() -> None:
    # Five 1-byte registers a tick: the last frame starts 5 x 1983.25 - 1981.25 = 7935 us
    # late, at most.
    walk = _walk([_move(0.0, FIVE)])
    assert late_bound_us(walk, rate=50.0, link=MINI.link, gap_us=GAP_US, limit=math.inf) == 7935
    assert _quick([_move(0.0, FIVE)], period_us=7935, decimate=False) == []
    assert _quick([_move(0.0, FIVE)], period_us=7934, decimate=False) is None
    # With decimate, half a period: nothing is dropped either.
    assert _quick([_move(0.0, FIVE)], period_us=15_870, decimate=True) == []
    assert _quick([_move(0.0, FIVE)], period_us=15_869, decimate=True) is None


def test_the_short_cut_reports_what_the_walk_finds() -> None:
    cues: list[Cue] = [_move(0.0, {"gait": 1.0}), _move(1.0, {"body_z": 100.0}, 0.01, "n")]
    found = _quick(cues, period_us=20_000, decimate=False)
    assert found is not None
    assert found == _walk(cues).diag.items
    assert [(d.origin and d.origin.cue, d.severity) for d in found] == [("m", "error"),
                                                                        ("n", "error")]
    assert found[0].message == "cue 'm': gait cannot follow a trajectory"
    assert found[1].message.startswith("the move to body_z 100 needs at least 0.34 s")
