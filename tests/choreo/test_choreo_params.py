"""Phrase and part parameters: values keep their YAML type, and a bad value is reported where it
was written (the call's ``with:``), with a field path that names the parameter and its use."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.choreo import check_file, load_show
from xgo_show.choreo.resolved import ActionCue, ArmCue, MotionCue, ResolvedShow, SetCue
from xgo_show.diagnostics import Diagnostic

from .conftest import WriteFn

MINI = """
show: T
tempo: {bpm: 120}
performers:
  rex: {model: mini}"""
XARM = """
show: T
tempo: {bpm: 120}
performers:
  arm: {model: xarm}"""
RIDER = """
show: T
tempo: {bpm: 120}
performers:
  bob: {model: rider}"""


def cues(show: ResolvedShow, performer: str) -> tuple[object, ...]:
    return next(t for t in show.tracks if t.performer == performer).cues


def errors(path: Path) -> list[Diagnostic]:
    _, diags = check_file(path)
    return [d for d in diags if d.is_error]


def where(diag: Diagnostic) -> tuple[str, int, int]:
    assert diag.origin is not None
    return Path(diag.origin.file).name, diag.origin.line, diag.origin.column


def spot(path: Path, token: str, nth: int = 1) -> tuple[str, int, int]:
    """(file name, line, column) of the ``nth`` occurrence of ``token`` in ``path``."""
    seen = 0
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        col = line.find(token)
        while col >= 0:
            seen += 1
            if seen == nth:
                return path.name, number, col + 1
            col = line.find(token, col + 1)
    raise AssertionError(f"{token!r} not in {path}")


def error_at(path: Path, token: str) -> Diagnostic:
    """The only error of the routine at ``path``, asserted to point at ``token``."""
    (err,) = errors(path)
    assert where(err) == spot(path, token)
    return err


# -- 1. parameters keep their type --------------------------------------------------------------


def test_integer_parameters_stay_integers(write: WriteFn) -> None:
    path = write(XARM + """
phrases:
  wave:
    params: {base: 500, n: 2}
    cues:
      - repeat: $n
        cues:
          - {pose: {6: $base}, duration: 1}
tracks:
  arm:
    - {phrase: wave}
    - {phrase: wave, with: {base: 450, n: 3}}
""")
    c = cues(load_show(path), "arm")
    assert [x.positions for x in c] == [{6: 500}] * 2 + [{6: 450}] * 3  # type: ignore[attr-defined]
    assert all(type(x.positions[6]) is int for x in c)  # type: ignore[attr-defined]


def test_string_and_number_parameters(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  show_off:
    params: {act: null, bar: 2, gait: trot}
    cues:
      - {action: $act}
      - {at: {bar: $bar}, set: {gait: $gait}}
tracks:
  rex:
    - {phrase: show_off, with: {act: 12}}
    - {at: 6, phrase: show_off, with: {act: stand_up, bar: 3, gait: walk}}
""")
    a, s, b, t = cues(load_show(path), "rex")
    assert isinstance(a, ActionCue) and a.action_id == 12
    assert isinstance(b, ActionCue) and b.name == "stand_up"
    assert isinstance(s, SetCue) and (s.start, s.values) == (2.0, {"gait": "trot"})
    assert isinstance(t, SetCue) and (t.start, t.values) == (6.0 + 4.0, {"gait": "walk"})


def test_fractional_value_for_an_integer_is_reported_at_the_argument(write: WriteFn) -> None:
    path = write(XARM + """
phrases:
  wave:
    params: {base: 500}
    cues:
      - {pose: {6: $base}, duration: 1}
tracks:
  arm:
    - {phrase: wave, with: {base: 450.5}}
""")
    err = error_at(path, "450.5")
    assert err.message == "should be a whole number, not 450.5"
    assert err.path == "tracks.arm[0].with.base -> phrase wave cues[0].pose[6]"


def test_bad_repeat_count_from_a_default_points_at_the_default(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  nod:
    params: {n: 2.5}
    cues:
      - repeat: $n
        cues: [{move: {pitch: 5}, duration: 1}]
tracks:
  rex: [{phrase: nod}]
""")
    err = error_at(path, "2.5")
    assert err.path == "phrases.nod.params.n -> phrase nod cues[0].repeat"


def test_out_of_range_value_is_reported_at_the_argument(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  nod:
    params: {depth: 10}
    cues: [{move: {pitch: $depth}, duration: 1}]
tracks:
  rex:
    - {phrase: nod}
    - {phrase: nod, with: {depth: 99}}
""")
    err = error_at(path, "99")
    assert "out of range" in err.message
    assert err.path == "tracks.rex[1].with.depth -> phrase nod cues[0].move.pitch"


