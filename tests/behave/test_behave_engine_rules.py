"""The behaviour engine rule by rule, on virtual time with a stage that records what it is
asked: every note word for word, each action's performers, the telemetry triggers' edges and
their defaults, losing a robot, timers, time windows, sets, loops and queues. Two performers
(rex, a Mini; ada, a Rider, whose status register says when it has fallen) and one-move
routines, so that a rule's performers can be told apart."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import pytest

from tests.behave.conftest import write_behaviour
from xgo_show.behave import load_behaviour
from xgo_show.behave.engine import QUEUE_LIMIT, BehaviourNote, Engine
from xgo_show.runtime.events import Event, FaultRaised, TelemetryRead

# Each routine's parts and their lengths in seconds.
ROUTINES = {
    "one": {"rex": 1.0},
    "two": {"ada": 1.0},
    "duo": {"rex": 1.0, "ada": 1.0},
}


class Stage:
    """A stage that records every call as one line."""

    def __init__(self) -> None:
        self.calls: list[str] = []

    def play(self, routine: str, performers: tuple[str, ...], play_id: int, t: float) -> None:
        self.calls.append(f"{t:g} play {routine} {','.join(performers)} #{play_id}")

    def rest(self, performers: tuple[str, ...], t: float) -> None:
        self.calls.append(f"{t:g} rest {','.join(performers)}")

    def safe_stop(self, performers: tuple[str, ...], reason: str, t: float) -> None:
        self.calls.append(f"{t:g} safe_stop {','.join(performers)} ({reason})")

    def write(self, key: str, performers: tuple[str, ...], t: float) -> None:
        self.calls.append(f"{t:g} write {key} {','.join(performers)}")


class Rig:
    """An engine on a behaviour of ``rules``, its stage's calls and its notes."""

    def __init__(self, tmp_path: Path, rules: str, extra: str = "", *,
                 wall: dt.datetime = dt.datetime(2026, 1, 1, 8, 0), start: float = 0.0,
                 started: bool = True) -> None:
        path = write_behaviour(tmp_path, ROUTINES, rules, extra)
        self.stage = Stage()
        self.notes: list[str] = []
        self.engine = Engine(load_behaviour(path), self.stage, emit=self._emit,
                             wall=lambda t: wall + dt.timedelta(seconds=t))
        if started:
            self.engine.start(start)

    def _emit(self, e: Event) -> None:
        assert isinstance(e, BehaviourNote)
        self.notes.append(f"{e.t:g} {e.rule} {e.kind}: {e.text}")

    def read(self, t: float, performer: str, name: str, value: float) -> None:
        self.engine.on_event(TelemetryRead(t, performer, name, value))

    def last_play(self) -> int:
        """The play id of the last play the stage was asked for."""
        return int([c for c in self.stage.calls if " play " in c][-1].rsplit("#", 1)[1])


def test_a_trigger_says_whether_a_rule_waits_for_it(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{publish: went}]}
        """, "triggers: [go]\n")
    assert rig.engine.trigger("go", 1.0) is True
    assert rig.engine.trigger("come", 2.0) is False
    assert rig.notes == ["1 g fired: trigger go", "1 g published: went"]


def test_offline_counts_from_the_start_and_from_the_last_reading(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: gone, when: [{offline: 2, performers: [ada]}], do: [{publish: lost}]}
        """, started=False)
    rig.engine.start(5.0)
    assert rig.engine.next_deadline() == 7.0  # ada last seen at the start, not at 0
    rig.read(6.0, "rex", "battery", 80)  # rex is not watched by the rule
    assert rig.engine.next_deadline() == 7.0
    rig.engine.advance(6.9)
    assert rig.notes == []
    rig.engine.advance(7.0)
    assert rig.notes == ["7 gone fired: ada offline (2 s without telemetry)",
                         "7 gone published: lost"]
    assert rig.engine.next_deadline() is None  # fired once: not armed again until heard
    rig.engine.advance(9.0)  # nor fired again; rex, silent since 6 s, is not the rule's
    assert len(rig.notes) == 2
    rig.read(9.5, "ada", "battery", 80)
    assert rig.engine.next_deadline() == 11.5


