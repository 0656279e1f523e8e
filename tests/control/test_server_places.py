"""Where ``serve`` starts and seeks a show (control/server.py), in this process over the
recording session: a section's start, a bar and beat of the show's tempo, a time to the
microsecond, a start time given on the wall clock, and the refusals of each in words."""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from tests.conftest import wait_until as _wait_until
from tests.control.serving import Serve, refusal
from tests.control.staging import Stage
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule


def wait_until(predicate: Callable[[], object], timeout: float = 10.0) -> None:
    """Wait for what another thread does (generous: a loaded machine is slow)."""
    _wait_until(predicate, timeout)


@pytest.fixture
def tempo(stage: Stage, triggered_schedule: Schedule) -> Iterator[Serve]:
    """The triggered show at 120 bpm in 4/4 (a bar is 2 s, a beat 0.5 s), loaded (on stand-in
    robots)."""
    s = Serve()
    timed = dataclasses.replace(triggered_schedule, tempo_map=((1, 120.0, 4),))
    assert s.ask("load", schedule=schedule_to_bytes(timed).decode())["ok"]
    yield s
    s.close()


def test_a_start_at_a_section_starts_at_its_start(loaded: Serve) -> None:
    got = loaded.ask("start", section="b")
    assert got["ok"] and got["offset"] == 0.6
    assert "starting 'Triggered test' from 0.6 s (<schedule>)" in loaded.said
    show = [t for t in threading.enumerate() if t.name == "xgo-show show"]
    assert len(show) == 1 and show[0].daemon
    loaded.ask("stop")


def test_a_start_at_a_time_is_said_to_the_microsecond(loaded: Serve) -> None:
    before = time.time()
    got = loaded.ask("start", time=0.12345678)
    assert got["offset"] == 0.123457
    assert got["start_time"] == round(got["start_time"], 6)
    assert before - 1.0 < got["start_time"] < time.time() + 1.0
    loaded.ask("stop")


@pytest.mark.parametrize(("fields", "offset"), [
    ({"bar": 1, "beat": 3}, 1.0), ({"bar": 2}, 2.0), ({"bar": 1, "beat": 1.5}, 0.25)])
def test_a_start_at_a_bar_and_beat_of_the_tempo(tempo: Serve, fields: dict[str, float],
                                                offset: float) -> None:
    got = tempo.ask("start", **fields)
    assert got["ok"] and got["offset"] == offset, got
    tempo.ask("stop")


def test_a_beat_outside_its_bar_is_refused(tempo: Serve) -> None:
    refusal(tempo.ask("start", bar=1, beat=5), "start", "bad_request",
            "beat 5 is outside bar 1, which has beats 1..4")


def test_a_seek_to_a_section_or_a_bar_while_playing(tempo: Serve) -> None:
    tempo.ask("start", section="d")
    wait_until(lambda: tempo.server.status()["state"] in ("playing", "waiting"), timeout=10)
    got = tempo.ask("seek", section="b")
    assert got["ok"] and got["show_time"] == 0.6 and got["section"] == "b"
    got = tempo.ask("seek", bar=1, beat=2)
    assert got["ok"] and got["show_time"] == 0.5
    refusal(tempo.ask("seek", section="zz"), "seek", "not_found",
            "no section named 'zz'; sections: a, b, c, d")
    tempo.ask("stop")


def test_a_show_without_sections_names_none(serve: Serve, triggered_schedule: Schedule) -> None:
    plain = dataclasses.replace(triggered_schedule, sections=())
    serve.ask("load", schedule=schedule_to_bytes(plain).decode())
    refusal(serve.ask("start", section="a"), "start", "not_found",
            "no section named 'a'; sections: none")


def test_a_start_a_second_in_the_past_is_refused(loaded: Serve) -> None:
    got = loaded.ask("start", at=time.time() - 1.0)
    assert got["error"] == "bad_request" and got["message"].startswith("start time is 1.")
