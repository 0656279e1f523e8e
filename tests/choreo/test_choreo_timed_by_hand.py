"""The Rider's actions have no documented duration: a routine gives one by hand and is warned,
until it says it timed them (settings.timed_by_hand); a misspelt name there is an error."""

from __future__ import annotations

from pathlib import Path

from xgo_show.choreo import check_file


def _diags(tmp_path: Path, timed: str) -> list[str]:
    path = tmp_path / "show.yaml"
    path.write_text(
        f"show: t\nsettings: {{timed_by_hand: {timed}}}\nperformers:\n  rio: {{model: rider}}\n"
        "tracks:\n  rio:\n    - {action: swinging, duration: 4}\n"
        "    - {action: reset, duration: 1}\n")
    return [d.format().removeprefix(f"{path}:") for d in check_file(path)[1]]


def test_each_hand_timed_action_warns_until_acknowledged(tmp_path: Path) -> None:
    diags = _diags(tmp_path, "[]")
    assert [d.split(": ")[0] for d in diags] == ["7:7", "8:7"]
    assert all("warning:" in d and "say so: settings: {timed_by_hand: [" in d for d in diags)
    assert _diags(tmp_path, "[swinging]") == [d for d in diags if "'reset'" in d]
    assert _diags(tmp_path, "[swinging, reset]") == []


def test_a_misspelt_name_is_an_error_with_a_suggestion(tmp_path: Path) -> None:
    diags = _diags(tmp_path, "[swingin, reset]")
    assert diags[0].startswith("2:28: error: settings.timed_by_hand[0]: 'swingin' is not an "
                               "action without a documented duration on any performer's "
                               "robot; did you mean 'swinging'?")
