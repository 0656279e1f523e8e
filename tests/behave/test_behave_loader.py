"""Behaviour files: the bundled one loads, the schema is current, and bad files are rejected
with an error at file:line:col (each case names the position and a part of the message)."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

from xgo_show.behave import check_behaviour, load_behaviour
from xgo_show.behave.schema import behaviour_json_schema
from xgo_show.errors import ChoreographyError

ROOT = Path(__file__).resolve().parents[2]
EXHIBITION = ROOT / "behaviours" / "exhibition" / "exhibition.yaml"
ROUTINES = ROOT / "behaviours" / "exhibition" / "routines"
GREET = ROUTINES / "greet.yaml"

HEAD = f"""\
behaviour: Test
performers:
  rex: {{model: mini}}
routines:
  greet: {ROUTINES / "greet.yaml"}
  sit: {ROUTINES / "sit.yaml"}
triggers: [visitor]
"""  # lines 1-7; a case's own text starts at line 8
GOOD_RULE = """\
rules:
  - name: greet
    when: [{trigger: visitor}]
    do: [{play: greet}]
"""


def test_bundled_behaviour_loads_and_compiles_every_routine() -> None:
    behaviour = load_behaviour(EXHIBITION)
    assert set(behaviour.routines) == {"idle", "greet", "sit", "get_up", "show"}
    assert behaviour.routine_performers("greet") == ("rex",)


def test_committed_schema_is_current_and_bundled_file_has_modeline() -> None:
    committed = json.loads((ROOT / "schemas" / "behaviour.schema.json").read_text())
    assert committed == behaviour_json_schema(), (
        "regenerate: python -m xgo_show.behave.schema > schemas/behaviour.schema.json"
    )
    first = EXHIBITION.read_text().splitlines()[0]
    assert first == "# yaml-language-server: $schema=../../schemas/behaviour.schema.json"


CASES = [
    # (name, text after HEAD, every error after the file's path, in order)
    ("no_rules", "",
     ["1:1: error: rules: missing required field 'rules'"]),
    ("unknown_field", GOOD_RULE + "colour: red\n",
     ["12:1: error: colour: unknown field 'colour' (allowed: behaviour, performers, routines, "
      "triggers, sets, initial, offline_after, rules)"]),
    ("trigger_kind", "rules:\n  - name: a\n    when: [{triger: visitor}]\n"
     "    do: [{play: greet}]\n",
     ["10:12: error: rules[0].when[0]: a trigger needs exactly one kind key: trigger, "
      "battery_below, tilt_beyond, offline, online, routine_ended, after, every, at, startup"]),
    ("two_kinds", "rules:\n  - name: a\n    when: [{trigger: visitor, startup: true}]\n"
     "    do: [{play: greet}]\n",
     ["10:12: error: rules[0].when[0]: a trigger needs exactly one kind key: trigger, "
      "battery_below, tilt_beyond, offline, online, routine_ended, after, every, at, startup"]),
    ("unknown_trigger", "rules:\n  - name: a\n    when: [{trigger: visiter}]\n"
     "    do: [{play: greet}]\n",
     ["7:12: error: triggers[0]: trigger 'visitor' is declared but no rule waits for it",
      "10:22: error: rules[0].when[0].trigger: no trigger 'visiter'; did you mean 'visitor'? "
      "(triggers: visitor)"]),
    ("missing_routine", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: dance}]\n",
     ["11:17: error: rules[0].do[0].play: no routine 'dance' (routines: greet, sit)"]),
    ("missing_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: greet, performers: [ivy]}]\n",
     ["11:37: error: rules[0].do[0].performers[0]: no performer 'ivy' (performers: rex)"]),
    ("loop_missing", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{loop: idle}]\n",
     ["11:17: error: rules[0].do[0].loop: no routine 'idle' (routines: greet, sit)"]),
    ("battery_range", "rules:\n  - name: a\n    when: [{battery_below: 120}, {trigger: visitor}]\n"
     "    do: [{play: sit}]\n",
     ["10:28: error: rules[0].when[0].battery_below: 120% is too large: give 0 to 100%"]),
    ("battery_clear", "rules:\n  - name: a\n    when: [{battery_below: 20, clear: 10}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n",
     ["10:39: error: rules[0].when[0].clear: clear: must be above the level (hysteresis: it "
      "re-arms the trigger)"]),
    ("tilt_clear", "rules:\n  - name: a\n    when: [{tilt_beyond: 45, clear: 50}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n",
     ["10:37: error: rules[0].when[0].clear: clear: must be below the angle (hysteresis: it "
      "re-arms the trigger)"]),
    ("tilt_zero", "rules:\n  - name: a\n    when: [{tilt_beyond: 0}, {trigger: visitor}]\n"
     "    do: [{play: sit}]\n",
     ["10:26: error: rules[0].when[0].tilt_beyond: 0 deg is too small: give more than 0 and at "
      "most 180 deg"]),
    ("bad_clock", "rules:\n  - name: a\n    when: [{at: '25:00'}, {trigger: visitor}]\n"
     "    do: [{play: sit}]\n",
     ["10:17: error: rules[0].when[0].at: should be a value in the expected form, not '25:00'"]),
    ("every_negative", "rules:\n  - name: a\n    when: [{every: -3}, {trigger: visitor}]\n"
     "    do: [{play: sit}]\n",
     ["10:20: error: rules[0].when[0].every: -3 s is too small: give more than 0 s"]),
    ("routine_ended_missing", "rules:\n  - name: a\n    when: [{routine_ended: bow}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n",
     ["10:28: error: rules[0].when[0].routine_ended: no routine 'bow' (routines: greet, sit)"]),
    ("offline_performer", "rules:\n  - name: a\n    when: [{offline: 2, performers: [max]}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n",
     ["10:38: error: rules[0].when[0].performers[0]: no performer 'max' (performers: rex)"]),
    ("condition_kind", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {performr: rex, is: idle}\n    do: [{play: sit}]\n",
     ["11:9: error: rules[0].if: a condition needs exactly one kind key: performer, telemetry, "
      "time, in_set, and, or, not"]),
    ("condition_state", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {performer: rex, is: sleeping}\n    do: [{play: sit}]\n",
     ["11:30: error: rules[0].if.is: should be one of 'idle' or 'playing', not 'sleeping'"]),
    ("condition_nested_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {and: [{not: {performer: ivy, is: idle}}]}\n    do: [{play: sit}]\n",
     ["11:34: error: rules[0].if.and[0].not.performer: no performer 'ivy' (performers: rex)"]),
    ("telemetry_no_threshold", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {telemetry: {performer: rex, name: battery}}\n    do: [{play: sit}]\n",
     ["11:21: error: rules[0].if.telemetry: give below:, above: or both"]),
    ("empty_time_window", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {time: {after: '10:00', before: '10:00'}}\n    do: [{play: sit}]\n",
     ["11:16: error: rules[0].if.time: an empty window: after and before are both 10:00"]),
    ("bad_mode", GOOD_RULE + "    mode: sometimes\n",
     ["12:11: error: rules[0].mode: should be one of 'single', 'restart', 'queued' or 'parallel', "
      "not 'sometimes'"]),
    ("priority_range", GOOD_RULE + "    priority: 100\n",
     ["12:15: error: rules[0].priority: 100 is too large: give 0 to 99"]),
    ("duplicate_rule", GOOD_RULE + "  - name: greet\n    when: [{trigger: visitor}]\n"
     "    do: [{play: sit}]\n",
     ["12:11: error: rules[1].name: a second rule named 'greet' (rules[0])"]),
    ("unused_trigger", "rules:\n  - name: a\n    when: [{startup: true}]\n    do: [{play: sit}]\n",
     ["7:12: error: triggers[0]: trigger 'visitor' is declared but no rule waits for it"]),
    ("switch_unknown_set", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{switch: night}]\n",
     ["11:19: error: rules[0].do[0].switch: no set 'night' (sets: none declared)"]),
    ("sets_without_initial", "sets: [day]\n" + GOOD_RULE,
     ["8:7: error: sets: sets: needs initial: (the set active at start-up)"]),
    ("action_kind", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{dance: greet}]\n",
     ["11:10: error: rules[0].do[0]: an action needs exactly one kind key: play, loop, stop, "
      "safe_stop, wait, set, led, publish, switch"]),
    ("wait_zero", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{wait: 0}, {play: sit}]\n",
     ["11:17: error: rules[0].do[0].wait: 0 s is too small: give more than 0 s"]),
    ("not_a_mapping", None,
     ["1:1: error: a behaviour is a mapping with behaviour, performers, routines and rules, not "
      "list"]),
    ("led_without_leds", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{led: {all: red}}]\n",
     ["11:16: error: rules[0].do[0].led: rex: led: the XGO-Mini has no LEDs"]),
    ("set_bad_value", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{set: {pace: sloww}}]\n",
     ["11:16: error: rules[0].do[0].set: rex: set.pace: pace: unknown value 'sloww'; one of "
      "normal, slow, fast"]),
    ("set_empty", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{set: {}}]\n",
     ["11:16: error: rules[0].do[0].set: {} is empty: give at least 1 entry (name: value)"]),
    ("set_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{set: {gait: walk}, performers: [ivy]}]\n",
     ["11:43: error: rules[0].do[0].performers[0]: no performer 'ivy' (performers: rex)"]),
    ("led_fade", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{led: {all: red}, fade: 1}]\n",
     ["11:28: error: rules[0].do[0].fade: unknown field 'fade' (allowed: led, performers)"]),
    ("phrase_missing", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: greet, phrase: bow}]\n",
     ["11:32: error: rules[0].do[0].phrase: phrase 'bow' of routine 'greet': routine has no "
      "phrase 'bow' (its phrases: nod)"]),
    ("phrase_bad_value", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: greet, phrase: nod, with: {depth: 99}}]\n",
     [f"11:32: error: rules[0].do[0].phrase: phrase 'nod' of routine 'greet': {GREET}:19:7: "
      f"error: tracks.rex[0].with.depth -> phrase nod cues[0].move.pitch[0]: pitch = 99 deg is "
      f"out of range [-22, 22] deg"]),
    # every name a rule gives is checked where it is given
    ("initial_unknown", "sets: [day]\ninitial: night\n" + GOOD_RULE,
     ["9:10: error: initial: no set 'night' (sets: day)"]),
    ("rule_set_unknown", "sets: [day]\ninitial: day\n" + GOOD_RULE + "    sets: [day, night]\n",
     ["14:17: error: rules[0].sets[1]: no set 'night' (sets: day)"]),
    ("duplicate_rules", GOOD_RULE + "  - name: greet\n    when: [{trigger: visitor}]\n"
     "    do: [{play: sit}]\n  - name: greet\n    when: [{trigger: visitor}]\n"
     "    do: [{play: sit}]\n",
     ["12:11: error: rules[1].name: a second rule named 'greet' (rules[0])",
      "15:11: error: rules[2].name: a second rule named 'greet' (rules[0])"]),
    ("battery_clear_at_level", "rules:\n  - name: a\n    when: [{battery_below: 20, clear: 20}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n",
     ["10:39: error: rules[0].when[0].clear: clear: must be above the level (hysteresis: it "
      "re-arms the trigger)"]),
    ("tilt_clear_at_angle", "rules:\n  - name: a\n    when: [{tilt_beyond: 45, clear: 45}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n",
     ["10:37: error: rules[0].when[0].clear: clear: must be below the angle (hysteresis: it "
      "re-arms the trigger)"]),
    ("condition_or_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {or: [{performer: rex, is: idle}, {performer: ivy, is: idle}]}\n"
     "    do: [{play: sit}]\n",
     ["11:55: error: rules[0].if.or[1].performer: no performer 'ivy' (performers: rex)"]),
    ("condition_routine", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {performer: rex, is: playing, routine: bow}\n    do: [{play: sit}]\n",
     ["11:48: error: rules[0].if.routine: no routine 'bow' (routines: greet, sit)"]),
    ("telemetry_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {telemetry: {performer: ivy, name: battery, below: 20}}\n    do: [{play: sit}]\n",
     ["11:33: error: rules[0].if.telemetry.performer: no performer 'ivy' (performers: rex)"]),
    ("time_without_bounds", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {time: {}}\n    do: [{play: sit}]\n",
     ["11:16: error: rules[0].if.time: give after:, before: or both (HH:MM)"]),
    ("in_set_none_declared", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {in_set: night}\n    do: [{play: sit}]\n",
     ["11:18: error: rules[0].if.in_set: no set 'night' (sets: none declared)"]),
    ("stop_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{stop: [rex, ivy]}, {safe_stop: [max]}, {stop: all}, {safe_stop: all}]\n",
     ["11:23: error: rules[0].do[0].stop[1]: no performer 'ivy' (performers: rex)",
      "11:43: error: rules[0].do[1].safe_stop[0]: no performer 'max' (performers: rex)"]),
    ("actions_after_a_bad_one", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{set: {gait: walk}, performers: [ivy]}, {play: dance, phrase: nod},\n"
     "         {set: {pace: sloww}}, {play: greet, phrase: bow}]\n",
     ["11:43: error: rules[0].do[0].performers[0]: no performer 'ivy' (performers: rex)",
      "11:57: error: rules[0].do[1].play: no routine 'dance' (routines: greet, sit)",
      "12:16: error: rules[0].do[2].set: rex: set.pace: pace: unknown value 'sloww'; one of "
      "normal, slow, fast",
      "12:54: error: rules[0].do[3].phrase: phrase 'bow' of routine 'greet': routine has no "
      "phrase 'bow' (its phrases: nod)"]),
    ("with_without_phrase", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: greet, with: {depth: 5}}]\n",
     ["11:30: error: rules[0].do[0].with: with: gives a phrase's parameter values: add phrase:"]),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_invalid_behaviour_reports_located_error(
    case: tuple[str, str | None, list[str]], tmp_path: Path
) -> None:
    name, body, errors = case
    path = tmp_path / f"{name}.yaml"
    path.write_text("- just\n- a list\n" if body is None else HEAD + body)
    behaviour, diags = check_behaviour(path)
    assert behaviour is None
    assert [d.format() for d in diags] == [f"{path}:{e}" for e in errors]


def _routines(tmp_path: Path) -> None:
    """duo: rex (a Mini) and ada (a Rider), with a phrase of two parameters both can play;
    solo: rex alone."""
    (tmp_path / "duo.yaml").write_text(textwrap.dedent("""\
        show: duo
        performers: {rex: {model: mini}, ada: {model: rider}}
        phrases:
          rise:
            params: {to: 100, hold: 1}
            cues:
              - move: {body_z: $to}
                duration: $hold
        tracks:
          rex: [{phrase: rise}]
          ada: [{phrase: rise}]
        """))
    (tmp_path / "solo.yaml").write_text(
        "show: solo\nperformers: {rex: {model: mini}}\n"
        "tracks: {rex: [{move: {body_z: 100}, duration: 1}]}\n")


def _of_three(tmp_path: Path, rules: str) -> Path:
    """A behaviour of rex, ada and ivy playing :func:`_routines`' duo and solo by ``rules``."""
    _routines(tmp_path)
    path = tmp_path / "b.yaml"
    path.write_text("behaviour: B\n"
                    "performers: {rex: {model: mini}, ada: {model: rider}, ivy: {model: mini}}\n"
                    "routines: {duo: duo.yaml, solo: solo.yaml}\nrules:\n"
                    + textwrap.indent(textwrap.dedent(rules), "  "))
    return path