# -- 2. lists as parameter values ---------------------------------------------------------------


def test_list_parameters_where_the_language_takes_lists(write: WriteFn) -> None:
    path = write(RIDER + """
phrases:
  glow:
    params: {colour: [255, 0, 0], path: [5, -5, 0]}
    cues:
      - {led: {all: $colour}}
      - {move: {roll: $path}, duration: 3}
      - {move: {roll: -$path}, duration: 3}
tracks:
  bob:
    - {phrase: glow, with: {colour: "#00ff00", path: [2, 0]}}
""")
    led, *moves = cues(load_show(path), "bob")
    assert isinstance(led, SetCue) and led.values["led1"] == (0, 255, 0)
    assert [m.targets["roll"] for m in moves] == [2, 0, -2, 0]  # type: ignore[attr-defined]


def test_list_where_a_number_is_needed_is_a_clear_error(write: WriteFn) -> None:
    path = write(XARM + """
phrases:
  wave:
    params: {base: 500}
    cues: [{pose: {6: $base}, duration: 1}]
tracks:
  arm:
    - {phrase: wave, with: {base: [1, 2]}}
""")
    err = error_at(path, "[1, 2]")
    assert err.message == "should be a whole number, not [1, 2]"


def test_bad_list_element_points_into_the_argument(write: WriteFn) -> None:
    path = write(RIDER + """
phrases:
  glow:
    params: {colour: null}
    cues: [{led: {all: $colour}}]
tracks:
  bob:
    - phrase: glow
      with:
        colour: [255, 0, 300]
""")
    err = error_at(path, "[255, 0, 300]")
    assert "300" in err.message


# -- 3. include with parameters -----------------------------------------------------------------


PART = """
params: {height: null, look: 0}
cues:
  - {move: {body_z: $height}, duration: 1}
  - {move: {yaw: $look}, duration: 1}
  - {move: {yaw: -$look}, duration: 1}
"""


def test_include_with_parameters(write: WriteFn) -> None:
    write(PART, "parts/greet.yaml")
    path = write(MINI + """
tracks:
  rex:
    - {include: parts/greet.yaml, with: {height: 110, look: 10}}
    - {include: parts/greet.yaml, with: {height: 90}}
""")
    c = cues(load_show(path), "rex")
    assert [next(iter(x.targets.values())) for x in c] == [  # type: ignore[attr-defined]
        110, 10, -10, 90, 0, 0
    ]


def test_include_missing_parameter_is_named(write: WriteFn) -> None:
    write(PART, "parts/greet.yaml")
    path = write(MINI + """
tracks:
  rex:
    - {include: parts/greet.yaml}
""")
    err = error_at(path, "parts/greet.yaml")
    assert "needs parameter 'height'" in err.message


def test_include_unknown_parameter_suggests(write: WriteFn) -> None:
    write(PART, "parts/greet.yaml")
    path = write(MINI + """
tracks:
  rex:
    - {include: parts/greet.yaml, with: {height: 100, lok: 5}}
""")
    err = error_at(path, "lok")
    assert "did you mean 'look'" in err.message and "parameters: height, look" in err.message


def test_include_with_for_a_part_without_parameters(write: WriteFn) -> None:
    write("- {move: {pitch: 5}, duration: 1}\n", "parts/plain.yaml")
    path = write(MINI + """
tracks:
  rex:
    - {include: parts/plain.yaml, with: {depth: 5}}
""")
    (err,) = errors(path)
    assert "no parameter 'depth'" in err.message and "parameters: none" in err.message


def test_include_parameter_error_points_at_the_argument(write: WriteFn) -> None:
    write(PART, "parts/greet.yaml")
    path = write(MINI + """
tracks:
  rex:
    - {include: parts/greet.yaml, with: {height: 300}}
""")
    err = error_at(path, "300")
    assert err.path == "tracks.rex[0].with.height -> include parts/greet.yaml cues[0].move.body_z"


