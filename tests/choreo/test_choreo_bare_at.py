"""A bare number 'at:' in a show with a tempo is seconds: the user is asked whether a bar was
meant; "2s" says seconds on purpose."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.choreo import check_file


def _check(tmp_path: Path, at: str, tempo: bool) -> tuple[float | None, list[str]]:
    path = tmp_path / "show.yaml"
    path.write_text(("tempo: {bpm: 120}\n" if tempo else "") + (
        "show: t\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
        f"    - {{at: {at}, move: {{pitch: 10}}, duration: 1}}\n"))
    show, diags = check_file(path)
    start = show.tracks[0].cues[0].start if show is not None else None
    return start, [d.format() for d in diags]


def test_a_bare_number_with_a_tempo_warns_where_it_is(tmp_path: Path) -> None:
    start, diags = _check(tmp_path, "2", tempo=True)
    assert start == 2.0
    assert diags == [f"{tmp_path / 'show.yaml'}:7:12: warning: tracks.rex[0].at: at: 2 is 2 "
                     "seconds, not a bar (the show has a tempo): for bar 2 write \"2.1\"; to "
                     "keep seconds, write \"2s\""]


@pytest.mark.parametrize(("at", "tempo"), [('"2s"', True), ('" 2.0 s"', True), ("2", False)])
def test_seconds_said_on_purpose_or_without_tempo_do_not(tmp_path: Path, at: str,
                                                         tempo: bool) -> None:
    assert _check(tmp_path, at, tempo) == (2.0, [])
