"""Relays as separate OS processes, each with simulated robots on real pseudo-terminals.

Zenoh runs on 127.0.0.1 with multicast scouting off and explicit endpoints: each relay listens
on a port of its own, and the conductor (this test process, or a child) connects to them.
"""

from __future__ import annotations

import os
import select
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import pytest

from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.net.session import SessionOptions, open_session
from xgo_show.profiles import get_profile
from xgo_show.relay.validate import schedule_digest
from xgo_show.runtime.safety import stop_frames
from xgo_show.sim import PtyServer, create_robot

READY_TIMEOUT = 20.0


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@pytest.fixture
def unused_port() -> int:
    return free_port()


@dataclass
class RelayProcess:
    """One ``xgo-show relay`` process and the simulators it drives."""

    name: str
    port: int
    proc: subprocess.Popen[str]
    servers: dict[str, PtyServer] = field(default_factory=dict)
    banner: str = ""

    @property
    def endpoint(self) -> str:
        return f"tcp/127.0.0.1:{self.port}"

    def stop_times(self, robot: str) -> list[float]:
        """When the simulator received the last frame of its model's safe stop."""
        server = self.servers[robot]
        last = stop_frames(get_profile(server.robot.model))[-1].data
        with server.lock:
            return [f.t for f in server.robot.received if f.data == last]

    def received(self, robot: str) -> list[bytes]:
        server = self.servers[robot]
        with server.lock:
            return [f.data for f in server.robot.received]

    def time_of(self, robot: str, data: bytes) -> float:
        """When the simulator received ``data`` first (this machine's monotonic clock)."""
        server = self.servers[robot]
        with server.lock:
            return next(f.t for f in server.robot.received if f.data == data)

    def kill(self, sig: int = signal.SIGKILL) -> None:
        if self.proc.poll() is None:
            os.kill(self.proc.pid, sig)


class Relays:
    """Starts relay processes; closes them and their simulators at the end."""

    def __init__(self) -> None:
        self.started: list[RelayProcess] = []

    def start(
        self,
        name: str,
        robots: dict[str, str],
        *extra: str,
        env: dict[str, str] | None = None,
        listen: bool = True,
    ) -> RelayProcess:
        relay = self.spawn(name, robots, *extra, env=env, listen=listen)
        self.ready(relay)
        return relay

    def start_many(self, specs: dict[str, dict[str, str]], *extra: str) -> list[RelayProcess]:
        """Start one relay per ``{name: robots}`` together (their start-ups overlap)."""
        started = [self.spawn(name, robots, *extra) for name, robots in specs.items()]
        for relay in started:  # they share the CPUs while starting: give each its share
            self.ready(relay, READY_TIMEOUT * max(1, len(started) // 2))
        return started

    def restart(self, old: RelayProcess, *extra: str) -> RelayProcess:
        """A new relay process in place of ``old`` (killed): same name, port and robots."""
        relay = self.spawn(old.name, {}, *extra, port=old.port, servers=old.servers)
        self.ready(relay)
        return relay

    def spawn(
        self,
        name: str,
        robots: dict[str, str],
        *extra: str,
        env: dict[str, str] | None = None,
        listen: bool = True,
        port: int | None = None,
        servers: dict[str, PtyServer] | None = None,
    ) -> RelayProcess:
        port = free_port() if port is None else port
        if servers is None:
            servers = {n: PtyServer(create_robot(model)).start() for n, model in robots.items()}
        cmd = [sys.executable, "-m", "xgo_show", "relay", "--name", name]
        for n, server in servers.items():
            cmd += ["--map", f"{n}={server.path}"]
        if listen:  # else the relay's --zenoh-config (in extra) names its endpoints
            cmd += ["--listen", f"tcp/127.0.0.1:{port}"]
        cmd += ["--no-telemetry", *extra]
        proc = subprocess.Popen(
            cmd,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, **(env or {})},
        )
        relay = RelayProcess(name, port, proc, servers)
        self.started.append(relay)
        return relay

    @staticmethod
    def ready(relay: RelayProcess, timeout: float = READY_TIMEOUT) -> None:
        """Wait for the relay's banner (it announces itself on Zenoh then)."""
        proc = relay.proc
        ready, _, _ = select.select([proc.stdout], [], [], timeout)
        assert proc.stdout is not None
        relay.banner = proc.stdout.readline() if ready else ""
        if "ready" not in relay.banner:
            proc.kill()
            raise AssertionError(
                f"relay {relay.name} did not start: {proc.stderr.read() if proc.stderr else ''}"
            )

    def close(self) -> None:
        for relay in self.started:
            if relay.proc.poll() is None:
                relay.proc.send_signal(signal.SIGCONT)
                relay.proc.terminate()
                try:
                    relay.proc.wait(5)
                except subprocess.TimeoutExpired:
                    relay.proc.kill()
                    relay.proc.wait(5)
            for stream in (relay.proc.stdout, relay.proc.stderr):
                if stream is not None:
                    stream.close()
        for server in {id(s): s for r in self.started for s in r.servers.values()}.values():
            server.close()  # once: a restarted relay shares its robots with the old one


@pytest.fixture
def relays() -> Iterator[Relays]:
    r = Relays()
    try:
        yield r
    finally:
        r.close()


@pytest.fixture
def conductor_session() -> Iterator[Callable[..., Any]]:
    """``open(*relays)``: a Zenoh session connected to those relays (closed at the end)."""
    opened: list[Any] = []

    def open_(*targets: RelayProcess) -> Any:
        session = open_session(
            SessionOptions(connect=tuple(r.endpoint for r in targets), listen=())
        )
        opened.append(session)
        return session

    yield open_
    for session in opened:
        session.close()


def upload_text(schedule: Schedule) -> tuple[str, str]:
    text = schedule_to_bytes(schedule).decode("ascii")
    return text, schedule_digest(text)


@pytest.fixture
def as_upload() -> Callable[[Schedule], tuple[str, str]]:
    return upload_text


def wait_for(predicate: Callable[[], bool], timeout: float = 5.0) -> float:
    """Poll until ``predicate()``; return the monotonic time it first held."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("the condition did not hold in time")
        time.sleep(0.005)
    return time.monotonic()


@pytest.fixture
def until() -> Callable[..., float]:
    return wait_for


def walk_schedule(seconds: float = 1.0, **models: str) -> Schedule:
    """Each performer (name=model) walks forward at once, then sways body_z every 50 ms."""
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.wire.xgo import write_frame

    parts = []
    for name, model in models.items():
        profile = get_profile(model)
        vx, body_z = profile.register("vx"), profile.register("body_z")
        wt = profile.write_type
        frames = [ScheduledFrame(0.0, write_frame(vx.address, vx.encode_value(0.1), write_type=wt))]
        frames += [
            ScheduledFrame(
                i * 0.05, write_frame(body_z.address, bytes((0x60 + i % 16,)), write_type=wt)
            )
            for i in range(1, int(seconds / 0.05))
        ]
        parts.append(PerformerSchedule(name, model, profile.link, tuple(frames), end=seconds))
    return Schedule("relay test", "test.yaml", tuple(parts), 20.0)


@pytest.fixture
def walk() -> Callable[..., Schedule]:
    return walk_schedule
