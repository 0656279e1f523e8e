"""What the show-control server says about a show (control/status.py), in-process."""

from __future__ import annotations

import time

import pytest

from xgo_show.choreo.sections import Section, Wait
from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.control.status import place, robots_status, show_summary, wall_time
from xgo_show.profiles import get_profile
from xgo_show.runtime.executor import ExecutorState, Progress
from xgo_show.runtime.show_runner import ShowProgress

LINK = get_profile("mini").link


def _schedule(**kw: object) -> Schedule:
    rex = PerformerSchedule("rex", "mini", LINK, (), 12.3456789)
    rio = PerformerSchedule("rio", "rider", LINK, (), 8.0)
    sections = (Section("intro", 0.0), Section("drop", 4.0000004, Wait("go", 2.5, "end")),
                Section("outro", 9.2500004, Wait("go")))  # fmt: skip
    return Schedule("demo", "demo.yaml", (rex, rio), 50.0, sections=sections, **kw)  # type: ignore[arg-type]


def test_wall_time_is_unix_seconds_to_the_microsecond() -> None:
    before = time.time()
    now = wall_time()
    assert before - 1e-6 <= now <= time.time() + 1e-6
    assert round(now, 6) == now


def test_place_gives_show_time_bar_beat_and_section() -> None:
    timed = _schedule(bpm=120.0, beats_per_bar=4)
    assert place(timed, 5.25) == {"show_time": 5.25, "bar": 3, "beat": 3.5, "section": "drop"}
    assert place(timed, 0.0) == {"show_time": 0.0, "bar": 1, "beat": 1.0, "section": "intro"}
    # Before the show (a count-in) the bar and beat are the show's first.
    assert place(timed, -1.0) == {"show_time": -1.0, "bar": 1, "beat": 1.0, "section": None}
    assert place(timed, 1.23456789) == {"show_time": 1.234568, "bar": 1, "beat": 3.469,
                                         "section": "intro"}  # fmt: skip
    assert place(_schedule(), 9.5) == {"show_time": 9.5, "section": "outro"}  # no tempo


def test_show_summary_lists_performers_sections_and_triggers() -> None:
    assert show_summary(_schedule(), "routines/demo.yaml") == {
        "name": "demo",
        "source": "routines/demo.yaml",
        "duration": 12.345679,
        "performers": [{"name": "rex", "model": "mini"}, {"name": "rio", "model": "rider"}],
        "sections": [
            {"name": "intro", "start": 0.0, "wait": None},
            {"name": "drop", "start": 4.0, "wait": {"trigger": "go", "timeout": 2.5,
                                                     "else": "end"}},
            {"name": "outro", "start": 9.25, "wait": {"trigger": "go", "timeout": None,
                                                      "else": "continue"}},
        ],
        "triggers": ["go"],
    }


def test_robots_status_per_performer() -> None:
    assert robots_status(None, {"rex": "port gone"}) == {}
    rex = Progress("rex", ExecutorState.RUNNING, 3.1234567, 40, 100, "rex: walk", "vx=10")
    rio = Progress("rio", ExecutorState.FAILED, 2.0, 7, 50, "", "")
    progress = ShowProgress(3.2, 20.0, (rex, rio), {"rex": {"battery": 87.0, "status": 1.0}})
    status = robots_status(progress, {"rio": "port gone"})
    assert status == {
        "rex": {"state": "running", "show_time": 3.123457, "cue": "rex: walk",
                "frames_sent": 40, "frames_total": 100, "battery": 87.0,
                "readings": {"battery": 87.0, "status": 1.0}, "fault": None},
        "rio": {"state": "failed", "show_time": 2.0, "cue": "",
                "frames_sent": 7, "frames_total": 50, "battery": None, "readings": {},
                "fault": "port gone"},
    }  # fmt: skip
    status["rex"]["readings"]["battery"] = 0.0  # a copy: the progress keeps its readings
    assert progress.telemetry["rex"]["battery"] == pytest.approx(87.0)