def test_phrases_and_writes_are_compiled_under_their_names(tmp_path: Path) -> None:
    path = _of_three(tmp_path, """\
        - name: r
          when: [{startup: true}]
          do:
            - {play: duo, phrase: rise}
            - {play: duo, phrase: rise, with: {to: 110, hold: 2}, performers: [ada]}
            - {play: duo, phrase: rise, with: {to: 105}, performers: [rex]}
            - {set: {body_z: 90}, performers: [ada]}
            - {set: {body_z: 95}}
        """)
    b = load_behaviour(path)
    assert b.path == str(path)
    assert {name: b.routine_performers(name) for name in b.routines} == {
        "duo": ("rex", "ada"),
        "solo": ("rex",),
        "duo.rise": ("rex", "ada"),
        "duo.rise(hold=2,to=110)": ("ada",),
        "duo.rise(to=105)": ("rex",),
    }
    assert b.routines["duo.rise(hold=2,to=110)"].performers[0].end == 2.0
    assert b.routines["duo.rise(to=105)"].performers[0].end == 1.0
    assert {k: tuple(p.name for p in s.performers) for k, s in b.writes.items()} == {
        "r.do[3]": ("ada",), "r.do[4]": ("rex", "ada", "ivy")}
    assert [p.model for p in b.writes["r.do[4]"].performers] == ["mini", "rider", "mini"]