def test_single_queued_and_restart_runs_word_for_word(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: s, when: [{trigger: a}], do: [{play: one}]}
        - {name: q, mode: queued, when: [{trigger: b}], do: [{play: two}]}
        - {name: r, mode: restart, when: [{trigger: c}], do: [{wait: 5}, {publish: done}]}
        """, "triggers: [a, b, c]\n")
    eng = rig.engine
    eng.trigger("a", 0.0)
    eng.trigger("a", 1.0)
    eng.trigger("b", 0.0)
    for t in range(1, QUEUE_LIMIT + 2):
        eng.trigger("b", float(t))
    eng.trigger("c", 0.0)
    eng.trigger("c", 2.0)
    assert rig.notes[:4] == ["0 s fired: trigger a", "0 s action: rex plays one",
                             "1 s skipped: trigger a: already running (single)",
                             "0 q fired: trigger b"]
    assert rig.notes[5:5 + QUEUE_LIMIT + 1] == [
        *[f"{t} q queued: trigger b: queued ({t} waiting)" for t in range(1, QUEUE_LIMIT + 1)],
        f"{QUEUE_LIMIT + 1} q skipped: trigger b: queue full ({QUEUE_LIMIT})"]
    assert rig.notes[-3:] == ["0 r fired: trigger c", "2 r cut: restarted by trigger c",
                              "2 r fired: trigger c"]
    # The queued run's routine ends: the first queued cause runs next, from the queue.
    eng.routine_ended("ada", rig.last_play(), 3.0, True)
    assert rig.notes[-2:] == ["3 q fired: trigger b (from the queue)",
                              "3 q action: ada plays two"]
    assert rig.stage.calls[-1].startswith("3 play two ada #")
    # The restarted run waits its 5 s from 2 s; the cut one published nothing.
    eng.advance(6.9)
    assert "r published: done" not in " ".join(rig.notes)
    eng.advance(7.0)
    assert rig.notes[-1] == "7 r published: done"
    assert eng.next_deadline() is None


def test_parallel_runs_go_on_side_by_side(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: p, mode: parallel, when: [{trigger: go}], do: [{wait: 2}, {publish: done}]}
        """, "triggers: [go]\n")
    rig.engine.trigger("go", 0.0)
    rig.engine.trigger("go", 1.0)
    rig.engine.advance(3.0)
    assert rig.notes == ["0 p fired: trigger go", "1 p fired: trigger go",
                         "3 p published: done", "3 p published: done"]


def test_a_queued_rule_cut_by_a_safety_rule_runs_its_queue_after_it_and_is_free_again(tmp_path: Path
                                                                          ) -> None:
    rig = Rig(tmp_path, """\
        - {name: q, mode: queued, when: [{trigger: go}], do: [{play: one}]}
        - {name: safe, safety: true, when: [{trigger: fall}], do: [{loop: one}]}
        """, "triggers: [go, fall]\n")
    for t in (0.0, 1.0, 2.0):
        rig.engine.trigger("go", t)
    rig.engine.trigger("fall", 3.0)
    rig.engine.trigger("go", 4.0)  # q runs nothing now: it fires (and is refused)
    assert rig.notes[-9:] == [
        "3 safe fired: trigger fall",
        "3 q cut: rex taken by rule safe",
        "3 safe action: rex loops one",
        "3 q fired: trigger go (from the queue)",
        "3 q refused: rex is held by rule safe (higher rank)",
        "3 q fired: trigger go (from the queue)",
        "3 q refused: rex is held by rule safe (higher rank)",
        "4 q fired: trigger go",
        "4 q refused: rex is held by rule safe (higher rank)",
    ]
    assert rig.stage.calls[-1].startswith("3 play one rex #")  # the safety rule's loop


def test_a_run_cut_while_it_runs_its_own_actions_stops_there(tmp_path: Path) -> None:
    # Its switch starts the set again, whose start-up restarts the rule: the first run is
    # cut inside its own switch and does not publish; the second does, once.
    rig = Rig(tmp_path, """\
        - {name: s, mode: restart, when: [{startup: true}], do: [{switch: b}, {publish: p}]}
        """, "sets: [a, b]\ninitial: a\n")
    assert rig.notes == [
        "0 s fired: start-up of set a",
        "0 s action: switch to set b",
        "0 s cut: restarted by start-up of set b",
        "0 s fired: start-up of set b",
        "0 s published: p",
    ]


