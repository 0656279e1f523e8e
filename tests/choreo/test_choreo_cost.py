"""What a routine costs to check is bounded: the samples its moves and fades need are counted
before any is taken, and a show past MAX_SAMPLES is one error at the cue that passes it."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from xgo_show.choreo import validate_file
from xgo_show.choreo.resolve import MAX_SAMPLES

from .conftest import WriteFn


def _errors(path: Path) -> list[str]:
    return [d.format() for d in validate_file(path) if d.is_error]


@pytest.mark.parametrize(("rate", "seconds", "performers", "refused"), [
    (1000, 3500, 1, True),  # an hour-long move at 1000 Hz: 3.5 M samples
    (1000, 300, 2, True),  # 600,000 samples, the second robot passes the limit
    (1000, 240, 2, False),  # 480,000: inside
    (50, 3500, 2, False),  # 350,000
])
def test_samples_are_counted_before_any_is_taken(
    write: WriteFn, rate: int, seconds: float, performers: int, refused: bool
) -> None:
    names = [f"r{i}" for i in range(performers)]
    perf = "".join(f"  {n}: {{model: mini}}\n" for n in names)
    tracks = "".join(f"  {n}:\n    - {{move: {{body_z: [80, 110, 80]}}, duration: {seconds}}}\n"
                     for n in names)
    path = write(f"show: t\nsettings: {{control_rate: {rate}}}\nperformers:\n{perf}"
                 f"tracks:\n{tracks}")
    started = time.process_time()
    errors = _errors(path)
    if not refused:
        assert errors == []
        return
    assert time.process_time() - started < 2.0  # nothing was sampled
    [err] = errors
    passing = 0 if seconds * rate > MAX_SAMPLES else 1  # the robot whose move passes it
    line = 6 + performers + 2 * passing
    assert err.startswith(f"{path}:{line}:7: error: ") and f"{MAX_SAMPLES:,}" in err, err
    assert "lower settings.control_rate" in err


def test_a_long_fade_costs_its_colour_steps_not_its_length(write: WriteFn) -> None:
    """An hour-long fade at 1000 Hz changes colour a few hundred times: it is accepted."""
    path = write("show: t\nsettings: {control_rate: 1000}\nperformers:\n  r: {model: rider}\n"
                 "tracks:\n  r:\n    - {led: {all: red}, fade: 3500, duration: 3500}\n")
    assert _errors(path) == []


def test_a_broken_tempo_is_reported_once_where_it_is_written(
    write: WriteFn, tmp_path: Path
) -> None:
    """A tempo file that cannot be read is one error at tempo.file; the bar/beat times of the
    cues do not also say the show has no tempo, and the cues' own values are still checked."""
    os.mkfifo(tmp_path / "song.tempo.yaml")
    path = write("show: t\ntempo: {file: song.tempo.yaml}\nperformers:\n  rex: {model: mini}\n"
                 "tracks:\n  rex:\n    - {action: wave, at: \"2.1\"}\n"
                 "    - {move: {body_z: 999}, beats: 2}\n")
    errors = _errors(path)
    assert len(errors) == 2, errors
    assert errors[0].startswith(f"{path}:2:15: error: tempo.file: cannot read the tempo map")
    assert "named pipe" in errors[0]
    assert errors[1].startswith(f"{path}:8:23: error: ") and "999" in errors[1]


@pytest.mark.parametrize(("name", "problem"), [
    ("/dev/zero", "is a character device, not a regular file"),
    ("folder.wav", "is a directory"),
    ("none.wav", "no such sound file"),
])
def test_a_sound_file_that_is_no_file_says_what_it_is(
    write: WriteFn, tmp_path: Path, name: str, problem: str
) -> None:
    (tmp_path / "folder.wav").mkdir()
    path = write(f"show: t\nmusic: {{file: {name}}}\nperformers:\n  rex: {{model: mini}}\n"
                 "tracks:\n  rex: [{action: wave}]\n")
    [err] = _errors(path)
    assert err.startswith(f"{path}:2:15: error: music.file: ") and problem in err, err


def _param_bomb(use: str) -> str:
    """A phrase handed a 5,000-point list, played 10,000 times, using it as ``use``."""
    points = ", ".join(str(80 + i % 30) for i in range(5000))
    return (f"show: t\nperformers:\n  rex: {{model: mini}}\nphrases:\n  p:\n"
            f"    params: {{path: null}}\n    cues:\n      - {use}\n"
            f"tracks:\n  rex:\n    - repeat: 10000\n      cues:\n"
            f"        - {{phrase: p, with: {{path: [{points}]}}}}\n")


@pytest.mark.parametrize(("use", "where", "message"), [
    # Each point of a path is a cue for the robot: 5,000 a play.
    ("{move: {body_z: $path}, duration: 0.001}", (8, 9), "more than 20,000 cues for the robots"),
    # Never a cue, but copied into every play: counted as values, as YAML aliases are.
    ("{walk: {vx: 1}, duration: 0.1, limits: $path}", (13, 20),
     "expand to more than 1,000,000 values"),
])
def test_a_parameter_copied_into_each_play_is_counted(
    write: WriteFn, use: str, where: tuple[int, int], message: str
) -> None:
    path = write(_param_bomb(use))
    started = time.process_time()
    found = validate_file(path)
    assert time.process_time() - started < 5.0  # took 60 s and 2.6 GB before the count
    first = next(d for d in found if message in d.message)
    assert first.origin is not None and (first.origin.line, first.origin.column) == where
