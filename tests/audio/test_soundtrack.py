"""A routine's ``music:`` from the file to the run: checked at file:line:col, carried by the
compiled schedule, played by dry-run on the show clock (or a warning and a silent show)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.audio.clicks import write_click_track
from xgo_show.audio.sink import NoAudioDevice, open_sink
from xgo_show.choreo import load_show
from xgo_show.choreo.loader import check_file
from xgo_show.cli.main import main
from xgo_show.compiler import compile_show, load_schedule, save_schedule


def _routine(folder: Path, music: str) -> Path:
    path = folder / "show.yaml"
    path.write_text(
        "show: short\n"
        "tempo: {bpm: 120}\n"
        f"music: {music}\n"
        "performers: {rex: {model: mini}}\n"
        "tracks:\n  rex:\n    - {move: {body_z: 90}, at: '1.2', beats: 1}\n",
        encoding="utf-8",
    )
    return path


@pytest.fixture
def show(tmp_path: Path) -> Path:
    write_click_track(tmp_path / "song.wav", [(120.0, 8)], first_downbeat=0.25)
    return _routine(tmp_path, "{file: song.wav, offset: 0.25}")


def test_music_is_checked_where_it_is_written(tmp_path: Path) -> None:
    _, diags = check_file(_routine(tmp_path, "{file: gone.ogg, offset: 0.25}"))
    (error,) = [d for d in diags if d.is_error]
    assert error.message == "no such sound file: gone.ogg"
    assert error.origin is not None and (error.origin.line, error.origin.column) == (3, 15)
    _, diags = check_file(_routine(tmp_path, "{file: song.ogg, ofset: 1}"))
    assert any("ofset" in d.message and "offset" in d.message for d in diags), diags


def test_the_compiled_schedule_carries_the_music(show: Path, tmp_path: Path) -> None:
    schedule = compile_show(load_show(show))
    assert schedule.music is not None and schedule.music.offset == 0.25
    back = load_schedule(save_schedule(schedule, tmp_path / "show.xshow.json"))
    assert back.music == schedule.music


def test_dry_run_plays_the_music_on_the_null_device(
    show: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["dry-run", str(show), "--audio-device", "null", "--latency", "music=20",
                 "--no-telemetry"]) == 0
    out = capsys.readouterr().out
    assert "music: song.wav from +0.250 s, on the null device (no sound), 20 ms buffer" in out
    assert "show completed" in out
    assert "| music: 0:0" in out  # the progress line says where the music is


def test_without_an_audio_device_the_show_runs_silent(
    show: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    try:
        open_sink("default").close()
        pytest.skip("this machine has an audio device")  # CI and servers have none
    except NoAudioDevice:
        pass
    assert main(["dry-run", str(show), "--no-telemetry"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("warning: music: no audio device (")
    assert "the show runs silent" in out and "show completed" in out


def test_no_music_and_fast_say_so_and_bad_latency_is_one_line(
    show: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["dry-run", str(show), "--no-music", "--fast"]) == 0
    assert "music: song.wav not played (--no-music)" in capsys.readouterr().out
    assert main(["dry-run", str(show), "--fast"]) == 0
    assert "music: song.wav not played with --fast" in capsys.readouterr().out
    for bad, says in [("rex", "write NAME=MS"), ("bob=3", "no output 'bob'"),
                      ("rex=fast", "write NAME=MS")]:
        assert main(["dry-run", str(show), "--fast", "--latency", bad]) == 2
        err = capsys.readouterr().err.strip()
        assert says in err and "\n" not in err, err
