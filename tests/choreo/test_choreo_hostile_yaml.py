"""Hostile YAML: numbers read as written (YAML 1.2), within range, text printable, every error
at its own line:col, nesting bounded; random input never raises."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.choreo import validate_file
from xgo_show.choreo.source import MAX_DEPTH, parse_yaml


def _one_error(text: str) -> tuple[int, int, str]:
    _, errors = parse_yaml(text, "f.yaml")
    assert len(errors) == 1, [e.format() for e in errors]
    o = errors[0].origin
    assert o is not None
    return o.line, o.column, errors[0].message


@pytest.mark.parametrize(("text", "value"), [
    ("v: 1e3", 1000.0), ("v: 1E-2", 0.01), ("v: -2.5e+1", -25.0), ("v: .5", 0.5),
    ("v: 500", 500), ("v: -7", -7), ("v: 0", 0), ("v: 0x1F", 31), ("v: 0o17", 15),
    ("v: 1_000", "1_000"), ("v: 1:30", "1:30"), ("v: 2024-01-01", "2024-01-01"),
    ("v: '0500'", "0500"), ("v: '1e3'", "1e3"), ("v: true", True), ("v: ~", None),
])
def test_numbers_are_read_as_yaml_1_2(text: str, value: object) -> None:
    doc, errors = parse_yaml(text, "f.yaml")
    assert errors == []
    assert isinstance(doc.data, dict)
    assert doc.data["v"] == value and type(doc.data["v"]) is type(value)


@pytest.mark.parametrize("text", ["pose: {1: 0500}", "pose: {1: 00}", "v: -012", "v: +0500",
                                  "{0500: 1}"])
def test_a_leading_zero_is_refused_at_its_place(text: str) -> None:
    line, col, message = _one_error(text)
    assert line == 1 and "leading zero" in message and "octal" in message


@pytest.mark.parametrize(("text", "col"), [
    ("at: 1" + "0" * 400, 5), ("v: [1, 2, " + "9" * 17 + "]", 11), ("v: 1e300", 4),
    ("v: -1e16", 4), ("v: .inf", 4), ("v: -.Inf", 4), ("v: .nan", 4), ("v: 9007199254740993", 4),
])
def test_numbers_out_of_range_are_refused_at_their_place(text: str, col: int) -> None:
    line, column, message = _one_error(text)
    assert (line, column) == (1, col)
    assert "too large" in message or "finite" in message


@settings(max_examples=200, deadline=None)
@given(st.one_of(st.integers(), st.floats(allow_nan=True, allow_infinity=True)))
def test_any_number_loads_or_is_one_located_error(number: float) -> None:
    doc, errors = parse_yaml(f"v: {number!r}".replace("inf", ".inf").replace("nan", ".nan"),
                             "f.yaml")
    if errors:
        assert len(errors) == 1 and errors[0].origin is not None
        assert (errors[0].origin.line, errors[0].origin.column) == (1, 4)
        return
    assert isinstance(doc.data, dict)
    value = doc.data["v"]
    assert isinstance(value, (int, float)) and math.isfinite(value) and abs(value) <= 2**53
    assert value == number


@pytest.mark.parametrize(("text", "where"), [
    ('name: "a\\e[2Jb"', (1, 7)), ("x: 1\nname: \"\\x07\"", (2, 7)), ('n: "\\u202e"', (1, 4)),
    ('{"\\e[31m": 1}', (1, 2)), ('v: ["ok", "\\0"]', (1, 11)),
    ('v: "0.\\ud801\\udca0"', (1, 4)),  # YAML makes two lone surrogates: unprintable
])
def test_text_with_control_characters_is_refused(text: str, where: tuple[int, int]) -> None:
    line, col, message = _one_error(text)
    assert (line, col) == where and "control character" in message
    assert "\x1b" not in message and "\x07" not in message
    message.encode("utf-8")  # printable: every character escaped that cannot be written


def test_other_scripts_digits_are_no_bar_and_beat(tmp_path: Path) -> None:
    path = tmp_path / "show.yaml"
    path.write_text("show: t\ntempo: {bpm: 120}\nperformers:\n  rex: {model: mini}\ntracks:\n"
                    "  rex: [{action: wave, at: \"\u0665.\u0663\"}]\n", encoding="utf-8")
    [err] = [d for d in validate_file(path) if d.is_error]
    assert err.origin is not None and (err.origin.line, err.origin.column) == (6, 28)
    assert "is not a time" in err.message


@pytest.mark.parametrize(("text", "where"), [
    ("a: 1\nb: 2\nc: \x01\n", (3, 4)), ("a: 1\n\x1b[2J\n", (2, 1)), ("x: [1,\n  2, \x7f]", (2, 6)),
    ("# ok\n# ok\nv: 1\x00", (3, 5)),
])
def test_control_characters_in_the_file_are_located(text: str, where: tuple[int, int]) -> None:
    line, col, message = _one_error(text)
    assert (line, col) == where and "control character" in message
    assert "\x1b" not in message and "\x00" not in message


@pytest.mark.parametrize("depth", [MAX_DEPTH + 1, 200, 1000])
@pytest.mark.parametrize("kind", ["flow", "block"])
def test_deep_nesting_is_refused_at_its_line(depth: int, kind: str) -> None:
    if kind == "flow":
        text = "a: 1\nb: 2\nv: " + "[" * depth + "]" * depth + "\n"
        line = 3
    else:
        text = "a: 1\nb:\n" + "".join("  " * i + "-\n" for i in range(depth))
        line = 2 + MAX_DEPTH
    found_line, _, message = _one_error(text)
    assert "nested more than" in message
    assert found_line == line if kind == "flow" else found_line >= 2


def test_nesting_at_the_limit_is_fine() -> None:
    depth = MAX_DEPTH - 1
    _, errors = parse_yaml("v: " + "[" * depth + "]" * depth, "f.yaml")
    assert errors == []


@pytest.mark.parametrize("text", [
    "v: !!python/tuple [1, 2]", "v: !!python/object:os.system {}", "v: !!python/name:os.system ''",
    "v: !custom [1]", "v: !!binary aGVsbG8=", "v: !!set {a, b}", "v: !!int abc",
    "v: !!float abc",
])
def test_tags_outside_the_safe_subset_are_refused(text: str) -> None:
    _, errors = parse_yaml(text, "f.yaml")
    assert errors and all(e.origin is not None and e.origin.line == 1 for e in errors)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200))
def test_random_bytes_never_raise(data: bytes) -> None:
    text = data.decode("utf-8", errors="replace")
    doc, errors = parse_yaml(text, "f.yaml")
    for e in errors:
        assert e.origin is not None and e.origin.line >= 1 and e.origin.column >= 1
        assert "\n" not in e.format()


@settings(max_examples=200, deadline=None)
@given(st.recursive(st.one_of(st.integers(), st.text(max_size=4), st.floats()),
                    lambda inner: st.lists(inner, max_size=3)
                    | st.dictionaries(st.text(max_size=3), inner, max_size=3), max_leaves=40))
def test_random_nesting_never_raises(value: object) -> None:
    import json
    doc, errors = parse_yaml("v: " + json.dumps(value), "f.yaml")
    assert all(e.origin is not None for e in errors)


@pytest.mark.parametrize(("bad", "column"), [
    ("{<<: [*b, 3], body_z: 100}", 24),  # a merge of something not a mapping: the 3
    ("{pitch: 0500}", 22),  # a leading zero
    ("{pitch: !!python/object:os.system 1}", 22),  # a Python tag
    ("{pitch: 1e400}", 22),  # infinite
    ("{pitch: 123456789012345678901234567890}", 22),  # past 2^53
    ("{pitch: \"\\e[2J\"}", 22),  # a terminal escape
])
def test_a_value_the_reader_refuses_hides_nothing_else(
    tmp_path: Path, bad: str, column: int
) -> None:
    """The reader's error and the later checks' errors, in one run: a bad setting and an
    unknown top-level key before it, an unknown register and a value out of range after it,
    a misspelt key in another track."""
    path = tmp_path / "show.yaml"
    path.write_text(
        "show: t\n"
        "settings: {control_rate: 0}\n"
        "base: &b {pitch: 5}\n"
        "performers:\n"
        "  rex: {model: mini}\n"
        "  ace: {model: mini}\n"
        "tracks:\n"
        "  rex:\n"
        f"    - {{move: {bad}, duration: 1}}\n"
        "    - {move: {bodyz: 90}, duration: 1}\n"
        "    - {move: {roll: 99}, duration: 1}\n"
        "  ace:\n"
        "    - {move: {pitch: 5}, duraton: 1}\n", encoding="utf-8")
    found = [(d.origin.line, d.origin.column, d.message) for d in validate_file(path)
             if d.is_error and d.origin]
    assert {line for line, _, _ in found} == {2, 3, 9, 10, 11, 13}, found
    [refused] = [f for f in found if f[0] == 9]  # the refused value, once, at its place
    assert refused[1] == column, found
    assert not any("refused" in m for _, _, m in found), found


_TIMES = (st.from_regex(r"\A\d{1,40}\.\d{1,40}\Z|\A\d{1,40}(\.\d{1,40})?s\Z")
          .map(lambda t: json.dumps(t))
          | st.builds(lambda bar, beat: f"{{bar: {bar}, beat: {beat}}}",
                      st.integers(-10, 10**30), st.integers(-10, 10**30) | st.floats())
          | st.builds(lambda unit, n: f"{{{unit}: {n}}}",
                      st.sampled_from(["beats", "bars", "seconds"]),
                      st.integers(-10, 10**30) | st.floats()))


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(["at", "after", "fade"]), _TIMES)
def test_any_time_or_length_is_taken_or_one_located_error(field: str, text: str) -> None:
    """Bar/beat strings with forty digits, seconds past any float, lengths of every unit:
    the routine loads or each error is at the cue's line, and nothing raises."""
    import tempfile

    routine = ("show: t\ntempo: {bpm: 120}\nperformers:\n  rex: {model: rider}\ntracks:\n"
               f"  rex:\n    - {{led: {{all: red}}, duration: 1, {field}: {text}}}\n")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "show.yaml"
        path.write_text(routine, encoding="utf-8")
        errors = [d for d in validate_file(path) if d.is_error]
    assert all(d.origin is not None and d.origin.line == 7 for d in errors), [
        d.format() for d in errors]