def test_stops_safe_stops_and_writes_name_their_performers(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - name: x
          when: [{trigger: go}]
          do:
            - {loop: duo, performers: [ada]}
            - {loop: duo}
            - {stop: [ada]}
            - {safe_stop: all}
            - {set: {gait: trot, pace: slow}, performers: [rex]}
            - {led: {led1: red}, performers: [ada]}
            - {set: {vx: 0}}
            - {stop: all}
            - {safe_stop: [rex]}
        """, "triggers: [go]\n")
    rig.engine.trigger("go", 1.0)
    assert rig.notes == [
        "1 x fired: trigger go",
        "1 x action: ada loops duo",
        "1 x action: rex, ada loops duo",
        "1 x action: ada rest",
        "1 x action: rex, ada safe stop",
        "1 x action: rex set gait=trot pace=slow",
        "1 x action: ada led led1=red",
        "1 x action: rex, ada set vx=0",
        "1 x action: rex, ada rest",
        "1 x action: rex safe stop",
    ]
    assert rig.stage.calls == [
        "1 play duo ada #1",
        "1 play duo rex,ada #2",
        "1 rest ada",
        "1 safe_stop rex,ada (rule x)",
        "1 write x.do[4] rex",
        "1 write x.do[5] ada",
        "1 write x.do[6] rex,ada",
        "1 rest rex,ada",
        "1 safe_stop rex (rule x)",
    ]
    assert rig.engine.playing("rex") is None  # the stops took the loop's performers back


def test_a_stop_gives_the_performers_back(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: a, when: [{trigger: go}], do: [{loop: duo}]}
        - {name: b, when: [{trigger: halt}], do: [{stop: [ada]}]}
        """, "triggers: [go, halt]\n")
    rig.engine.trigger("go", 0.0)
    assert (rig.engine.playing("rex"), rig.engine.playing("ada")) == ("duo", "duo")
    rig.engine.trigger("halt", 1.0)
    assert (rig.engine.playing("rex"), rig.engine.playing("ada")) == ("duo", None)


def test_a_loop_plays_again_until_it_is_cut_and_a_stale_end_is_ignored(tmp_path: Path
                                                                        ) -> None:
    rig = Rig(tmp_path, """\
        - {name: l, when: [{startup: true}], do: [{loop: one}]}
        - {name: after, when: [{routine_ended: one}], do: [{publish: ended}]}
        """)
    first = rig.last_play()
    rig.engine.routine_ended("rex", first, 1.0, True)
    second = rig.last_play()
    assert second != first and rig.stage.calls[-1] == f"1 play one rex #{second}"
    rig.engine.routine_ended("rex", first, 1.5, True)  # the old play's end: nothing
    assert len(rig.stage.calls) == 2 and rig.engine.playing("rex") == "one"
    rig.engine.routine_ended("rex", second, 2.0, False)  # cut: not played again, no trigger
    assert rig.engine.playing("rex") is None
    assert rig.notes == ["0 l fired: start-up", "0 l action: rex loops one"]


