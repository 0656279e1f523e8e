"""The relay's side of a remote behaviour, without the network: a :class:`StageHost` over a
simulated Rider on a real pty, driven with decoded relay requests. What it refuses (with the
reason), a routine played by its hash reaching the robot and its end reported with the play's
id, and the safe stop when the stage closes."""

from __future__ import annotations

import textwrap
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.conftest import wait_until
from xgo_show.behave import load_behaviour
from xgo_show.behave.relay_host import StageHost
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.errors import RelayRefused, UploadRefused
from xgo_show.net import messages as msg
from xgo_show.profiles import get_profile
from xgo_show.relay.robots import OwnedRobot
from xgo_show.relay.validate import schedule_digest
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.events import EventBus
from xgo_show.runtime.safety import stop_frames
from xgo_show.sim import create_robot
from xgo_show.sim.pty_server import PtyServer
from xgo_show.transports import open_transport

WHO = msg.Conductor("c1", "tester")


def _request(op: str, **fields: Any) -> msg.Request:
    """``op`` as the relay decodes it (fields checked as on the wire)."""
    raw = {"v": 1, "op": op, "seq": 1, "sent": 0.0, "conductor": WHO.to_json(), **fields}
    return msg.decode_request(msg.encode(raw))


@pytest.fixture
def host() -> Iterator[tuple[StageHost, PtyServer]]:
    with PtyServer(create_robot("rider")) as server:
        transport = open_transport(server.path)
        transport.open()
        robot = OwnedRobot("rex", server.path, "rider", transport)
        stage = StageHost({"rex": robot}, clock=MonotonicClock(), events=EventBus(),
                          allow_unsafe=False)
        try:
            yield stage, server
        finally:
            stage.close("test over")
            transport.close()


def _upload(tmp_path: Path, performer: str) -> tuple[str, str]:
    (tmp_path / "up.yaml").write_text(textwrap.dedent(f"""\
        show: up
        performers: {{{performer}: {{model: rider}}}}
        tracks:
          {performer}: [{{move: {{body_z: 80}}, duration: 0.6}}]
        """))
    (tmp_path / "b.yaml").write_text(textwrap.dedent(f"""\
        behaviour: b
        performers: {{{performer}: {{model: rider}}}}
        routines: {{up: up.yaml}}
        rules: [{{name: r, when: [{{startup: true}}], do: [{{play: up}}]}}]
        """))
    schedule = load_behaviour(tmp_path / "b.yaml").routines["up"]
    text = schedule_to_bytes(schedule).decode("ascii")
    return text, schedule_digest(text)


def test_refusals_say_why(host: tuple[StageHost, PtyServer], tmp_path: Path) -> None:
    stage, _ = host
    with pytest.raises(RelayRefused, match="stage is not open"):
        stage.handle(_request("stage_rest", robots=["rex"]))
    text, sha = _upload(tmp_path, "fido")
    with pytest.raises(UploadRefused, match="'fido' is not a robot of this relay"):
        stage.handle(_request("stage_upload", schedule=text, sha256=sha))
    with pytest.raises(RelayRefused, match="no robot fido on this relay"):
        stage.handle(_request("stage_open", robots=["fido"], telemetry=0.25, watchdog_ms=500))
    stage.handle(_request("stage_open", robots=["rex"], telemetry=0.25, watchdog_ms=500))
    with pytest.raises(RelayRefused, match="open already"):
        stage.handle(_request("stage_open", robots=["rex"], telemetry=0.25, watchdog_ms=500))
    with pytest.raises(RelayRefused, match="no uploaded schedule with SHA-256 00000000"):
        stage.handle(_request("stage_play", sha256="0" * 64, robots=["rex"], play=1))
    with pytest.raises(RelayRefused, match="robot fido is not on the behaviour stage"):
        stage.handle(_request("stage_rest", robots=["fido"]))


def test_a_play_by_hash_reaches_the_robot_and_its_end_comes_back(
    host: tuple[StageHost, PtyServer], tmp_path: Path
) -> None:
    stage, server = host
    text, sha = _upload(tmp_path, "rex")
    assert stage.handle(_request("stage_upload", schedule=text, sha256=sha)) == {"sha256": sha}
    stage.handle(_request("stage_open", robots=["rex"], watch=0.02, telemetry=0.25,
                          watchdog_ms=500))
    at = MonotonicClock().now() - 0.01  # already past: plays at once, and says how late
    reply = stage.handle(_request("stage_play", sha256=sha, robots=["rex"], play=7, at=at))
    assert reply["late"] >= 0.01
    ended: list[list[Any]] = []
    wait_until(lambda: ended.extend(stage.status()["ended"]) or ended, timeout=3.0)
    assert ended == [["rex", 7]]
    first = stage._schedules[sha].performers[0].frames[0].data
    with server.lock:
        assert first in [f.data for f in server.robot.received]
    stage.close("done")
    last = stop_frames(get_profile("rider"))[-1].data

    def stopped_last() -> bool:  # the simulator reads the pty in its own thread: wait for it
        with server.lock:
            return server.robot.received[-1].data == last

    wait_until(stopped_last)
    assert stage.status() == {"open": False, "ended": []}