def test_a_rules_performers_must_have_a_part_in_what_it_plays(tmp_path: Path) -> None:
    path = _of_three(tmp_path, """\
        - {name: a, when: [{startup: true}], do: [{play: duo, performers: [ivy, rex]}]}
        - {name: b, when: [{startup: true}], do: [{loop: solo, performers: [ada]}]}
        """)
    _, diags = check_behaviour(path)
    assert [d.format() for d in diags] == [
        f"{path}:5:70: error: rules[0].do[0].performers[0]: routine 'duo' has no part for "
        "'ivy' (it has rex, ada)",
        f"{path}:6:71: error: rules[1].do[0].performers[0]: routine 'solo' has no part for "
        "'ada' (it has rex)",
    ]


def test_routines_that_do_not_fit_the_behaviour_are_errors_and_left_out(tmp_path: Path) -> None:
    _routines(tmp_path)
    (tmp_path / "bad.yaml").write_text("show: x\nperformers: {rex: {model: mini}}\n"
                                      "tracks: {rex: [{move: {pitch: 99}, duration: 1},\n"
                                      "              {move: {roll: 99}, duration: 1}]}\n")
    (tmp_path / "rider.yaml").write_text("show: y\nperformers: {rex: {model: rider}}\n"
                                        "tracks: {rex: [{move: {body_z: 100}, duration: 1}]}\n")
    (tmp_path / "fast.yaml").write_text("show: f\nperformers: {rex: {model: mini}}\n"
                                       "tracks: {rex: [{move: {pitch: 20}, duration: 0.05}]}\n")
    path = tmp_path / "b.yaml"
    path.write_text(textwrap.dedent("""\
        behaviour: B
        performers: {rex: {model: mini}, ivy: {model: mini}}
        routines:
          gone: nowhere.yaml
          gone2: nowhere2.yaml
          bad: bad.yaml
          bad2: bad.yaml
          duo: duo.yaml
          rider: rider.yaml
          solo: solo.yaml
          fast: fast.yaml
        rules:
          - name: r
            when: [{startup: true}]
            do: [{play: duo, performers: [ivy]}, {play: rider, performers: [ivy]},
                 {play: duo, phrase: rise}, {play: solo, performers: [ivy]}]
        """))
    # duo and rider are left out: a rule playing them on ivy is not told they have no part
    # for ivy, nor is their phrase compiled
    _, diags = check_behaviour(path)
    bad = (f"{tmp_path / 'bad.yaml'}: 2 error(s): {tmp_path / 'bad.yaml'}:3:31: error: "
           "tracks.rex[0].move.pitch: pitch = 99 deg is out of range [-22, 22] deg (and 1 more)")
    assert [d.format() for d in diags] == [
        f"{path}:4:9: error: routines.gone: routine 'gone': no such file "
        f"{str(tmp_path / 'nowhere.yaml')!r}",
        f"{path}:5:10: error: routines.gone2: routine 'gone2': no such file "
        f"{str(tmp_path / 'nowhere2.yaml')!r}",
        f"{path}:6:8: error: routines.bad: routine 'bad' does not load: {bad}",
        f"{path}:7:9: error: routines.bad2: routine 'bad2' does not load: {bad}",
        f"{path}:8:8: error: routines.duo: routine 'duo' has a part for 'ada', not a performer "
        "of this behaviour (rex, ivy)",
        f"{path}:9:10: error: routines.rider: routine 'rider' plays 'rex' as a rider; the "
        "behaviour says mini",
        # a compile's error has a line of its own for each problem: one line here
        f"{path}:11:9: error: routines.fast: routine 'fast' does not load: show 'f' cannot be "
        f"compiled (1 error): {tmp_path / 'fast.yaml'}:3:16: error: tracks.rex: the move to "
        "pitch 20 needs at least 0.69 s under its limits (pitch: velocity 60 deg/s, "
        "acceleration 300 deg/s², jerk 2000 deg/s³) but is given 0.05 s",
        f"{path}:16:63: error: rules[0].do[3].performers[0]: routine 'solo' has no part for "
        "'ivy' (it has rex)",
    ]