def test_a_routines_end_fires_only_for_the_performers_named(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: p, when: [{trigger: go}], do: [{play: duo}, {publish: both}]}
        - {name: e, mode: parallel, when: [{routine_ended: duo, performers: [ada]}],
           do: [{publish: ada_done}]}
        - {name: o, mode: parallel, when: [{routine_ended: one}], do: [{publish: other}]}
        """, "triggers: [go]\n")
    rig.engine.trigger("go", 0.0)
    play = rig.last_play()
    rig.engine.routine_ended("rex", play, 1.0, True)
    assert rig.notes[-1] == "0 p action: rex, ada plays duo"  # rex is not ada; p waits
    rig.engine.routine_ended("ada", play, 1.2, True)
    assert rig.notes[-3:] == ["1.2 p published: both", "1.2 e fired: duo ended on ada",
                              "1.2 e published: ada_done"]


def test_telemetry_triggers_default_clears_and_their_performers(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: rexlow, mode: parallel, when: [{battery_below: 5, performers: [rex]}],
           do: [{publish: rexlow}]}
        - {name: low, mode: parallel, when: [{battery_below: 20, performers: [ada]}],
           do: [{publish: low}]}
        - {name: adatilt, mode: parallel, when: [{tilt_beyond: 10, performers: [ada]}],
           do: [{publish: adatilt}]}
        - {name: tilt, mode: parallel, when: [{tilt_beyond: 40, performers: [rex]}],
           do: [{publish: tilt}]}
        """)
    # The battery's clear is 5 above the level (25): 24.9 does not re-arm, 25 does.
    for t, value in enumerate([30, 20, 19.9, 24.9, 19, 25, 19.5]):
        rig.read(float(t), "ada", "battery", value)
    rig.read(10.0, "rex", "battery", 6)  # not ada's, nor below rex's 5
    # The tilt's clear is half the angle (20): 20 does not re-arm, 19.9 does.
    for t, (name, value) in enumerate([("imu_pitch", 40), ("imu_pitch", -40.1),
                                       ("imu_pitch", 20), ("imu_pitch", 50),
                                       ("imu_pitch", 19.9), ("imu_roll", 41)], start=20):
        rig.read(float(t), "rex", name, value)
    rig.read(30.0, "ada", "imu_roll", 5)  # not rex's, nor beyond ada's 10
    fired = [n for n in rig.notes if "fired" in n]
    assert fired == [
        "2 low fired: ada battery 20% < 20%",
        "6 low fired: ada battery 20% < 20%",
        "21 tilt fired: rex tilted 40 deg > 40",
        "25 tilt fired: rex tilted 41 deg > 40",
    ]


def test_a_fallen_status_or_fault_is_a_tilt_of_90_degrees(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: fall, mode: parallel, when: [{tilt_beyond: 60}], do: [{publish: fell}]}
        """)
    rig.read(1.0, "ada", "status", 1)  # a Rider standing
    rig.read(2.0, "ada", "status", 0)  # fallen (0x00 on a Rider)
    rig.read(3.0, "ada", "status", 1)  # up again: 0 degrees from the status, re-armed
    rig.read(4.0, "ada", "imu_roll", 10)
    rig.engine.on_event(FaultRaised(5.0, "ada", "port closed"))  # not a fall
    rig.engine.on_event(FaultRaised(6.0, "ada", "rider reports status 0x00 (fallen)"))
    rig.engine.on_event(FaultRaised(7.0, "nobody", "fallen"))
    assert [n for n in rig.notes if "fired" in n] == [
        "2 fall fired: ada tilted 90 deg > 60", "6 fall fired: ada tilted 90 deg > 60"]


def test_losing_a_robot_fires_its_offline_rules_once_and_online_when_heard(tmp_path: Path
                                                                          ) -> None:
    rig = Rig(tmp_path, """\
        - {name: gone, mode: parallel, when: [{offline: 30, performers: [ada]}],
           do: [{publish: lost}]}
        - {name: any, mode: parallel, when: [{offline: 30}], do: [{publish: lost_any}]}
        - {name: back, mode: parallel, when: [{online: true, performers: [ada]}],
           do: [{publish: back}]}
        """)
    rig.engine.lost("nobody", "relay silent", 1.0)
    rig.engine.lost("rex", "relay silent", 1.0)
    rig.engine.lost("ada", "relay silent", 2.0)
    rig.engine.lost("ada", "relay silent", 3.0)  # already offline: once
    assert [n for n in rig.notes if "fired" in n] == [
        "1 any fired: rex offline (relay silent)",
        "2 gone fired: ada offline (relay silent)",
        "2 any fired: ada offline (relay silent)",
    ]
    rig.read(4.0, "rex", "battery", 90)
    rig.read(5.0, "ada", "battery", 90)
    rig.read(5.5, "ada", "battery", 90)  # online already: once
    assert [n for n in rig.notes if "fired" in n][3:] == ["5 back fired: ada back online"]
    rig.engine.lost("ada", "relay silent", 6.0)  # re-armed by the reading
    assert rig.notes[-4:] == ["6 gone fired: ada offline (relay silent)", "6 gone published: lost",
                              "6 any fired: ada offline (relay silent)",
                              "6 any published: lost_any"]


def test_timers_after_every_and_at_in_time_order(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: e, mode: parallel, when: [{every: 4}], do: [{publish: e}]}
        - {name: a, mode: parallel, when: [{after: 2.5}], do: [{publish: a}]}
        - {name: t, mode: parallel, when: [{at: "08:00:03"}, {at: "08:00"}],
           do: [{publish: t}]}
        """)
    assert rig.engine.next_deadline() == 0.0  # 08:00 is now: today, not tomorrow
    rig.engine.advance(9.0)
    assert [n for n in rig.notes if "fired" in n] == [
        "0 t fired: at 08:00", "2.5 a fired: after 2.5 s", "3 t fired: at 08:00:03",
        "4 e fired: every 4 s"]
    # Each timer once by 9 s: every 4 s is next at 8, then 12; the clock times tomorrow.
    rig.engine.advance(9.0)
    assert [n for n in rig.notes if "fired" in n][4:] == ["8 e fired: every 4 s"]
    day = 24 * 3600
    assert sorted(rig.engine._timers.values()) == [12.0, day + 0.0, day + 3.0]