def test_part_parameters_are_not_seen_by_the_parts_phrases(write: WriteFn) -> None:
    write("""
params: {d: 5}
phrases:
  p: {cues: [{move: {pitch: $d}, duration: 1}]}
cues: [{phrase: p}]
""", "parts/scoped.yaml")
    path = write(MINI + """
tracks:
  rex: [{include: parts/scoped.yaml}]
""")
    (err,) = errors(path)
    assert "unknown parameter $d in phrase 'p'" in err.message


def test_a_parametrised_part_is_not_a_phrase_library(write: WriteFn) -> None:
    write("params: {d: 5}\nphrases: {p: {cues: [{rest: 1}]}}\n", "lib.yaml")
    path = write(MINI + """
include: [lib.yaml]
tracks:
  rex: [{phrase: p}]
""")
    assert any("holds phrases only" in d.message for d in errors(path))


def test_parametrised_part_alone_gets_a_structural_check(write: WriteFn) -> None:
    good = write(PART, "parts/greet.yaml")
    _, diags = check_file(good)
    assert [d.severity for d in diags] == ["warning"]
    bad = write("""
params: {height: 100}
cues:
  - {move: {body_z: $height}, durration: 1}
  - {move: {pitch: $nope}, duration: 1}
""", "parts/bad.yaml")
    _, diags = check_file(bad)
    errs = sorted((d.origin.line, d.message) for d in diags if d.is_error and d.origin)
    assert [line for line, _ in errs] == [3, 4]
    assert "durration" in errs[0][1] and "unknown parameter $nope" in errs[1][1]


# -- 4. problems inside an included file name the include ---------------------------------------


def test_error_in_an_included_part_keeps_the_including_path(write: WriteFn) -> None:
    part = write("""
- {move: {pitch: 5}, duration: 1}
- {move: {pitch: 6}, duration: 1}
- {move: {pitch: 99}, duration: 1}
""", "parts/wave.yaml")
    path = write(MINI + """
tracks:
  rex:
    - {move: {pitch: 1}, duration: 1}
    - {include: parts/wave.yaml}
    - {move: {pitch: 1}, duration: 1}
    - {include: parts/wave.yaml}
""")
    [err] = errors(path)  # one problem, at its place, with both ways to it
    assert where(err) == spot(part, "99")
    assert err.path == ("tracks.rex[1] -> include parts/wave.yaml [2].move.pitch, "
                        "tracks.rex[3] -> include parts/wave.yaml [2].move.pitch")
    assert err.message.endswith(
        "(met 2 times: this text is used again by a repeat, phrase, include or alias)")


def test_nested_includes_chain_their_paths(write: WriteFn) -> None:
    write("cues: [{rest: 1}, {include: inner.yaml}]\n", "parts/outer.yaml")
    inner = write("- {move: {pich: 5}, duration: 1}\n", "parts/inner.yaml")
    path = write(MINI + """
tracks:
  rex: [{include: parts/outer.yaml}]
""")
    errs = errors(path)
    assert any(
        e.path == "tracks.rex[0] -> include parts/outer.yaml cues[1] -> include inner.yaml "
        "[0].move.pich" and where(e) == spot(inner, "5")
        for e in errs
    ), [e.format() for e in errs]


def test_structural_error_in_a_part_names_the_include(write: WriteFn) -> None:
    write("- {mvoe: {pitch: 5}, duration: 1}\n", "parts/bad.yaml")
    path = write(MINI + """
tracks:
  rex: [{rest: 1}, {include: parts/bad.yaml}]
""")
    errs = errors(path)
    inner = [e for e in errs if where(e)[0] == "bad.yaml"]
    assert inner and inner[0].path.startswith("tracks.rex[1] -> include parts/bad.yaml [0]")


# -- sweep: other places a parameter can go -----------------------------------------------------