def test_an_unknown_model_and_every_error_in_load_behaviours_message(tmp_path: Path) -> None:
    _routines(tmp_path)
    path = tmp_path / "b.yaml"
    path.write_text(textwrap.dedent("""\
        behaviour: B
        performers: {rex: {model: mini}, bob: {model: minni}}
        routines: {solo: solo.yaml}
        rules:
          - {name: r, when: [{startup: true}], do: [{play: soloo}]}
        """))
    with pytest.raises(ChoreographyError) as err:
        load_behaviour(path)
    errors = [
        f"{path}:2:47: error: performers.bob.model: unknown robot model 'minni'; valid: mini, "
        "lite, rider, xarm",
        f"{path}:5:52: error: rules[0].do[0].play: no routine 'soloo'; did you mean 'solo'? "
        "(routines: solo)",
    ]
    assert str(err.value).splitlines() == [f"{path}: 2 error(s):", *errors]
    assert [d.format() for d in err.value.diagnostics] == errors


def test_a_routine_the_compiler_refuses_otherwise_is_an_error_at_the_routine(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Any error of the package's tree from compiling (a profile's layout the merger cannot
    # match, a schedule check), not only a routine's own problems, is told at the routine.
    import xgo_show.compiler
    from xgo_show.errors import ProfileError

    def refuse(show: object) -> None:
        raise ProfileError("mini: 2 bytes at 0x30 do not match the register layout")

    monkeypatch.setattr(xgo_show.compiler, "compile_show", refuse)
    _routines(tmp_path)
    path = tmp_path / "b.yaml"
    path.write_text(textwrap.dedent("""\
        behaviour: B
        performers: {rex: {model: mini}}
        routines: {solo: solo.yaml, again: solo.yaml}
        rules:
          - {name: r, when: [{startup: true}], do: [{play: solo}]}
        """))
    _, diags = check_behaviour(path)
    assert [d.format() for d in diags] == [
        f"{path}:3:18: error: routines.solo: routine 'solo' does not compile: mini: 2 bytes "
        "at 0x30 do not match the register layout",
        f"{path}:3:36: error: routines.again: routine 'again' does not compile: mini: 2 bytes "
        "at 0x30 do not match the register layout",
    ]