def test_time_windows_of_the_day(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - name: w
          mode: parallel
          when: [{trigger: go}]
          if: {or: [{time: {after: "08:00:30", before: "08:01:30"}},
                    {time: {after: "23:00", before: "00:00:10"}}]}
          do: [{publish: in}]
        - {name: from, mode: parallel, when: [{trigger: go}],
           if: {time: {after: "08:02"}}, do: [{publish: from}]}
        - {name: until, mode: parallel, when: [{trigger: go}],
           if: {time: {before: "08:00:01"}}, do: [{publish: until}]}
        - {name: nine, mode: parallel, when: [{trigger: go}],
           if: {time: {after: "08:59:30", before: "09:00"}}, do: [{publish: nine}]}
        """, "triggers: [go]\n")
    # The clock reads 08:00 at 0 s, 08:59:59 at 3599 s, 23:00 at 54000 s and 00:00:09 the
    # next day at 57609 s.
    for t in (0, 29, 30, 89, 90, 119, 120, 3599, 3600, 53999, 54000, 57609, 57610):
        rig.engine.trigger("go", float(t))
    published = [n.split()[0] + " " + n.split()[-1] for n in rig.notes if "published" in n]
    assert published == ["0 until", "30 in", "89 in", "120 from", "3599 from", "3599 nine",
                         "3600 from", "53999 from", "54000 in", "54000 from",
                         "57609 in", "57609 until", "57610 until"]


def test_conditions_all_any_not_performer_telemetry_and_set(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: p, when: [{trigger: go}], do: [{loop: one}]}
        - name: c
          mode: parallel
          when: [{trigger: ask}]
          if: {and: [{performer: rex, is: playing, routine: one},
                     {performer: ada, is: idle},
                     {not: {in_set: b}},
                     {telemetry: {performer: ada, name: battery, above: 20, below: 50}},
                     {telemetry: {performer: rex, name: tilt, below: 30}},
                     {time: {after: "08:00"}},
                     {not: {time: {before: "07:00"}}}]}
          do: [{publish: yes}]
        - {name: s, when: [{trigger: sw}], do: [{switch: b}]}
        """, "triggers: [go, ask, sw]\nsets: [a, b]\ninitial: a\n")
    eng = rig.engine

    def ask(t: float) -> bool:
        eng.trigger("ask", t)
        return rig.notes[-1].endswith("published: yes")

    rig.read(0.0, "ada", "battery", 30)
    rig.read(0.0, "rex", "imu_roll", 10)
    assert not ask(1.0)  # rex idle
    eng.trigger("go", 2.0)
    assert ask(3.0)
    for name, value, holds in [("battery", 20, False), ("battery", 50, False),
                               ("battery", 49.9, True), ("battery", 20.1, True)]:
        rig.read(4.0, "ada", name, value)
        assert ask(4.0) is holds, (name, value)
    rig.read(5.0, "rex", "imu_pitch", -30)
    assert not ask(5.0)  # tilt 30: not below 30
    rig.read(5.0, "rex", "imu_pitch", -29)
    assert ask(5.0)
    eng.trigger("sw", 6.0)
    assert not ask(7.0)
    assert rig.notes[-1] == "7 c skipped: trigger ask: conditions do not hold"