def test_parameters_in_timing_fields(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  step:
    params: {len: 2, gap: 1, at: 0.5}
    cues:
      - {at: $at, move: {pitch: 5}, beats: $len}
      - {after: {beats: $gap}, move: {pitch: 0}, bars: $len}
      - {after: $gap, move: {pitch: 3}, duration: $len}
tracks:
  rex: [{phrase: step}]
""")
    a, b, c = cues(load_show(path), "rex")
    assert (a.start, a.duration) == (0.5, 1.0)  # type: ignore[attr-defined]
    assert (b.start, b.duration) == (2.0, 4.0)  # type: ignore[attr-defined]
    assert (c.start, c.duration) == (7.0, 2.0)  # type: ignore[attr-defined]


def test_nested_phrases_pass_parameters_down(write: WriteFn) -> None:
    body = XARM + """
phrases:
  outer:
    params: {x: 500}
    cues: [{phrase: inner, with: {b: $x}}, {phrase: mirror, with: {m: -$x}}]
  mirror:
    params: {m: null}
    cues: [{phrase: inner, with: {b: -$m}}]
  inner:
    params: {b: null}
    cues: [{pose: {6: $b}, duration: 1}]
tracks:
  arm:
"""
    good = write(body + "    - {phrase: outer, with: {x: 300}}\n", "good.yaml")
    c = cues(load_show(good), "arm")
    assert [x.positions for x in c] == [{6: 300}, {6: 300}]  # type: ignore[attr-defined]
    path = write(body + "    - {phrase: outer, with: {x: 1.5}}\n")
    [err] = errors(path)  # one place, reached two ways: once, naming both
    assert (where(err), err.path) == (
        spot(path, "1.5"),
        "tracks.arm[0].with.x -> phrase outer cues[0].with.b -> phrase inner cues[0].pose[6], "
        "tracks.arm[0].with.x -> phrase outer cues[1].with.m -> phrase mirror cues[0].with.b "
        "-> phrase inner cues[0].pose[6]")
    assert err.message.endswith("(met 2 times: this text is used again by a repeat, phrase, "
                                "include or alias)")


def test_list_built_in_a_phrase_points_into_the_phrase(write: WriteFn) -> None:
    path = write(XARM + """
phrases:
  outer:
    params: {x: 500}
    cues: [{phrase: inner, with: {b: [$x, 0]}}]
  inner:
    params: {b: null}
    cues: [{pose: {6: $b}, duration: 1}]
tracks:
  arm: [{phrase: outer, with: {x: 300}}]
""")
    err = error_at(path, "[$x, 0]")
    assert err.path == "phrases.outer.cues[0].with.b -> phrase inner cues[0].pose[6]"


def test_parameter_outside_a_phrase_gets_a_hint(write: WriteFn) -> None:
    path = write(MINI + """
tracks:
  rex: [{move: {pitch: $depth}, duration: 1}]
""")
    (err,) = errors(path)
    assert "parameters ($name) work in the cues of a phrase" in err.message


def test_parameter_as_a_key_is_an_error(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  nod:
    params: {reg: pitch}
    cues: [{move: {$reg: 5}, duration: 1}]
tracks:
  rex: [{phrase: nod}]
""")
    (err,) = errors(path)
    assert err.path.endswith(".$reg") and "values, not keys" in err.message


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(base=st.integers(0, 1000), pitch=st.one_of(st.integers(-22, 22),
                                                  st.floats(-22, 22, allow_nan=False)))
def test_any_in_range_value_passes_through_unchanged(
    tmp_path: Path, base: int, pitch: float
) -> None:
    arm = tmp_path / "arm.yaml"
    arm.write_text(XARM + f"""
phrases:
  p: {{params: {{v: null}}, cues: [{{pose: {{6: $v}}, duration: 1}}]}}
tracks:
  arm: [{{phrase: p, with: {{v: {base}}}}}]
""", encoding="utf-8")
    (cue,) = cues(load_show(arm), "arm")
    assert isinstance(cue, ArmCue) and cue.positions == {6: base}
    dog = tmp_path / "dog.yaml"
    dog.write_text(MINI + f"""
phrases:
  p: {{params: {{v: null}}, cues: [{{move: {{pitch: $v}}, duration: 1}}]}}
tracks:
  rex: [{{phrase: p, with: {{v: {yaml.safe_dump(pitch).splitlines()[0]}}}}}]
""", encoding="utf-8")
    (move,) = cues(load_show(dog), "rex")
    assert isinstance(move, MotionCue)
    assert move.targets["pitch"] == pitch  # as if written in place


