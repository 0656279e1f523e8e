"""Sections and waits: resolved in show time, checked, compiled, saved and read back."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.choreo import load_show, validate_file
from xgo_show.choreo.sections import (
    Section,
    Wait,
    format_sections,
    section_at,
    section_named,
    trigger_names,
)
from xgo_show.choreo.timebase import TempoMap
from xgo_show.compiler import compile_show
from xgo_show.compiler.artifact import (
    _canonical,
    _envelope,
    schedule_from_bytes,
    schedule_to_bytes,
)
from xgo_show.compiler.schedule import Schedule

ROOT = Path(__file__).resolve().parents[2]
CURTAIN = ROOT / "choreographies" / "curtain_call.yaml"

ROUTINE = """\
show: S
tempo: {bpm: 120}
performers:
  rex: {model: mini}
sections:
%s
tracks:
  rex:
    - {move: {body_z: 110}, beats: 2}
    - {at: "3.1", move: {pitch: 10}, beats: 2}
    - {at: "5.1", move: {pitch: 0}, beats: 2}
"""


def write(tmp_path: Path, sections: str) -> Path:
    path = tmp_path / "s.yaml"
    path.write_text(ROUTINE % sections, encoding="utf-8")
    return path


def test_sections_are_placed_in_show_time_with_their_waits() -> None:
    show = load_show(CURTAIN)
    assert [(s.name, s.start) for s in show.sections] == [
        ("opening", 0.0), ("bow", 4.0), ("encore", 8.0), ("finale", 12.0)
    ]
    assert show.sections[1].wait == Wait("go", None, "continue")
    assert show.sections[2].wait == Wait("encore", 20.0, "finale")
    origin = show.sections[1].origin
    assert origin is not None and origin.line == 26 and origin.cue == "bow"


def test_a_wait_at_a_bar_line_and_one_at_the_start(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        '  - {name: standby, wait: {trigger: go}}\n'
        '  - {name: b, at: "3.1", wait: {trigger: go, timeout: 2.5, else: end}}',
    )
    show = load_show(path)
    assert show.sections == (
        Section("standby", 0.0, Wait("go"), show.sections[0].origin),
        Section("b", 4.0, Wait("go", 2.5, "end"), show.sections[1].origin),
    )
    assert trigger_names(show.sections) == ("go",)


@pytest.mark.parametrize(
    ("sections", "message"),
    [
        ('  - {name: a}\n  - {name: b, at: 5, wait: {trigger: "no/slash"}}', "should be a name of letters"),
        ("  - {name: a, wait: {trigger: go, timeout: 0}}", "0 s is too small: give more than 0 and at most 3600 s"),
        ("  - {name: a, wait: {trigger: go, timeout: 1, else: a}}", "back to this same wait"),
        ("  - {name: continue}", "keyword of else:"),
        ("  - {name: a, at: 60}", "after the show's end"),
        ("  - {name: a, wat: 3}", "wat"),
    ],
)
def test_bad_sections_are_errors_at_their_place(
    tmp_path: Path, sections: str, message: str
) -> None:
    errors = [d for d in validate_file(write(tmp_path, sections)) if d.is_error]
    assert errors, "expected an error"
    assert any(message in d.message for d in errors), [d.format() for d in errors]
    assert all(d.origin is not None and d.origin.line >= 6 for d in errors)


def test_a_cue_ending_exactly_at_the_wait_is_fine(tmp_path: Path) -> None:
    path = write(tmp_path, '  - {name: a}\n  - {name: b, at: "2.1", wait: {trigger: go}}')
    assert [d for d in validate_file(path) if d.is_error] == []  # the first move ends at 1 s


def test_a_cue_across_a_wait_is_an_error_but_across_a_plain_section_is_not(
    tmp_path: Path,
) -> None:
    plain = write(tmp_path, '  - {name: a}\n  - {name: b, at: 8.5}')  # inside the last move
    assert [d for d in validate_file(plain) if d.is_error] == []
    held = write(tmp_path, '  - {name: a}\n  - {name: b, at: 8.5, wait: {trigger: go}}')
    errors = [d for d in validate_file(held) if d.is_error]
    assert len(errors) == 1 and "across the wait for trigger 'go' at 8.500 s" in errors[0].message
    assert errors[0].origin is not None and errors[0].origin.line == 12


def test_sections_survive_compile_save_and_load() -> None:
    schedule = compile_show(load_show(CURTAIN))
    assert schedule.sections == load_show(CURTAIN).sections
    again = schedule_from_bytes(schedule_to_bytes(schedule))
    assert again.sections == schedule.sections
    assert schedule_to_bytes(again) == schedule_to_bytes(schedule)


def _document(schedule: Schedule) -> str:
    """The JSON document in a schedule file's body."""
    body = _canonical(schedule)
    return body[4:4 + int.from_bytes(body[:4], "little")].decode()


def test_a_schedule_without_sections_reads_as_one_straight_run() -> None:
    schedule = compile_show(load_show(ROOT / "choreographies" / "hello_mini.yaml"))
    assert '"sections"' not in _document(schedule)
    assert schedule_from_bytes(schedule_to_bytes(schedule)).sections == ()


def test_a_schedule_with_an_unknown_else_target_is_refused() -> None:
    schedule = compile_show(load_show(CURTAIN))
    body = _canonical(schedule)
    size = int.from_bytes(body[:4], "little")
    doc = _document(schedule).replace('"else":"finale"', '"else":"fin"').encode()
    data = _envelope(len(doc).to_bytes(4, "little") + doc + body[4 + size:])
    with pytest.raises(Exception, match=r"sections\[2\]\.wait\.else: no section named 'fin'"):
        schedule_from_bytes(data, name="cc.xshow.json")


def test_section_at_and_by_name() -> None:
    secs = load_show(CURTAIN).sections
    assert section_at(secs, 0.0) is secs[0]
    assert section_at(secs, 3.999) is secs[0]
    assert section_at(secs, 4.0) is secs[1]
    assert section_at(secs, 100.0) is secs[3]
    assert section_at((Section("late", 2.0),), 1.0) is None
    assert section_named(secs, "encore") is secs[2]
    assert section_named(secs, "nope") is None


def test_the_table_lists_sections_bars_and_triggers() -> None:
    secs = load_show(CURTAIN).sections
    text = format_sections(secs, TempoMap.constant(120), end=16.0)
    assert "encore             8.000 s  5.1         4.000 s  trigger 'encore', after 20 s: finale" \
        in text
    assert text.endswith("triggers: go, encore\n")
    assert format_sections(()) == ""