def test_a_condition_on_a_reading_never_made_does_not_hold(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - name: c
          when: [{trigger: ask}]
          if: {or: [{telemetry: {performer: ada, name: tilt, above: -1}},
                    {telemetry: {performer: rex, name: battery, below: 101}},
                    {performer: rex, is: playing}]}
          do: [{publish: yes}]
        """, "triggers: [ask]\n")
    rig.engine.trigger("ask", 1.0)
    assert rig.notes == ["1 c skipped: trigger ask: conditions do not hold"]


def test_switching_sets_cuts_runs_rests_loops_and_starts_the_new_set(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: w, sets: [a], mode: queued, when: [{trigger: go}],
           do: [{wait: 10}, {publish: late}]}
        - {name: stay, when: [{trigger: go}], do: [{wait: 10}, {publish: stayed}]}
        - {name: l, sets: [a], when: [{trigger: go}], do: [{loop: two}]}
        - {name: k, when: [{trigger: go}], do: [{loop: one}]}
        - {name: s, when: [{trigger: sw}], do: [{switch: b}, {switch: b}, {publish: in_b}]}
        - {name: u, sets: [b], when: [{startup: true}, {after: 1}], do: [{publish: up}]}
        """, "triggers: [go, sw]\nsets: [a, b]\ninitial: a\n")
    rig.engine.trigger("go", 0.0)
    rig.engine.trigger("go", 1.0)  # w queues it; stay is single and skips it
    rig.engine.trigger("sw", 2.0)
    assert rig.notes[-6:] == [
        "2 s fired: trigger sw",
        "2 s action: switch to set b",
        "2 w cut: set b does not include it",
        "2 u fired: start-up of set b",
        "2 u published: up",
        "2 s published: in_b",
    ]
    assert rig.stage.calls[-1] == "2 rest ada"  # l's loop (set a); k's goes on
    assert (rig.engine.playing("rex"), rig.engine.playing("ada")) == ("one", None)
    assert rig.engine.next_deadline() == 3.0  # b's after 1 s, from the switch
    rig.engine.advance(20.0)
    assert rig.notes[-3:] == ["3 u fired: after 1 s", "3 u published: up",
                              "20 stay published: stayed"]
    assert not any("late" in n or "from the queue" in n for n in rig.notes)


