"""A short triggered show played on simulated robots (real ptys), with every frame recorded."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
import zenoh

from tests.children import exited, first_answer
from tests.control.serving import Serve
from tests.control.staging import Stage, staged
from tests.loopback import client_config, free_port
from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.client import ControlClient
from xgo_show.control.director import Director
from xgo_show.runtime.clock import Clock, FakeClock, MonotonicClock
from xgo_show.runtime.events import Event, FrameSent
from xgo_show.runtime.launch import Launch
from xgo_show.runtime.show_runner import ShowResult
from xgo_show.sim.bench import SimBench

# Four sections of 0.6 s: a plays at once; b waits for 'go'; c waits for 'encore' at most
# 0.3 s, then skips to d.
ROUTINE = """\
show: Triggered test
performers:
  rex: {model: mini}
  ivy: {model: lite}
sections:
  - {name: a}
  - {name: b, at: 0.6, wait: {trigger: go}}
  - {name: c, at: 1.2, wait: {trigger: encore, timeout: 0.3, else: d}}
  - {name: d, at: 1.8}
tracks:
  rex:
    - {move: {pitch: 6}, duration: 0.5}
    - {at: 0.6, move: {pitch: 0}, duration: 0.5}
    - {at: 1.2, move: {pitch: 6}, duration: 0.5}
    - {at: 1.8, move: {pitch: 0}, duration: 0.5}
  ivy:
    - {move: {pitch: -6}, duration: 0.5}
    - {at: 0.6, move: {pitch: 0}, duration: 0.5}
    - {at: 1.2, move: {pitch: -6}, duration: 0.5}
    - {at: 1.8, move: {pitch: 0}, duration: 0.5}
"""


def status_or_none(client: ControlClient) -> dict[str, Any] | None:
    """The server's status, or None while no server answers (it is still starting)."""
    from xgo_show.errors import ControlFailed

    try:
        return client.status()
    except ControlFailed:
        return None


@contextmanager
def serve_process(show: Path, ns: str) -> Iterator[tuple[subprocess.Popen[str], str, list[str]]]:
    """An ``xgo-show serve --sim`` process with ``show`` loaded, on an endpoint of its own in
    namespace ``ns``: the process, its endpoint, and (once it has stopped) its output in a
    one-item list. It must stop cleanly when terminated."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "serve", "--sim", "--load", str(show),
         "--listen", endpoint, "--namespace", ns],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    output: list[str] = []
    try:
        yield proc, endpoint, output
    finally:
        proc.terminate()
        output.append(exited(proc, 10))
        assert proc.returncode == 0, output[0]


@contextmanager
def control_session(proc: subprocess.Popen[str], endpoint: str, ns: str) -> Iterator[zenoh.Session]:
    """A client session to the serve process at ``endpoint``, open once the server answers a
    status query (the handshake: a query answered means the server is up)."""
    s = zenoh.open(client_config(endpoint))
    try:
        first_answer(lambda: status_or_none(ControlClient(s, ns, timeout=1.0)), proc)
        yield s
    finally:
        s.close()


@pytest.fixture(scope="session")
def triggered_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The routine above, as a file."""
    path: Path = tmp_path_factory.mktemp("show") / "triggered.yaml"
    path.write_text(ROUTINE, encoding="utf-8")
    return path


@pytest.fixture(scope="session")
def triggered_schedule(triggered_path: Path) -> Schedule:
    return compile_show(load_show(triggered_path))


@dataclass
class Played:
    """What a directed run did: its result and every frame written (with write times)."""

    result: ShowResult | None = None
    frames: list[FrameSent] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)

    def record(self, event: Event) -> None:
        assert isinstance(event, FrameSent)
        self.frames.append(event)

    def scheduled(self, performer: str) -> list[FrameSent]:
        return [f for f in self.frames if f.performer == performer and f.kind == "frame"]


@contextmanager
def directed_show(
    schedule: Schedule, *, fast: bool = False
) -> Iterator[tuple[Director, Played, Callable[[], None]]]:
    """A director over a launch on simulators; call the yielded ``go()`` to run the show in
    a thread (``played.result`` is set when it ends)."""
    played = Played()
    clock: Clock = FakeClock(time.monotonic()) if fast else MonotonicClock()
    with (
        SimBench(schedule, [p.name for p in schedule.performers]) as sims,
        Launch(schedule, sims.urls, clock=clock, telemetry=False) as launch,
    ):
        launch.events.subscribe(played.events.append)
        launch.events.subscribe(played.record, FrameSent)
        launch.open()
        launch.preflight()
        runner = launch.arm()
        director = Director(runner, clock=clock)
        thread: list[threading.Thread] = []

        def go() -> None:
            def play() -> None:
                played.result = launch.run(handle_signals=False)

            th = threading.Thread(target=play, name="xgo-show test show")
            thread.append(th)
            th.start()

        try:
            yield director, played, go
        finally:
            if thread:
                thread[0].join(20.0)
                if thread[0].is_alive():
                    runner.stop("test over")
                    thread[0].join(5.0)
            director.close()

@pytest.fixture
def directed() -> Callable[..., Any]:
    """:func:`directed_show` as a fixture: ``with directed(schedule) as (director, played,
    go):``."""
    return directed_show


@pytest.fixture
def stage(monkeypatch: pytest.MonkeyPatch) -> Iterator[Stage]:
    """Stand-in robots (tests/control/staging.py) behind ``stand:`` URLs and in place of
    ``serve --sim``'s simulators."""
    with staged(monkeypatch) as s:
        yield s


@pytest.fixture
def serve(stage: Stage) -> Iterator[Serve]:
    """``serve``'s server over a recording session (tests/control/serving), ``--sim`` with
    stand-in robots in place of the simulators (tests/control/staging)."""
    s = Serve()
    yield s
    s.close()


@pytest.fixture
def loaded(serve: Serve, triggered_schedule: Schedule) -> Serve:
    """:func:`serve` with the triggered show loaded."""
    got = serve.ask("load", schedule=schedule_to_bytes(triggered_schedule).decode())
    assert got["ok"], got
    return serve
