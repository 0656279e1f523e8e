"""Pause, resume and seek through two relay processes: every host acts at the same show time.

The conductor is this process (the launch stages over ``zenoh:`` URLs, as ``run`` uses them);
each relay is an ``xgo-show relay`` process with a simulated robot on a real pty. Every
schedule frame carries its own index, so what each simulator received says which show times
its host played, and when.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.net.session import SessionOptions
from xgo_show.profiles import get_profile
from xgo_show.relay import conductor
from xgo_show.relay.options import ConductorOptions
from xgo_show.runtime.events import ShowSought
from xgo_show.runtime.launch import Launch
from xgo_show.runtime.show_runner import ShowResult
from xgo_show.wire.xgo import write_frame

STEP = 0.05  # seconds between two numbered frames
COUNT = 100  # numbered frames: 5 s of show, room to seek ahead however late the pause came
AHEAD = 0.4  # seconds between a command and the time every host acts on it


def numbered(**models: str) -> Schedule:
    """Each performer walks, then writes body_z = 0x40 + i at i * STEP (a unique frame each)."""
    parts = []
    for name, model in models.items():
        profile = get_profile(model)
        vx, body_z = profile.register("vx"), profile.register("body_z")
        wt = profile.write_type
        frames = [ScheduledFrame(0.0, write_frame(vx.address, vx.encode_value(0.1), write_type=wt))]
        frames += [
            ScheduledFrame(i * STEP, write_frame(body_z.address, bytes((0x40 + i,)), write_type=wt))
            for i in range(1, COUNT)
        ]
        parts.append(PerformerSchedule(name, model, profile.link, tuple(frames), end=COUNT * STEP))
    return Schedule("numbered", "test.yaml", tuple(parts), 20.0)


@pytest.fixture
def relayed() -> Iterator[None]:
    yield
    conductor.close_session()


def test_pause_resume_and_seek_act_at_the_same_show_time_on_every_host(
    relays, until, relayed: None
) -> None:
    left, right = relays.start_many({"left": {"rex": "mini"}, "right": {"lola": "lite"}})
    hosts = ((left, "rex"), (right, "lola"))
    show = numbered(rex="mini", lola="lite")
    index = {
        name: {f.data: round(f.t / STEP) for f in show.performer(name).frames[1:]}
        for _, name in hosts
    }

    def played(relay: Any, name: str) -> list[tuple[float, int]]:
        """(receive time, index) of every numbered frame the robot received, in order."""
        server = relay.servers[name]
        with server.lock:
            got = list(server.robot.received)
        return [(f.t, index[name][f.data]) for f in got if f.data in index[name]]

    conductor.configure(
        ConductorOptions(session=SessionOptions(connect=(left.endpoint, right.endpoint), listen=()))
    )
    urls = {"rex": "zenoh:left/rex", "lola": "zenoh:right/lola"}
    with Launch(show, urls, telemetry=False, command_lead=AHEAD) as launch:
        assert launch.open() == {}
        assert launch.preflight().ok
        runner = launch.arm()
        sought: list[ShowSought] = []
        launch.events.subscribe(lambda e: sought.append(e), ShowSought)  # type: ignore[arg-type]
        results: list[ShowResult] = []
        player = threading.Thread(
            target=lambda: results.append(launch.run(handle_signals=False)), daemon=True
        )
        player.start()
        # The first frames on both hosts (or the run ended: then say how).
        until(lambda: all(played(r, n) for r, n in hosts) or not player.is_alive(), 20)
        assert all(played(r, n) for r, n in hosts), (results, [
            (n, len(played(r, n)), r.proc.poll()) for r, n in hosts])
        begin = runner.result.start_at if runner.result else 0.0

        # Pause between two frames: frames 1..k go out on both hosts, none after.
        k = round((time.monotonic() - begin + AHEAD) / STEP) + 2
        pause_at = begin + k * STEP + STEP / 2
        runner.pause(at=pause_at)
        until(lambda: time.monotonic() > pause_at + 0.3, 2)
        resume_at = time.monotonic() + AHEAD
        runner.resume(at=resume_at)
        until(lambda: time.monotonic() > resume_at + 0.2, 2)
        # Seek a second ahead of where the show will be: the test reads where the show is
        # instead of assuming how quickly this machine got here.
        planned = time.monotonic() + AHEAD
        target = k + math.ceil((planned - resume_at) / STEP) + 20
        assert target + 5 < COUNT, f"the show was at frame {target - 20} before the seek"
        runner.seek(target * STEP + STEP / 2, at=planned)
        player.join(10)
        assert results and results[0].completed, results
    # The runner may move a command that would reach its relays too late to a later time.
    (seek_at,) = (e.at for e in sought)
    reached = k + math.ceil((seek_at - resume_at) / STEP) + 1  # the last frame before it
    assert reached < target, f"the seek acted at frame {reached}, {seek_at - planned:.3f} s late"

    for relay, name in hosts:
        got = played(relay, name)
        before = [i for t, i in got if t < resume_at - 0.1]
        assert before == list(range(1, k + 1)), f"{name} paused at frame {before[-1]}, not {k}"
        quiet = [i for t, i in got if pause_at + 0.01 < t < resume_at - 0.1]
        assert not quiet, f"{name} received frames {quiet} while paused"
        # After the resume: frame k + 1 half a step after the resume time, on every host.
        t_next = next(t for t, i in got if i == k + 1)
        assert abs(t_next - (resume_at + STEP / 2)) < 0.010, name
        # The seek: frames reached + 1 .. target skipped, target + 1 half a step after seek_at.
        skipped = set(range(reached + 1, target + 1)) & {i for _, i in got}
        assert not skipped, f"{name} played {sorted(skipped)} across the seek"
        t_after = next(t for t, i in got if i == target + 1)
        assert abs(t_after - (seek_at + STEP / 2)) < 0.010, name
        assert got[-1][1] == COUNT - 1  # and on to the end
    firsts = [[t for t, i in played(r, n) if i in (k + 1, target + 1)] for r, n in hosts]
    assert abs(firsts[0][0] - firsts[1][0]) < 0.010 and abs(firsts[0][-1] - firsts[1][-1]) < 0.010
