"""A relayed robot's timeline on the conductor: state changes at the relay's own times.

The relay is an ``xgo-show relay`` process whose clock reads 37.5 s ahead of this machine's and
runs 60 ppm fast (the test-only clock hook), with a simulated Mini on a real pty; the conductor
is this process (the launch stages over a ``zenoh:`` URL). Heartbeats come every 100 ms, so a
timeline built from their arrival is up to 100 ms late; the relay's forwarded events are not.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest

from xgo_show.net.session import SessionOptions
from xgo_show.net.testhooks import CLOCK_ENV
from xgo_show.relay import conductor
from xgo_show.relay.options import ConductorOptions
from xgo_show.relay.performer import MIN_NETWORK_LEAD
from xgo_show.runtime.events import StateChanged
from xgo_show.runtime.executor import ExecutorState
from xgo_show.runtime.launch import Launch
from xgo_show.runtime.runlog import RunLog
from xgo_show.runtime.show_runner import ShowResult

AHEAD = 0.3  # seconds between a command and the time it is due
EXACT = 0.010  # seconds: an event's time against the time it was due
#: seconds an event may trail the time it was due on a loaded machine, where the relay's
#: executor wakes late (13.6 ms seen in a full suite at load 12-15); a timeline built from the
#: heartbeats' arrival would be up to their 100 ms period late, a time before the due one wrong
LATE = 0.040


@pytest.fixture
def relayed() -> Iterator[None]:
    yield
    conductor.close_session()


def test_pauses_and_resumes_are_on_the_timeline_at_the_relays_times(
    relays, walk, until, relayed: None
) -> None:
    host = relays.start("far", {"rex": "mini"}, env={CLOCK_ENV: "offset=37.5,ppm=60"})
    show = walk(3.0, rex="mini")
    conductor.configure(
        ConductorOptions(session=SessionOptions(connect=(host.endpoint,), listen=()))
    )
    states: list[StateChanged] = []
    with RunLog() as log, Launch(show, {"rex": "zenoh:far/rex"}, telemetry=False) as launch:
        log.attach(launch.events)
        launch.events.subscribe(lambda e: states.append(e), StateChanged)  # type: ignore[arg-type]
        assert launch.open() == {} and launch.preflight().ok
        runner = launch.arm()
        rex = runner.performers["rex"]
        results: list[ShowResult] = []
        player = threading.Thread(
            target=lambda: results.append(launch.run(handle_signals=False)), daemon=True
        )
        player.start()

        def saw(state: ExecutorState, after: float) -> StateChanged:
            until(lambda: any(e.state is state and e.t > after for e in states), 3)
            return next(e for e in states if e.state is state and e.t > after)

        begin = saw(ExecutorState.RUNNING, 0.0).t
        assert runner.result is not None
        start_at = runner.result.start_at
        pause_at = time.monotonic() + AHEAD
        runner.pause(at=pause_at)
        paused = saw(ExecutorState.PAUSED, begin)
        resume_at = time.monotonic() + AHEAD
        runner.resume(at=resume_at)
        resumed = saw(ExecutorState.RUNNING, resume_at - 0.05)
        # The progress of a running relayed robot moves on between heartbeats.
        until(lambda: time.monotonic() > resume_at + 0.1, 2)
        now = time.monotonic()
        expected = paused.show_time + (now - resume_at)
        assert abs(rex.progress.show_time - expected) < 0.03

        # A command for "now" goes with a time too: the relay acts when every host can, and
        # a second one later is a command of its own (not taken for the first).
        asked = time.monotonic()
        rex.pause()
        again = saw(ExecutorState.PAUSED, resumed.t)
        assert again.t > asked + MIN_NETWORK_LEAD - EXACT
        rex.resume()
        back = saw(ExecutorState.RUNNING, again.t)
        rex.pause()
        saw(ExecutorState.PAUSED, back.t)
        runner.resume(at=time.monotonic() + AHEAD)
        player.join(10)
        assert results and results[0].completed, results
        records = [r for r in log.records if r["kind"] == "state"]

    assert -0.002 < paused.t - pause_at < LATE, paused.t - pause_at
    assert abs(paused.show_time - (pause_at - start_at)) < 1e-3
    assert -0.002 < resumed.t - resume_at < LATE, resumed.t - resume_at
    # It goes on where it stopped: its show time when it said so is the paused one plus how
    # late after the resume time it said so (a loaded machine wakes it a few ms late: seen
    # 2.0 ms in a full suite at load 10-15, which a bare "< 1 ms" took for a jump).
    lateness = resumed.t - resume_at
    assert abs(resumed.show_time - paused.show_time - lateness) < 1e-3, lateness
    logged = [(r["state"], r["t"]) for r in records]
    assert ("paused", round(paused.t, 6)) in logged and ("running", round(resumed.t, 6)) in logged
    assert [r["state"] for r in records][-1] == "finished"