def test_negating_a_list_negates_each_number(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  nod:
    params: {d: null}
    cues: [{move: {pitch: -$d}, duration: 2}]
tracks:
  rex: [{phrase: nod, with: {d: [4, -2.5]}}]
""")
    assert [m.targets for m in cues(load_show(path), "rex")] == [  # type: ignore[attr-defined]
        {"pitch": -4}, {"pitch": 2.5}
    ]


@pytest.mark.parametrize(("value", "shown"), [
    ("deep", "'deep'"), ("{a: 1}", "{'a': 1}"), ("true", "True"), ("[1, x]", "[1, 'x']"),
    ("[]", "[]"),
])
def test_negating_a_non_number_is_reported_at_the_argument(
    write: WriteFn, value: str, shown: str
) -> None:
    path = write(MINI + f"""
phrases:
  nod:
    params: {{d: null}}
    cues: [{{move: {{pitch: -$d}}, duration: 1}}]
tracks:
  rex: [{{phrase: nod, with: {{d: {value}}}}}]
""")
    err = error_at(path, value)
    assert "-$d needs a number" in err.message and shown in err.message


def test_a_mapping_parameter_and_an_error_inside_it(write: WriteFn) -> None:
    body = MINI + """
phrases:
  go:
    params: {target: null}
    cues: [{move: $target, duration: 1}]
tracks:
  rex:
"""
    good = write(body + "    - {phrase: go, with: {target: {body_z: 100, pitch: 5}}}\n", "ok.yaml")
    (move,) = cues(load_show(good), "rex")
    assert isinstance(move, MotionCue) and move.targets == {"body_z": 100, "pitch": 5}
    path = write(body + "    - {phrase: go, with: {target: {body_z: 500}}}\n")
    err = error_at(path, "500")
    assert err.path == "tracks.rex[0].with.target.body_z -> phrase go cues[0].move.body_z"


def test_the_documented_parametrised_part_works(write: WriteFn) -> None:
    doc = (Path(__file__).resolve().parents[2] / "docs" / "choreography.md").read_text("utf-8")
    part = doc.split("```yaml\n# parts/greet.yaml\n", 1)[1].split("```", 1)[0]
    write(part, "parts/greet.yaml")
    path = write(MINI + """
tracks:
  rex:
    - {include: parts/greet.yaml, with: {height: 110}}
    - {include: parts/greet.yaml, with: {height: 90, look: 12}}
""")
    targets = [m.targets for m in cues(load_show(path), "rex")]  # type: ignore[attr-defined]
    assert targets == [{"body_z": 110}, {"yaw": 0}, {"yaw": 0}, {"yaw": 0},
                       {"body_z": 90}, {"yaw": 12}, {"yaw": -12}, {"yaw": 0}]


def test_schemas_accept_parameters_and_parametrised_parts() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    from xgo_show.choreo.schema import choreography_json_schema, choreography_part_json_schema

    part = yaml.safe_load(PART)
    assert jsonschema.Draft202012Validator(choreography_part_json_schema()).is_valid(part)
    show = yaml.safe_load(MINI + """
phrases:
  p: {params: {rgb: [1, 2, 3], n: 2}, cues: [{repeat: $n, cues: [{rest: 1}]}]}
tracks:
  rex:
    - {phrase: p, with: {rgb: [0, 0, 0], n: 3}}
    - {include: parts/greet.yaml, with: {height: 100}}
""")
    validator = jsonschema.Draft202012Validator(choreography_json_schema())
    assert validator.is_valid(show)
    show["tracks"]["rex"][0]["with"]["n"] = None
    assert not validator.is_valid(show)


def test_a_phrase_passes_its_parameter_on_to_an_include(write: WriteFn) -> None:
    write(PART, "parts/greet.yaml")
    path = write(MINI + """
phrases:
  p:
    params: {h: 100}
    cues: [{include: parts/greet.yaml, with: {height: $h}}]
tracks:
  rex: [{phrase: p}, {phrase: p, with: {h: 300}}]
""")
    err = error_at(path, "300")
    assert err.path == ("tracks.rex[1].with.h -> phrase p cues[0].with.height -> include "
                        "parts/greet.yaml cues[0].move.body_z")


def test_a_parameter_inside_a_bar_beat_string_gets_a_hint(write: WriteFn) -> None:
    path = write(MINI + """
phrases:
  p:
    params: {bar: 2}
    cues: [{at: "$bar.1", move: {pitch: 5}, duration: 1}]
tracks:
  rex: [{phrase: p}]
""")
    (err,) = errors(path)
    assert "a parameter goes in whole: {bar: $bar, beat: 1}" in err.message
