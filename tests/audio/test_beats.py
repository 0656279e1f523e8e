"""``xgo-show beats`` on generated click tracks with tempo changes: the tempo map it writes,
included by a routine, puts every beat within 10 ms of the click that was recorded."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.audio.clicks import click_times, write_click_track
from xgo_show.audio.beats import Analysis, tempo_map
from xgo_show.choreo.loader import check_file
from xgo_show.choreo.timebase import Segment, TempoMap
from xgo_show.cli.main import main

SECTIONS = [(100.0, 32), (120.0, 32), (90.0, 24), (132.0, 16)]


def _routine(folder: Path, tempo_file: str) -> Path:
    path = folder / "show.yaml"
    path.write_text(
        "show: to the click\n"
        f"tempo: {{file: {tempo_file}}}\n"
        "performers: {rex: {model: mini}}\n"
        "tracks:\n  rex:\n    - {action: dance, at: '2.1'}\n",
        encoding="utf-8",
    )
    return path


@pytest.mark.parametrize("suffix", [".ogg", ".flac", ".mp3"])
def test_tempo_map_from_a_click_track_puts_every_beat_within_10_ms(
    tmp_path: Path, suffix: str, capsys: pytest.CaptureFixture[str]
) -> None:
    track = write_click_track(tmp_path / f"click{suffix}", SECTIONS, first_downbeat=1.3, pickup=2)
    out = tmp_path / "click.tempo.yaml"
    assert main(["beats", str(track.path), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert f"music: {{file: click{suffix}, offset: 1.300}}" in err

    show, diags = check_file(_routine(tmp_path, out.name))
    assert show is not None, [d.format() for d in diags]
    tempo = TempoMap([Segment(*row) for row in show.tempo_map])
    assert [row[0] for row in show.tempo_map] == [1, 9, 17, 23]  # one entry per tempo change
    offset = 1.3
    counted = track.beats[2:]  # the pickup comes before bar 1
    predicted = np.array([offset + tempo.seconds(i) for i in range(len(counted))])
    errors = np.abs(predicted - np.array(counted))
    assert errors.max() < 0.010, f"max beat error {errors.max() * 1000:.1f} ms"


def test_beats_prints_the_map_and_says_how_to_use_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    track = write_click_track(tmp_path / "waltz.wav", [(90.0, 24)], first_downbeat=0.4,
                              beats_per_bar=3)
    assert main(["beats", str(track.path), "--beats-per-bar", "3"]) == 0
    text = capsys.readouterr().out
    assert "tempo: {file: waltz.tempo.yaml}" in text
    entries = [line for line in text.splitlines() if line.startswith("  - ")]
    assert len(entries) == 1 and entries[0].endswith(", beats_per_bar: 3}"), entries
    assert abs(float(entries[0].split("bpm: ")[1].split(",")[0]) - 90) < 0.01


def test_beats_on_files_that_are_not_songs_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = tmp_path / "notes.ogg"
    text.write_text("not a song", encoding="utf-8")
    silence = tmp_path / "silence.wav"
    import soundfile as sf

    sf.write(silence, np.zeros(44100 * 3, dtype=np.float32), 44100)
    for path, says in [
        (tmp_path / "missing.ogg", "no such sound file"),
        (text, "cannot decode it"),
        (silence, "no steady beat found"),
    ]:
        assert main(["beats", str(path)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and says in err, err


def test_a_routine_names_the_tempo_file_errors_at_their_own_lines(tmp_path: Path) -> None:
    (tmp_path / "bad.tempo.yaml").write_text(
        "tempo:\n  - {bar: 1, bpm: 100}\n  - {bar: 5, bpm: -3}\n", encoding="utf-8"
    )
    _, diags = check_file(_routine(tmp_path, "bad.tempo.yaml"))
    assert any(d.origin and d.origin.file.endswith("bad.tempo.yaml") and d.origin.line == 3
               for d in diags), [d.format() for d in diags]
    _, diags = check_file(_routine(tmp_path, "none.tempo.yaml"))
    assert next(d.message for d in diags if d.is_error).startswith(
        "cannot read the tempo map 'none.tempo.yaml': no such file"
    )
    assert diags[0].origin is not None and diags[0].origin.line == 2


@settings(max_examples=60, deadline=None)
@given(
    sections=st.lists(
        st.tuples(st.floats(60, 200), st.integers(1, 6)), min_size=1, max_size=5
    ),
    jitter=st.floats(0, 0.001),
)
def test_tempo_map_meets_every_beat_it_was_made_from(
    sections: list[tuple[float, int]], jitter: float
) -> None:
    bars = [(bpm, count * 4) for bpm, count in sections]
    times = click_times(bars, 0.25)
    times += [times[-1] + 60.0 / bars[-1][0]]  # closes the last bar
    wobble = np.resize([jitter, -jitter], len(times))
    beats = tuple(float(t) for t in np.array(times) + wobble)
    analysis = Analysis(beats, 0, 4, tuple(60.0 for _ in beats))
    entries = tempo_map(analysis, tolerance=0.003)
    tempo = TempoMap([Segment(e.bar, e.bpm, 4) for e in entries])
    predicted = [beats[0] + tempo.seconds(i) for i in range(len(beats))]
    assert max(abs(p - b) for p, b in zip(predicted, beats, strict=True)) <= 0.003 + 2 * jitter
    assert len(entries) <= sum(count for _, count in sections)
