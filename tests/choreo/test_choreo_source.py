"""YAML reading with positions: every value knows its line:column; duplicates are errors."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from xgo_show.choreo.source import format_path, parse_yaml, read_yaml


def test_marks_are_one_based_line_and_column() -> None:
    doc, errors = parse_yaml("show: x\ntracks:\n  rex:\n    - {move: {pitch: 5}}\n", "f.yaml")
    assert errors == []
    assert doc.data == {"show": "x", "tracks": {"rex": [{"move": {"pitch": 5}}]}}
    assert doc.marks[("show",)] == (1, 7)
    assert doc.key_marks[("tracks",)] == (2, 1)
    assert doc.marks[("tracks", "rex", 0)] == (4, 7)
    assert doc.marks[("tracks", "rex", 0, "move", "pitch")] == (4, 22)


def test_origin_falls_back_to_nearest_enclosing_node() -> None:
    doc, _ = parse_yaml("a:\n  b: 1\n", "f.yaml")
    origin = doc.origin(("a", "missing", "deeper"))
    assert (origin.file, origin.line, origin.column) == ("f.yaml", 2, 3)
    assert doc.origin(("a", "b"), key=True).column == 3
    assert doc.origin(("a", "b")).column == 6


def test_duplicate_key_is_an_error_with_both_lines() -> None:
    _, errors = parse_yaml("a: 1\nb: 2\na: 3\n", "f.yaml")
    assert len(errors) == 1
    err = errors[0]
    assert err.origin is not None and (err.origin.line, err.origin.column) == (3, 1)
    assert "duplicate key 'a'" in err.message and "line 1" in err.message


def test_nested_duplicates_are_all_reported() -> None:
    _, errors = parse_yaml("x: {a: 1, a: 2}\ny: [{b: 1, b: 1}]\n", "f.yaml")
    assert [(e.origin.line, e.origin.column) for e in errors if e.origin] == [(1, 11), (2, 12)]


def test_syntax_error_is_one_diagnostic_with_position() -> None:
    _, errors = parse_yaml("a: [1, 2\nb: 3\n", "f.yaml")
    assert len(errors) == 1
    assert errors[0].message.startswith("YAML syntax")
    assert errors[0].origin is not None and errors[0].origin.line == 2


def test_empty_and_multi_document_files() -> None:
    assert parse_yaml("", "f")[1][0].message == "the file is empty"
    assert "one YAML document" in parse_yaml("a: 1\n---\nb: 2\n", "f")[1][0].message


def test_merge_keys_explicit_wins_and_is_no_duplicate() -> None:
    doc, errors = parse_yaml("base: &b {x: 1, y: 2}\nc:\n  <<: *b\n  y: 5\n", "f")
    assert errors == []
    assert doc.data == {"base": {"x": 1, "y": 2}, "c": {"y": 5, "x": 1}}


def test_boolean_keys_are_refused() -> None:
    _, errors = parse_yaml("true: 1\n", "f")
    assert "must be a name" in errors[0].message


@pytest.mark.parametrize(("text", "value"), [
    ("on", "on"), ("off", "off"), ("yes", "yes"), ("No", "No"), ("y", "y"),
    ("true", True), ("False", False), ("TRUE", True),
])
def test_booleans_are_read_as_yaml_1_2(text: str, value: object) -> None:
    """Only true and false are booleans; on/off/yes/no are the text written (an on/off
    choice, a colour, or an error that names the word), as keys too."""
    doc, errors = parse_yaml(f"v: {text}\n{text}: 1\n" if not isinstance(value, bool)
                             else f"v: {text}\n", "f")
    assert errors == []
    assert isinstance(doc.data, dict) and doc.data["v"] == value
    assert type(doc.data["v"]) is type(value)


def test_unsafe_tags_are_errors_not_exceptions() -> None:
    _, errors = parse_yaml("a: !!python/object:os.system ls\n", "f")
    assert errors and errors[0].is_error


def test_recursive_alias_is_an_error() -> None:
    _, errors = parse_yaml("a: &x [*x]\n", "f")
    assert any("recursive" in e.message for e in errors)


def test_unreadable_files(tmp_path: Path) -> None:
    assert read_yaml(tmp_path / "nope.yaml")[1][0].message == "no such file"
    assert read_yaml(tmp_path)[1][0].message == "is a directory"
    bad = tmp_path / "bin.yaml"
    bad.write_bytes(b"a: \xff\xfe\n")
    assert "UTF-8" in read_yaml(bad)[1][0].message


def test_format_path() -> None:
    assert format_path(("tracks", "rex", 3, "move", "body_z")) == "tracks.rex[3].move.body_z"
    assert format_path((1, "a")) == "[1].a"


def test_absurd_nesting_is_an_error_not_a_crash() -> None:
    _, errors = parse_yaml("a: " + "[" * 3000 + "]" * 3000, "f")
    assert [e.message for e in errors] == ["the YAML is nested more than 64 levels deep here"]


@pytest.mark.parametrize("text", [
    "a: 1\na: " + "[" * 70 + "]" * 70 + "\n",  # the second 'a' is a duplicate: left unbuilt
    "? [" + "[" * 70 + "]" * 70 + "]\n: 1\n",  # a key that is a list: left unbuilt
    "a: {<<: {b: " + "[" * 70 + "]" * 70 + "}}\n",  # in a merge
])
def test_nesting_too_deep_in_a_node_left_unbuilt_is_still_the_one_error(text: str) -> None:
    # Without aliases the builder bounds the nesting; what it does not build is walked.
    _, errors = parse_yaml(text, "f")
    assert [e.message for e in errors] == ["the YAML is nested more than 64 levels deep here"]


def test_nesting_at_the_limit_is_read_and_one_more_level_is_not() -> None:
    at_limit = "[" * 63 + "1" + "]" * 63  # 63 lists and the number: 64 levels
    doc, errors = parse_yaml(at_limit, "f")
    assert errors == [] and doc.marks[(0,) * 63] == (1, 64)
    _, errors = parse_yaml("[" + at_limit + "]", "f")
    assert [(e.origin.line, e.origin.column) for e in errors if e.origin] == [(1, 65)]
    assert parse_yaml("[" * 64 + "]" * 64, "f")[1] == []  # 64 levels, the deepest empty


def test_the_cap_counts_the_nodes_left_unbuilt_too(monkeypatch: pytest.MonkeyPatch) -> None:
    import xgo_show.choreo.source as source

    text = "{a: 1, a: [1, 2, 3]}\n"  # 1 + 2 + (1 + 1 + 3): the duplicate's list counts
    monkeypatch.setattr(source, "MAX_NODES", 8)
    assert [e.message for e in parse_yaml(text, "f")[1]] == ["duplicate key 'a' (first at line 1)"]
    monkeypatch.setattr(source, "MAX_NODES", 7)
    assert parse_yaml(text, "f")[1][0].message.startswith("the file makes")


def _laughs(levels: int, width: int = 10) -> str:
    lines = [f"a0: &a0 [{', '.join(['lol'] * width)}]"]
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * width)}]")
    return "\n".join(lines) + "\n"


def test_billion_laughs_is_one_error_at_the_alias_not_a_memory_error() -> None:
    import time

    started = time.perf_counter()
    _, errors = parse_yaml(_laughs(10), "f.yaml")  # 10^10 values if expanded
    assert time.perf_counter() - started < 2.0
    assert len(errors) == 1
    err = errors[0]
    # a5's eighth alias passes 1,000,000: 123,460 values before a5, 111,111 per alias.
    assert err.origin is not None and (err.origin.line, err.origin.column) == (6, 45)
    assert "this alias" in err.message and "1,000,000" in err.message


def test_the_cap_counts_aliases_at_each_use(monkeypatch: pytest.MonkeyPatch) -> None:
    import xgo_show.choreo.source as source

    text = "a: &x [1, 2, 3]\nb: *x\nc: *x\n"  # 1 + (1+4) + (1+4) + (1+4) = 16 values
    monkeypatch.setattr(source, "MAX_NODES", 16)
    doc, errors = parse_yaml(text, "f.yaml")
    assert errors == [] and doc.data == {"a": [1, 2, 3], "b": [1, 2, 3], "c": [1, 2, 3]}
    monkeypatch.setattr(source, "MAX_NODES", 15)
    _, errors = parse_yaml(text, "f.yaml")
    assert [(e.origin.line, e.origin.column) for e in errors if e.origin] == [(3, 4)]


def test_the_cap_also_bounds_a_huge_file_without_aliases(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import xgo_show.choreo.source as source

    monkeypatch.setattr(source, "MAX_NODES", 5)
    _, errors = parse_yaml("[1, 2, 3, 4, 5, 6]\n", "f.yaml")
    assert len(errors) == 1 and errors[0].message.startswith("the file makes")
    assert errors[0].origin is not None and errors[0].origin.column == 14


def test_the_bundled_show_is_far_under_the_cap() -> None:
    import xgo_show.choreo.source as source

    text = (Path(__file__).parents[2] / "choreographies" / "mixed_five.yaml").read_text()
    node = yaml.compose(text, Loader=yaml.SafeLoader)
    assert source._expanded_size(node, {}, set()) * 50 < source.MAX_NODES


def test_an_explicit_key_beside_a_merge_keeps_its_own_place() -> None:
    """A value written next to ``<<`` is located where it is written; a merged one in the
    anchor (a problem in it is one in the anchor's text)."""
    text = "base: &b {x: 1, y: 2}\nc:\n  <<: *b\n  y: 5\nd:\n  y: 7\n  <<: [*b]\n"
    doc, errors = parse_yaml(text, "f")
    assert errors == []
    assert doc.marks[("c", "y")] == (4, 6)  # written here, not the anchor's y at 1:21
    assert doc.key_marks[("c", "y")] == (4, 3)
    assert doc.marks[("c", "x")] == (1, 14)  # merged: where the anchor wrote it
    assert doc.marks[("d", "y")] == (6, 6)  # order of '<<' and the key does not matter
    assert doc.data["d"] == {"y": 7, "x": 1}


def test_the_cap_bounds_a_file_at_the_limit_without_aliases(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # libyaml's node count stands for the walk there: 7 values pass, 8 do not (list + 7).
    import xgo_show.choreo.source as source

    monkeypatch.setattr(source, "MAX_NODES", 8)
    assert parse_yaml("[1, 2, 3, 4, 5, 6, 7]\n", "f.yaml")[1] == []
    _, errors = parse_yaml("[1, 2, 3, 4, 5, 6, 7, 8]\n", "f.yaml")
    assert len(errors) == 1 and errors[0].message.startswith("the file makes")


def test_a_value_read_before_is_still_refused_at_each_place() -> None:
    # Scalars are read once per text; a problem is not a value and is reported every time.
    text = "a: [0500, 1.5, 0500]\nb: {x: 1.5, true: 1}\nc: {true: 2}\n"
    doc, errors = parse_yaml(text, "f.yaml")
    assert [(e.origin.line, e.origin.column) for e in errors if e.origin] == [
        (1, 5), (1, 16), (2, 13), (3, 5)]
    assert isinstance(doc.data, dict) and doc.data["b"] == {"x": 1.5}


def test_a_key_read_before_is_still_a_duplicate_in_one_mapping() -> None:
    _, errors = parse_yaml("- {at: 1, move: {z: 1}}\n- {at: 2, at: 3}\n", "f.yaml")
    assert [(e.origin.line, e.origin.column, e.message) for e in errors if e.origin] == [
        (2, 11, "duplicate key 'at' (first at line 2)")]


def _files() -> list[Path]:
    root = Path(__file__).parents[2]
    found = [*root.glob("choreographies/**/*.yaml"), *root.glob("tests/choreo/invalid/**/*")]
    return sorted(p for p in found if p.is_file())


@pytest.mark.parametrize("path", _files(), ids=lambda p: p.name)
def test_with_and_without_the_walk_the_same_document(path: Path) -> None:
    # A '*' anywhere (an alias, or here a comment) makes the reader walk the nodes for their
    # depth and count and watch for recursive aliases; without one, the builder bounds them.
    text = path.read_text(encoding="utf-8")
    fast, fast_errors = parse_yaml(text, "f.yaml")
    walked, walked_errors = parse_yaml(text + "\n# *\n", "f.yaml")
    assert fast.data == walked.data
    assert fast.marks == walked.marks and fast.key_marks == walked.key_marks
    assert fast_errors == walked_errors


@pytest.mark.parametrize("text", [
    "a: 1\na: " + "[" * 70 + "]" * 70 + "\n",
    "a: " + "[" * 63 + "1" + "]" * 63 + "\n",
    "tracks: {rex: [{at: 1, move: {pitch: 5}}, {at: 2, at: 3}]}\n",
    "a: [0500, 1.5, true, .nan]\n",
])
def test_without_libyaml_the_same_document(text: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # PyYAML without libyaml composes in Python (no C resolver calls to stand in for): the
    # builder's bounds and reading are the same.
    import xgo_show.choreo.source as source

    fast, fast_errors = parse_yaml(text, "f.yaml")
    monkeypatch.setattr(source, "_FAST_LOADER", None)
    slow, slow_errors = parse_yaml(text, "f.yaml")
    assert (fast.data, fast.marks, fast.key_marks) == (slow.data, slow.marks, slow.key_marks)
    assert fast_errors == slow_errors
