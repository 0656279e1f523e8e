"""Sections in ``run`` and ``dry-run`` (control/rehearsal.py), in this process: whether a show
can be played the way the user asked (a trigger script, MIDI timecode), in the user's words,
and the director (and script player) set up beside a runner for the length of a run.
test_script.py checks the same refusals through the command line."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.control.director import Director
from xgo_show.control.rehearsal import check_triggers, directed
from xgo_show.errors import ChoreographyError, UsageError

from .directing import Runner, SetClock, schedule

ROOT = Path(__file__).resolve().parents[2]


def script(tmp_path: Path, *names: str) -> Path:
    path = tmp_path / "script.yaml"
    path.write_text("triggers:\n" + "".join(f"  - {{trigger: {n}, after: 0.1}}\n"
                                             for n in names), encoding="utf-8")
    return path


def test_a_show_without_waits_needs_no_script() -> None:
    assert check_triggers(schedule(()), None) is None
    assert check_triggers(schedule(()), None, follow="mtc:0") is None


def test_a_show_that_waits_needs_a_script_or_serve() -> None:
    with pytest.raises(UsageError) as info:
        check_triggers(schedule(), None)
    assert str(info.value) == (
        "this show waits for trigger(s) go, encore, bow: rehearse it with --triggers "
        "SCRIPT.yaml (see docs/choreography.md), or serve it with 'xgo-show serve' and fire "
        "them with 'xgo-show trigger NAME'")


def test_a_script_of_the_shows_triggers_is_loaded(tmp_path: Path) -> None:
    got = check_triggers(schedule(), script(tmp_path, "go", "encore"), follow="osc:9000")
    assert got is not None and [c.trigger for c in got.triggers] == ["go", "encore"]
    assert check_triggers(schedule(), str(script(tmp_path, "bow"))) is not None


def test_a_script_naming_triggers_the_show_lacks_is_refused(tmp_path: Path) -> None:
    path = script(tmp_path, "go", "zed", "lights", "zed")
    with pytest.raises(UsageError) as info:
        check_triggers(schedule(), path)
    assert str(info.value) == (
        f"--triggers {path}: the show waits for no trigger named lights, zed; its triggers: "
        "go, encore, bow")


def test_a_script_for_a_show_without_waits_is_refused(tmp_path: Path) -> None:
    path = script(tmp_path, "go")
    with pytest.raises(UsageError) as info:
        check_triggers(schedule(()), path)
    assert str(info.value) == f"--triggers {path}: no section of this show waits for a trigger"


def test_a_script_that_is_not_one_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("triggers: 5\n", encoding="utf-8")
    with pytest.raises(ChoreographyError):
        check_triggers(schedule(), path)


@pytest.mark.parametrize("follow", ["mtc:0", "mtc"])
def test_a_show_that_waits_cannot_follow_midi_timecode(tmp_path: Path, follow: str) -> None:
    with pytest.raises(UsageError) as info:
        check_triggers(schedule(), script(tmp_path, "go"), follow=follow)
    assert str(info.value) == (
        f"--follow {follow}: this show waits for trigger(s) go, encore, bow, but MIDI timecode "
        "sets the show time every frame, so a hold at a wait would be taken for a timecode "
        "jump; follow the desk's OSC cues instead (--follow osc:PORT, waits released by "
        "--triggers SCRIPT.yaml), or serve the show ('xgo-show serve') and fire its triggers "
        "with 'xgo-show trigger NAME'")


def test_a_show_without_waits_runs_without_a_director() -> None:
    runner = Runner(schedule(()), "rex")
    with directed(runner, SetClock(), None) as director:  # type: ignore[arg-type]
        assert director is None


def test_a_show_that_waits_runs_with_a_director_closed_after(tmp_path: Path) -> None:
    runner = Runner(schedule(), "rex")
    clock = SetClock()
    said: list[str] = []
    loaded = check_triggers(schedule(), script(tmp_path, "go"))
    before = len(runner.events._entries)
    with directed(runner, clock, loaded, say=said.append) as director:  # type: ignore[arg-type]
        assert isinstance(director, Director)
        assert director.clock is clock and director.runner is runner
        assert len(runner.events._entries) > before + 1  # the director and the player listen
    assert len(runner.events._entries) == before  # and both let go after
    with directed(runner, clock, None) as director:  # type: ignore[arg-type]
        assert isinstance(director, Director)
