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
    # (name, text after HEAD, "LINE:COL", message part)
    ("no_rules", "", "1:1", "missing required field 'rules'"),
    ("unknown_field", GOOD_RULE + "colour: red\n", "12:1", "unknown field 'colour'"),
    ("trigger_kind", "rules:\n  - name: a\n    when: [{triger: visitor}]\n"
     "    do: [{play: greet}]\n", "10:12", "a trigger needs exactly one kind key"),
    ("two_kinds", "rules:\n  - name: a\n    when: [{trigger: visitor, startup: true}]\n"
     "    do: [{play: greet}]\n", "10:12", "exactly one kind key"),
    ("unknown_trigger", "rules:\n  - name: a\n    when: [{trigger: visiter}]\n"
     "    do: [{play: greet}]\n", "10:22", "no trigger 'visiter'; did you mean 'visitor'?"),
    ("missing_routine", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: dance}]\n", "11:17", "no routine 'dance'"),
    ("missing_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: greet, performers: [ivy]}]\n", "11:37", "no performer 'ivy'"),
    ("loop_missing", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{loop: idle}]\n", "11:17", "no routine 'idle'"),
    ("battery_range", "rules:\n  - name: a\n    when: [{battery_below: 120}, {trigger: visitor}]\n"
     "    do: [{play: sit}]\n", "10:28", "120% is too large: give 0 to 100%"),
    ("battery_clear", "rules:\n  - name: a\n    when: [{battery_below: 20, clear: 10}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n", "10:39", "must be above the level"),
    ("tilt_clear", "rules:\n  - name: a\n    when: [{tilt_beyond: 45, clear: 50}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n", "10:37", "must be below the angle"),
    ("tilt_zero", "rules:\n  - name: a\n    when: [{tilt_beyond: 0}, {trigger: visitor}]\n"
     "    do: [{play: sit}]\n", "10:26", "0 deg is too small: give more than 0 and at most 180 deg"),
    ("bad_clock", "rules:\n  - name: a\n    when: [{at: '25:00'}, {trigger: visitor}]\n"
     "    do: [{play: sit}]\n", "10:17", "not '25:00'"),
    ("every_negative", "rules:\n  - name: a\n    when: [{every: -3}, {trigger: visitor}]\n"
     "    do: [{play: sit}]\n", "10:20", "-3 s is too small: give more than 0 s"),
    ("routine_ended_missing", "rules:\n  - name: a\n    when: [{routine_ended: bow}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n", "10:28", "no routine 'bow'"),
    ("offline_performer", "rules:\n  - name: a\n    when: [{offline: 2, performers: [max]}, "
     "{trigger: visitor}]\n    do: [{play: sit}]\n", "10:38", "no performer 'max'"),
    ("condition_kind", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {performr: rex, is: idle}\n    do: [{play: sit}]\n", "11:9",
     "a condition needs exactly one kind key"),
    ("condition_state", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {performer: rex, is: sleeping}\n    do: [{play: sit}]\n", "11:30",
     "'idle' or 'playing'"),
    ("condition_nested_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {and: [{not: {performer: ivy, is: idle}}]}\n    do: [{play: sit}]\n", "11:34",
     "no performer 'ivy'"),
    ("telemetry_no_threshold", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {telemetry: {performer: rex, name: battery}}\n    do: [{play: sit}]\n", "11:21",
     "give below:, above: or both"),
    ("empty_time_window", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    if: {time: {after: '10:00', before: '10:00'}}\n    do: [{play: sit}]\n", "11:16",
     "an empty window"),
    ("bad_mode", GOOD_RULE + "    mode: sometimes\n", "12:11", "'single', 'restart'"),
    ("priority_range", GOOD_RULE + "    priority: 100\n", "12:15", "100 is too large: give 0 to 99"),
    ("duplicate_rule", GOOD_RULE + "  - name: greet\n    when: [{trigger: visitor}]\n"
     "    do: [{play: sit}]\n", "12:11", "a second rule named 'greet'"),
    ("unused_trigger", "rules:\n  - name: a\n    when: [{startup: true}]\n    do: [{play: sit}]\n",
     "7:12", "declared but no rule waits for it"),
    ("switch_unknown_set", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{switch: night}]\n", "11:19", "no set 'night'"),
    ("sets_without_initial", "sets: [day]\n" + GOOD_RULE, "8:7", "needs initial:"),
    ("action_kind", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{dance: greet}]\n", "11:10", "an action needs exactly one kind key"),
    ("wait_zero", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{wait: 0}, {play: sit}]\n", "11:17", "0 s is too small: give more than 0 s"),
    ("not_a_mapping", None, "1:1", "a behaviour is a mapping"),
    ("led_without_leds", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{led: {all: red}}]\n", "11:16", "rex: led: the XGO-Mini has no LEDs"),
    ("set_bad_value", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{set: {pace: sloww}}]\n", "11:16", "unknown value 'sloww'; one of normal"),
    ("set_empty", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{set: {}}]\n", "11:16", "{} is empty: give at least 1 entry"),
    ("set_performer", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{set: {gait: walk}, performers: [ivy]}]\n", "11:43", "no performer 'ivy'"),
    ("led_fade", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{led: {all: red}, fade: 1}]\n", "11:28", "unknown field 'fade'"),
    ("phrase_missing", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: greet, phrase: bow}]\n", "11:32", "routine has no phrase 'bow'"),
    ("phrase_bad_value", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: greet, phrase: nod, with: {depth: 99}}]\n", "11:32",
     "pitch = 99 deg is out of range"),
    ("with_without_phrase", "rules:\n  - name: a\n    when: [{trigger: visitor}]\n"
     "    do: [{play: greet, with: {depth: 5}}]\n", "11:30", "add phrase:"),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_invalid_behaviour_reports_located_error(
    case: tuple[str, str | None, str, str], tmp_path: Path
) -> None:
    name, body, where, message = case
    path = tmp_path / f"{name}.yaml"
    path.write_text("- just\n- a list\n" if body is None else HEAD + body)
    behaviour, diags = check_behaviour(path)
    assert behaviour is None
    found = [f"{d.origin.line}:{d.origin.column} {d.message}" for d in diags if d.origin]
    assert any(f.startswith(where + " ") and message in f for f in found), (name, found)


def test_routine_file_problems_are_errors_at_load(tmp_path: Path) -> None:
    (tmp_path / "broken.yaml").write_text("show: x\nperformers: {rex: {model: mini}}\n"
                                         "tracks: {rex: [{move: {pitch: 99}, duration: 1}]}\n")
    (tmp_path / "other.yaml").write_text("show: y\nperformers: {ivy: {model: mini}}\n"
                                        "tracks: {ivy: [{move: {pitch: 5}, duration: 1}]}\n")
    path = tmp_path / "b.yaml"
    path.write_text(textwrap.dedent("""\
        behaviour: B
        performers: {rex: {model: mini}}
        routines:
          a: broken.yaml
          b: other.yaml
          c: nowhere.yaml
        rules:
          - {name: r, when: [{startup: true}], do: [{play: a}]}
        """))
    with pytest.raises(ChoreographyError) as err:
        load_behaviour(path)
    text = str(err.value)
    assert "b.yaml:4:6: error: routines.a: routine 'a' does not load" in text
    assert "b.yaml:5:6: error: routines.b: routine 'b' has a part for 'ivy'" in text
    assert "b.yaml:6:6: error: routines.c: routine 'c': no such file" in text
