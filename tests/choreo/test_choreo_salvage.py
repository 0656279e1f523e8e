"""One structural error hides nothing: the well-formed rest of a routine is still checked,
and what the broken part made unknowable (times, phrases, tempo) gives no false alarm."""

from __future__ import annotations

from xgo_show.choreo import validate_file

from .conftest import WriteFn


def _errors(path: object) -> list[tuple[int, int, str]]:
    return [(d.origin.line, d.origin.column, d.message)
            for d in validate_file(path)  # type: ignore[arg-type]
            if d.is_error and d.origin is not None]


def test_semantic_errors_in_other_tracks_are_listed(write: WriteFn) -> None:
    path = write("""
        show: S
        performers:
          rex: {model: mini}
          rio: {model: rider}
        tracks:
          rex:
            - {move: {pitch: 10}, duration: -1}
          rio:
            - {move: {roll: 90}, duration: 1}
        """)
    found = _errors(path)
    assert [(line, col) for line, col, _ in found] == [(7, 37), (9, 21)]
    assert "out of range" in found[1][2]


def test_bad_cue_in_a_repeat_leaves_its_siblings_checked(write: WriteFn) -> None:
    path = write("""
        show: S
        performers:
          rio: {model: rider}
        tracks:
          rio:
            - repeat: 2
              cues:
                - {action: 99999}
                - {move: {roll: 90}, duration: 1}
        """)
    lines = [line for line, _, _ in _errors(path)]
    assert lines == [8, 9]


def test_no_false_alarms_from_the_broken_parts(write: WriteFn) -> None:
    # The bad tempo, the bad phrase and the bad duration are the only errors: no "needs a
    # tempo", no "unknown phrase", no overlap computed from guessed times, no unused warnings.
    path = write("""
        show: S
        tempo: {bpm: -5}
        performers:
          rex: {model: mini}
          idle: {model: lite}
        phrases:
          nod:
            cues: []
        tracks:
          rex:
            - {move: {pitch: 10}, duration: -1}
            - {move: {pitch: 5}, duration: 2}
            - {move: {pitch: 0}, at: 1, duration: 1}
            - {phrase: nod}
            - {action: stand_up, beats: 2}
        """)
    diags = validate_file(path)
    assert [d.origin.line for d in diags if d.origin] == [2, 8, 11]


def test_a_bad_performer_drops_its_track_only(write: WriteFn) -> None:
    path = write("""
        show: S
        performers:
          rex: {model: poodle}
          rio: {model: rider}
        tracks:
          rex:
            - {move: {pitch: 10}, duration: 1}
          rio:
            - {led: {led9: red}}
        """)
    assert [line for line, _, _ in _errors(path)] == [3, 9]


def test_a_dropped_length_is_not_also_missing(write: WriteFn) -> None:
    # A walk, an xArm pose and a Rider action (no documented time) need a length: when theirs
    # was malformed, that error is the only one. A cue that lost another timing field and
    # never had a length still needs one.
    walk = write("""
        show: S
        performers:
          rex: {model: mini}
          bob: {model: rider}
        tracks:
          rex:
            - {walk: {vx: 5}, duration: -1}
            - {walk: {vx: 5}, after: {beats: x}}
          bob:
            - {action: 1, beats: []}
        """)
    assert [(line, "needs" in msg) for line, _, msg in _errors(walk)] == [
        (7, False), (8, True), (8, False), (10, False)
    ]
    arm = write("""
        show: S
        performers:
          arm: {model: xarm}
        tracks:
          arm:
            - {pose: {1: 500}, bars: -2}
        """, "arm.yaml")
    assert [line for line, _, _ in _errors(arm)] == [6]
