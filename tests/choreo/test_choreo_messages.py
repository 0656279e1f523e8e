"""Every message in our words: a value out of range says what was written, which way it is off
and what is allowed, in the field's unit; no pydantic phrasing ever reaches the user."""

from __future__ import annotations

import json
import re
import tempfile
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.choreo import validate_file

from .conftest import WriteFn

# pydantic's own wording: none of it may reach a message.
_PYDANTIC = re.compile(r"[Ii]nput should|valid (?:integer|number|boolean|string|dictionary|list)"
                       r"|after validation|instance of|Value error|Field required|Extra inputs|"
                       r"should have at least|greater than or equal|less than or equal")


def _routine(where: str, value: object) -> dict[str, Any]:
    """A small valid routine with ``value`` put at ``where``."""
    cue: dict[str, Any] = {"move": {"body_z": 100}, "duration": 1}
    show: dict[str, Any] = {"show": "t", "performers": {"rex": {"model": "mini"}},
                            "tracks": {"rex": [cue]}}
    area, _, name = where.partition(".")
    if area == "settings":
        show["settings"] = {name: value}
    elif area == "tempo":
        show["tempo"] = {"bpm": 120, name: value} if name != "bpm" else {"bpm": value}
    elif area == "music":
        show["music"] = {"file": "a.wav", name: value}
    elif area == "performer":
        show["performers"]["rex"][name] = value
    elif area == "limits":
        cue["limits"] = {"body_z": {name: value}}
    elif area == "repeat":
        show["tracks"]["rex"] = [{"repeat": value, "cues": [cue]}]
    elif area == "move":
        cue["move"] = {"body_z": value}
    else:
        cue[name] = value
    return show


PLACES = ["settings.control_rate", "settings.gap_ms", "settings.battery_floor",
          "settings.on_failure", "settings.decimate", "settings.end", "tempo.bpm",
          "tempo.beats_per_bar", "music.offset", "performer.model", "performer.port",
          "performer.arm", "limits.velocity", "limits.acceleration", "limits.jerk",
          "repeat.count", "move.body_z", "cue.duration", "cue.beats", "cue.at", "cue.after",
          "cue.interrupt"]
VALUES = st.one_of(
    st.integers(-10**7, 10**7), st.floats(-1e9, 1e9, allow_nan=False), st.booleans(),
    st.sampled_from([0, -1, 1e-12, 1e300, 65, 1001, 255, 256, 10001, "", "x", "1e3", [], {},
                     [1, 2], {"a": 1}, None]),
    st.text("abc $-_.", max_size=4),
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(PLACES), VALUES)
def test_no_message_is_in_pydantic_words(where: str, value: object) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "show.yaml"
        path.write_text(json.dumps(_routine(where, value)), encoding="utf-8")
        found = validate_file(path)
    for d in found:
        line = d.format()
        assert not _PYDANTIC.search(line), line
        assert re.match(rf"^{re.escape(str(path))}:\d+:\d+: (error|warning): ", line), line


@pytest.mark.parametrize(("setting", "message"), [
    ("settings: {gap_ms: 0}", "0 ms is too small: give 1 to 1000 ms"),
    ("settings: {gap_ms: 1e4}", "10000 ms is too large: give 1 to 1000 ms"),
    ("settings: {control_rate: 0}", "0 Hz is too small: give 1 to 1000 Hz"),
    ("settings: {battery_floor: 101}", "101% is too large: give 0 to 100%"),
    ("tempo: {bpm: 120, beats_per_bar: 65}", "65 beats is too large: give 1 to 64 beats"),
    ("tempo: {bpm: -120}", "-120 bpm is too small: give 1 to 1000 bpm"),
    ("music: {file: a.wav, offset: -4000}", "-4000 s is too small: give -3600 to 86400 s"),
])
def test_a_range_is_said_in_the_fields_unit(write: WriteFn, setting: str, message: str) -> None:
    path = write(f"show: t\n{setting}\nperformers:\n  rex: {{model: mini}}\ntracks:\n"
                 "  rex: [{action: wave}]\n")
    assert [d.message for d in validate_file(path) if d.is_error] == [message]


@pytest.mark.parametrize(("cue", "message"), [
    ("{move: {body_z: 100}, duration: -1}", "-1 s is too small: give 0 to 3600 s"),
    ("{move: {body_z: 100}, beats: -2}", "-2 beats is too small: give 0 to 60000 beats"),
    ("{move: {body_z: 100}, limits: {body_z: {velocity: 1e-12}}}",
     "1e-12 mm/s is too small: give 0.001 to 1e7 mm/s"),
    ("{repeat: 0, cues: [{action: wave}]}", "0 is too small: give 1 to 10000"),
    ("{repeat: 2.5, cues: [{action: wave}]}", "should be a whole number, not 2.5"),
    ("{repeat: 2, cues: []}", "[] is empty: give at least 1 item"),
    ("{move: {}}", "{} is empty: give at least 1 entry (name: value)"),
    ("{action: wave, at: -3}", "-3 s is too small: a time is 0 to 3600 s from the start"),
    ("{rest: -1}", "-1 s is too small: a length is 0 to 3600 s"),
    ("{rest: {beats: -1}}", "-1 beats is too small: a length is 0 to 60000 beats"),
    ("{move: {body_z: 100}, interrupt: maybe}", "should be true or false, not 'maybe'"),
    ("{set: {gait: [1]}}", "should be a number, text or true or false, not [1]"),
])
def test_a_cue_field_is_said_in_our_words(write: WriteFn, cue: str, message: str) -> None:
    path = write(f"show: t\nperformers:\n  rex: {{model: mini}}\ntracks:\n  rex:\n    - {cue}\n")
    assert [d.message for d in validate_file(path) if d.is_error] == [message]


def test_a_choice_lists_what_is_allowed(write: WriteFn) -> None:
    path = write("show: t\nperformers:\n  rex: {model: poodle}\ntracks:\n  rex: [{rest: 1}]\n")
    assert [d.message for d in validate_file(path) if d.is_error] == [
        "should be one of 'mini', 'lite', 'rider' or 'xarm', not 'poodle'"]
