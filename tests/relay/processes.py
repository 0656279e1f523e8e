"""Relays as separate OS processes, each with simulated robots on real pseudo-terminals.

Zenoh runs on 127.0.0.1 with multicast scouting off and explicit endpoints: each relay listens
on a port of its own, and the conductor (a test, or a child process) connects to them. The
``relays`` fixture (tests/conftest.py) hands out a :class:`Relays`.
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field

from tests.loopback import free_port
from xgo_show.profiles import get_profile
from xgo_show.runtime.safety import stop_frames
from xgo_show.sim import PtyServer, create_robot

READY_TIMEOUT = 20.0


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
        # Every relay is told first, then waited for: each takes a few tenths of a second to
        # safe-stop its robots and close its session, and those overlap instead of adding up.
        running = [r for r in self.started if r.proc.poll() is None]
        for relay in running:
            relay.proc.send_signal(signal.SIGCONT)
            relay.proc.terminate()
        deadline = time.monotonic() + 5 * max(1, len(running) // 2)  # they share the CPUs
        for relay in running:
            try:
                relay.proc.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                relay.proc.kill()
                relay.proc.wait(5)
        for relay in self.started:
            for stream in (relay.proc.stdout, relay.proc.stderr):
                if stream is not None:
                    stream.close()
        for server in {id(s): s for r in self.started for s in r.servers.values()}.values():
            server.close()  # once: a restarted relay shares its robots with the old one