def test_a_start_up_without_sets_and_a_preempted_wait(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - {name: st, when: [{startup: true}], do: [{play: one}, {publish: never}]}
        - {name: hi, priority: 5, when: [{trigger: go}], do: [{play: one}]}
        - {name: lo, when: [{trigger: lo}], do: [{play: one}]}
        - {name: safe, safety: true, when: [{trigger: fall}], do: [{play: one}]}
        """, "triggers: [go, lo, fall]\n")
    rig.engine.trigger("go", 1.0)
    rig.engine.trigger("lo", 2.0)
    rig.engine.trigger("fall", 3.0)
    rig.engine.trigger("go", 4.0)
    assert rig.notes == [
        "0 st fired: start-up",
        "0 st action: rex plays one",
        "1 hi fired: trigger go",
        "1 st cut: rex taken by rule hi",
        "1 hi action: rex plays one",
        "2 lo fired: trigger lo",
        "2 lo refused: rex is held by rule hi (higher rank)",
        "3 safe fired: trigger fall",
        "3 hi cut: rex taken by rule safe",
        "3 safe action: rex plays one",
        "4 hi fired: trigger go",
        "4 hi refused: rex is held by rule safe (higher rank)",
    ]


@pytest.mark.parametrize("priority", [0, 99])
def test_any_safety_rule_outranks_any_priority(tmp_path: Path, priority: int) -> None:
    rig = Rig(tmp_path, f"""\
        - {{name: safe, safety: true, when: [{{trigger: fall}}], do: [{{play: one}}]}}
        - {{name: hi, priority: {priority}, when: [{{trigger: go}}], do: [{{play: one}}]}}
        """, "triggers: [go, fall]\n")
    rig.engine.trigger("fall", 1.0)
    rig.engine.trigger("go", 2.0)
    assert rig.notes[-1] == "2 hi refused: rex is held by rule safe (higher rank)"


def test_a_switch_arms_the_timers_again_from_the_switch(tmp_path: Path) -> None:
    # y (every set) is due at 3 s, but s switches sets at 1 s: y now counts from there (4 s),
    # even within the one advance that reaches both; x (set a only) is gone, and the clock
    # time of t is still 08:00:03, reached in that advance.
    rig = Rig(tmp_path, """\
        - {name: s, sets: [a], when: [{after: 1}], do: [{switch: b}]}
        - {name: x, sets: [a], when: [{after: 2}], do: [{publish: x}]}
        - {name: t, when: [{at: "08:00:03"}], do: [{publish: t}]}
        - {name: y, mode: parallel, when: [{every: 3}], do: [{publish: y}]}
        """, "sets: [a, b]\ninitial: a\n")
    rig.engine.advance(3.5)
    assert [n for n in rig.notes if "fired" in n] == ["1 s fired: after 1 s",
                                                     "3 t fired: at 08:00:03"]
    assert rig.engine.next_deadline() == 4.0
    rig.engine.advance(4.0)
    assert rig.notes[-1] == "4 y published: y"
    assert rig.engine.next_deadline() == 7.0


def test_clock_times_to_the_second_and_a_late_advance(tmp_path: Path) -> None:
    # Started a quarter second after 08:00:00: 08:00:03 is 2.75 s later, not 3.
    rig = Rig(tmp_path, """\
        - {name: t, mode: parallel, when: [{at: "08:00:03"}], do: [{publish: t}]}
        """, start=0.25)
    assert rig.engine.next_deadline() == 3.0
    # An advance a second short of a day late fires it, and plans it for the next second
    # (the clock time comes round then), not a day after that.
    rig.engine.advance(24 * 3600 + 2.0)
    assert rig.notes[-1] == "3 t published: t"
    assert rig.engine.next_deadline() == 24 * 3600 + 3.0


def test_each_trigger_and_each_performer_has_its_own_edge(tmp_path: Path) -> None:
    rig = Rig(tmp_path, """\
        - name: low
          mode: parallel
          when: [{battery_below: 30, clear: 90}, {battery_below: 10, clear: 90}]
          do: [{publish: low}]
        - name: tilt
          mode: parallel
          when: [{tilt_beyond: 30, clear: 5}, {tilt_beyond: 60, clear: 5}]
          do: [{publish: tilt}]
        """)
    for t, (performer, name, value) in enumerate([
        ("ada", "battery", 25), ("ada", "battery", 5), ("rex", "battery", 25),
        ("ada", "battery", 50),  # not cleared (90): nothing again
        ("ada", "imu_roll", 40), ("ada", "imu_roll", 70), ("rex", "imu_roll", 40),
        ("ada", "imu_roll", 10),  # 10 is not below the clear of 5
        ("ada", "imu_roll", 45),
    ]):
        rig.read(float(t), performer, name, value)
    assert [n for n in rig.notes if "fired" in n] == [
        "0 low fired: ada battery 25% < 30%",
        "1 low fired: ada battery 5% < 10%",
        "2 low fired: rex battery 25% < 30%",
        "4 tilt fired: ada tilted 40 deg > 30",
        "5 tilt fired: ada tilted 70 deg > 60",
        "6 tilt fired: rex tilted 40 deg > 30",
    ]


def test_taking_a_performer_a_run_only_loops_on_does_not_cut_the_run(tmp_path: Path) -> None:
    # a loops one on rex and waits; b takes rex: a's loop ends there, its run goes on.
    rig = Rig(tmp_path, """\
        - {name: a, when: [{trigger: go}], do: [{loop: one}, {wait: 5}, {publish: a_done}]}
        - {name: b, when: [{trigger: take}], do: [{play: one}]}
        """, "triggers: [go, take]\n")
    rig.engine.trigger("go", 0.0)
    rig.engine.trigger("take", 1.0)
    rig.engine.advance(5.0)
    assert rig.notes == ["0 a fired: trigger go", "0 a action: rex loops one",
                         "1 b fired: trigger take", "1 b action: rex plays one",
                         "5 a published: a_done"]
