"""A relay and its conductor on two "hosts" (network namespaces joined by a veth pair), each a
process of its own. Every show starts on the conductor's time although the relay's clock is 30 s
off and 80 ppm fast. Mid-show, a pulled cable (which TCP does not notice) or a frozen (SIGSTOP)
conductor ends in the upload's link-loss policy within the 500 ms watchdog: a safe stop, or the
show played to its end under ``continue``; the relay's run log says which, and the conductor
notices the silent relay within the watchdog too."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from tests.net.netns import Cable, Host
from tests.net.test_netns import Lines, _stop
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.profiles import get_profile
from xgo_show.runtime.safety import stop_frames
from xgo_show.sim import PtyServer, create_robot
from xgo_show.wire.xgo import write_frame

CONDUCTOR = str(Path(__file__).with_name("conductor_peer.py"))
WATCHDOG = 0.5
MARGIN = 0.15  # the stop frames themselves, and a loaded machine's wake-up


def sway(seconds: float) -> Schedule:
    """rex sways body_z every 50 ms for ``seconds``."""
    profile = get_profile("mini")
    reg = profile.register("body_z")
    frames = tuple(
        ScheduledFrame(
            k * 0.05, write_frame(reg.address, bytes((k % 128,)), write_type=profile.write_type)
        )
        for k in range(int(seconds / 0.05))
    )
    part = PerformerSchedule("rex", "mini", profile.link, frames, end=seconds)
    return Schedule("netns test", "-", (part,), 20.0)


@dataclass
class Stage:
    """A simulated robot here, its relay on host a, a conductor on host b."""

    sim: PtyServer
    relay: subprocess.Popen[str]
    conductor: subprocess.Popen[str]
    events: Lines
    cable: Cable
    log: Path
    seconds: float

    def received(self) -> list[tuple[float, bytes]]:
        with self.sim.lock:
            return [(f.t, f.data) for f in self.sim.robot.received]

    def stopped_at(self) -> float | None:
        last = stop_frames(get_profile("mini"))[-1].data
        times = [t for t, d in self.received() if d == last]
        return times[0] if times else None

    def started(self) -> float:
        """The show's start time (this machine's clock), once its first frame landed on it.

        The relay's clock reads 30 s ahead: unsynced, the show would start 30 s late. The skew
        itself (well under a millisecond) is measured by benchmarks/relay_sync.py; a loaded
        machine delays a pseudo-terminal by some milliseconds, hence the margin here.
        """
        started = json.loads(self.events.next())
        assert started["event"] == "started"
        start_at = float(started["start_at"])
        planned = {f.data for f in sway(self.seconds).performers[0].frames}  # not the reads
        first = _until(lambda: [t for t, d in self.received() if d in planned], 5.0)[0]
        assert -0.001 < first - start_at < 0.02
        return start_at

    def relay_events(self) -> list[dict[str, Any]]:
        lines = self.log.read_text(encoding="utf-8").splitlines()
        return [r for r in map(json.loads, lines) if "event" in r]


@pytest.fixture
def stage(two_hosts: tuple[Host, Host, Cable], tmp_path: Path) -> Iterator[Callable[..., Stage]]:
    a, b, cable = two_hosts
    made: list[Stage] = []

    def start(seconds: float, link_loss: str = "stop") -> Stage:
        sim = PtyServer(create_robot("mini")).start()
        env = {**os.environ, "XGO_SHOW_TEST_CLOCK": "offset=30,ppm=80"}
        endpoint = f"tcp/{a.address}:7447"
        log = tmp_path / "relay.jsonl"
        relay = a.popen(
            [sys.executable, "-m", "xgo_show", "relay", "--name", "left",
             "--map", f"rex={sim.path}", "--listen", endpoint, "--no-telemetry",
             "--log", str(log)],
            env=env,
        )  # fmt: skip
        assert relay.stdout is not None
        assert "ready" in relay.stdout.readline()
        show = tmp_path / "show.json"
        show.write_bytes(schedule_to_bytes(sway(seconds)))
        conductor = b.popen(
            [sys.executable, CONDUCTOR, endpoint, "left", str(show), link_loss],
            stdin=subprocess.PIPE,
        )
        made.append(Stage(sim, relay, conductor, Lines(conductor), cable, log, seconds))
        return made[-1]

    yield start
    for s in made:
        _stop(s.conductor, s.relay)
        s.sim.close()


def _until(predicate: Callable[[], Any], timeout: float) -> Any:
    deadline = time.monotonic() + timeout
    while not (value := predicate()):
        if time.monotonic() > deadline:
            raise AssertionError("the condition did not hold in time")
        time.sleep(0.002)
    return value


def _pull_cable(s: Stage) -> float:
    s.cable.unplug()
    return time.monotonic()


def _freeze_conductor(s: Stage) -> float:
    os.kill(s.conductor.pid, signal.SIGSTOP)
    return time.monotonic()


@pytest.mark.parametrize("fault", [_pull_cable, _freeze_conductor], ids=["cable", "frozen"])
def test_a_lost_conductor_mid_show_is_a_safe_stop_within_the_watchdog(
    stage: Callable[..., Stage], fault: Callable[[Stage], float]
) -> None:
    s = stage(3.0)
    start_at = s.started()
    _until(lambda: time.monotonic() > start_at + 0.3, 5.0)
    lost = fault(s)
    try:
        stopped = _until(s.stopped_at, 3.0)
    finally:
        os.kill(s.conductor.pid, signal.SIGCONT)
    assert stopped - lost < WATCHDOG + MARGIN
    link_lost = [e for e in s.relay_events() if e["event"] == "link_lost"]
    assert [e["policy"] for e in link_lost] == ["stop"]
    if fault is _pull_cable:  # a frozen conductor notices nothing, of course
        noticed = json.loads(s.events.next(3.0))
        assert noticed["event"] == "relay lost"
        assert noticed["t"] - lost < WATCHDOG + MARGIN


def test_a_pulled_cable_under_continue_plays_the_show_to_its_end(
    stage: Callable[..., Stage],
) -> None:
    s = stage(1.5, link_loss="continue")
    start_at = s.started()
    _until(lambda: time.monotonic() > start_at + 0.3, 5.0)
    pulled = _pull_cable(s)
    last = sway(1.5).performers[0].frames[-1]
    ended = _until(lambda: [t for t, d in s.received() if d == last.data], 3.0)[-1]
    assert ended > pulled + WATCHDOG  # it went on past the watchdog...
    assert abs(ended - (start_at + last.t)) < 0.02  # ...on its own clock, still on time
    assert s.stopped_at() is None or s.stopped_at() > ended  # no safe stop mid-show
    link_lost = [e for e in s.relay_events() if e["event"] == "link_lost"]
    assert [e["policy"] for e in link_lost] == ["continue"]
