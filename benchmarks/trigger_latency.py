"""Trigger latency over Zenoh: a client's trigger -> the first frame of the released section at
the robot, and a running show's timing under a flood of triggers.

Every part is its own OS process, as on a stage: ``xgo-show serve`` drives a simulated Mini on
a real pseudo-terminal (the simulator runs here, so each frame's arrival is timed where the
robot would see it); the clients that fire the triggers are started from this script
(``--client``); one more process keeps a CPU busy the whole time. Zenoh runs on 127.0.0.1 with
multicast scouting off. All times are CLOCK_MONOTONIC, which every process on the host shares.

1. A show of 200 sections, each waiting for ``go``. Side by side, two clients release them:
   - *push*: subscribes to the ``wait`` events and puts ``NS/trigger/go`` the moment one says
     the show holds;
   - *polling*: asks ``NS/status`` every 20 ms and, when it sees the show holding, fires the
     trigger as a query (the way a client that polls does everything).
   For each: trigger sent -> the section's first frame at the simulator, and the show began
   holding (its ``wait`` event) -> that frame.
2. A 14 s show without waits, played twice: alone, then while a client puts 1,000 triggers a
   second nobody waits for. Send-time error: each frame's arrival at the simulator minus its
   planned time (the start time the ``start`` reply gives, plus the frame's time).

Prints figures only (no asserts)::

    python benchmarks/trigger_latency.py [--triggers 200]
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import zenoh

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.client import ControlClient
from xgo_show.control.keys import event_key, trigger_key
from xgo_show.runtime.stats import percentile
from xgo_show.sim import create_robot
from xgo_show.sim.pty_server import PtyServer

NS = "bench-triggers"
POLL = 0.02  # seconds between the polling client's status queries
SECTION = 0.1  # seconds each section plays before the next wait


def triggered_routine(n: int) -> str:
    """``n`` sections after the first, each waiting for ``go``; each starts with a body height
    of its own (distinct from its neighbours'), the frame the benchmark looks for."""
    lines = ["show: Trigger latency", "performers:", "  rex: {model: mini}", "sections:",
             "  - {name: s0}"]
    lines += [f"  - {{name: s{k}, at: {k * SECTION:.1f}, wait: {{trigger: go}}}}"
              for k in range(1, n + 1)]
    lines += ["tracks:", "  rex:"]
    lines += [f"    - {{at: {k * SECTION:.1f}, set: {{body_z: {80 + k % 30}}}}}"
              for k in range(n + 1)]
    return "\n".join(lines) + "\n"


STEADY = """\
show: Steady
performers:
  rex: {model: mini}
tracks:
  rex:
    - repeat: 7
      cues:
        - {move: {pitch: 10, body_z: 110}, duration: 1.0}
        - {move: {pitch: -10, body_z: 90}, duration: 1.0}
"""


# ---------------------------------------------------------------------- client processes


def _session(endpoint: str) -> zenoh.Session:
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", "[]")
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    return zenoh.open(config)


def push_client(endpoint: str, count: int) -> None:
    """Fire ``go`` the moment a ``wait`` event says the show holds; print each send time."""
    with _session(endpoint) as session:
        waits: queue.Queue[dict[str, Any]] = queue.Queue()
        sub = session.declare_subscriber(
            event_key(NS, "wait"), lambda s: waits.put(json.loads(s.payload.to_bytes()))
        )
        ControlClient(session, NS).status()  # the subscription is in place: ready
        print("ready", flush=True)
        key = trigger_key(NS, "go")
        for _ in range(count):
            while (event := waits.get(timeout=30))["state"] != "waiting":
                pass
            sent = time.monotonic()
            session.put(key, b"{}", congestion_control=zenoh.CongestionControl.BLOCK)
            print(f"sent {event['section']} {sent:.6f}", flush=True)
        sub.undeclare()


def polling_client(endpoint: str, count: int) -> None:
    """Ask status every :data:`POLL` s; fire ``go`` as a query when the show holds."""
    with _session(endpoint) as session:
        client = ControlClient(session, NS)
        client.status()
        print("ready", flush=True)
        fired = ""
        for _ in range(count):
            while True:
                status = client.status()
                held = status.get("waiting_for") or {}
                if status["state"] == "waiting" and held.get("section") != fired:
                    break
                time.sleep(POLL)
            fired = held["section"]
            sent = time.monotonic()
            client.trigger("go")
            print(f"sent {fired} {sent:.6f}", flush=True)


def flood_client(endpoint: str, rate: int, seconds: float) -> None:
    """Put ``rate`` triggers a second nobody waits for, for ``seconds``."""
    with _session(endpoint) as session:
        ControlClient(session, NS).status()
        print("ready", flush=True)
        key, start, sent = trigger_key(NS, "lights"), time.monotonic(), 0
        while (now := time.monotonic()) < start + seconds:
            while sent < int((now - start) * rate):
                session.put(key, b"{}", congestion_control=zenoh.CongestionControl.BLOCK)
                sent += 1
            time.sleep(0.002)
        print(f"flooded {sent}", flush=True)


# ---------------------------------------------------------------------- the bench


def _free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


@contextmanager
def _process(*args: str) -> Iterator[subprocess.Popen[str]]:
    proc = subprocess.Popen(list(args), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.terminate()
        try:
            proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()


def _client(endpoint: str, mode: str, *extra: str) -> subprocess.Popen[str]:
    proc = subprocess.Popen(
        [sys.executable, __file__, "--client", mode, "--connect", endpoint, *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if line.strip() != "ready":
        proc.kill()
        why = proc.stderr.read() if proc.stderr else ""
        raise SystemExit(f"{mode} client did not start: {line}{why}")
    return proc


class Bench:
    """The serve process, its simulated robot and an operator's session."""

    def __init__(self, server: PtyServer, session: zenoh.Session, endpoint: str) -> None:
        self.server = server
        self.endpoint = endpoint
        self.client = ControlClient(session, NS, timeout=30.0)
        self.session = session
        # wall clock -> monotonic, for the events' and replies' Unix times
        self.wall_offset = time.time() - time.monotonic()

    def frames_since(self, t: float) -> list[tuple[float, bytes]]:
        with self.server.lock:
            return [(f.t, f.data) for f in self.server.robot.received if f.t >= t]

    def wait_until_loaded(self) -> None:
        while self.client.status()["state"] != "loaded":
            time.sleep(0.05)

    def triggered(self, path: Path, schedule: Schedule, mode: str, n: int
                  ) -> tuple[list[float], list[float]]:
        """(trigger sent -> first frame, hold began -> first frame) in seconds, per section."""
        waits: dict[str, float] = {}
        sub = self.session.declare_subscriber(event_key(NS, "wait"), lambda s: _wait(s, waits))
        self.client.command("load", path=str(path))
        first = {sec.name: _frame_at(schedule, sec.start) for sec in schedule.sections}
        proc = _client(self.endpoint, mode, "--count", str(n))
        began = time.monotonic()
        self.client.command("start")
        out, _ = proc.communicate(timeout=60 + n * 2)
        self.wait_until_loaded()
        sub.undeclare()
        frames = self.frames_since(began)
        sent_to_frame, hold_to_frame = [], []
        for line in out.splitlines():
            if not line.startswith("sent "):
                continue
            _, section, stamp = line.split()
            sent = float(stamp)
            arrived = next(t for t, data in frames if t > sent and data == first[section])
            sent_to_frame.append(arrived - sent)
            hold_to_frame.append(arrived - (waits[section] - self.wall_offset))
        return sent_to_frame, hold_to_frame

    def steady(self, path: Path, schedule: Schedule, flood: bool) -> list[float]:
        """Each frame's arrival minus its planned time, in seconds."""
        self.client.command("load", path=str(path))
        flooder = _client(self.endpoint, "flood", "--seconds", str(schedule.duration + 2)) \
            if flood else None
        try:
            reply = self.client.command("start", **{"in": 0.5})
            start = reply["start_time"] - self.wall_offset
            self.wait_until_loaded()
        finally:
            if flooder is not None:
                flooder.communicate(timeout=30)
        planned = [start + f.t for f in schedule.performers[0].frames]
        datas = [f.data for f in schedule.performers[0].frames]
        errors, i = [], 0
        for t, data in self.frames_since(start - 0.5):
            if i < len(datas) and data == datas[i]:
                errors.append(t - planned[i])
                i += 1
        if i != len(datas):
            raise SystemExit(f"only {i} of {len(datas)} frames of the steady show arrived")
        return errors


def _wait(sample: zenoh.Sample, waits: dict[str, float]) -> None:
    event = json.loads(sample.payload.to_bytes())
    if event["state"] == "waiting":
        waits[event["section"]] = event["time"]


def _frame_at(schedule: Schedule, t: float) -> bytes:
    return next(f.data for f in schedule.performers[0].frames if abs(f.t - t) < 1e-9)


def row(name: str, seconds: list[float]) -> str:
    ms = sorted(s * 1000 for s in seconds)
    p = [percentile(ms, q) for q in (0.5, 0.99, 0.999)]
    return f"{name:<58} {p[0]:8.2f} {p[1]:8.2f} {p[2]:8.2f} {ms[-1]:8.2f}  (n={len(ms)})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--triggers", type=int, default=200, help="triggers per client")
    parser.add_argument("--client", choices=("push", "polling", "flood"), help=argparse.SUPPRESS)
    parser.add_argument("--connect", help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--seconds", type=float, default=0.0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.client == "push":
        return push_client(args.connect, args.count)
    if args.client == "polling":
        return polling_client(args.connect, args.count)
    if args.client == "flood":
        return flood_client(args.connect, 1000, args.seconds)
    n = args.triggers
    with tempfile.TemporaryDirectory() as tmp, PtyServer(create_robot("mini")) as server:
        triggered_path, steady_path = Path(tmp) / "triggered.yaml", Path(tmp) / "steady.yaml"
        triggered_path.write_text(triggered_routine(n), encoding="utf-8")
        steady_path.write_text(STEADY, encoding="utf-8")
        triggered, steady = (compile_show(load_show(p)) for p in (triggered_path, steady_path))
        endpoint = _free_endpoint()
        with _process(sys.executable, "-c", "while True: pass"), \
                _process(sys.executable, "-m", "xgo_show", "serve", "--map",
                         f"rex={server.path}", "--no-telemetry", "--listen", endpoint,
                         "--namespace", NS), \
                _session(endpoint) as session:
            bench = Bench(server, session, endpoint)
            deadline = time.monotonic() + 30
            while True:
                try:
                    ControlClient(session, NS, timeout=1.0).status()
                    break
                except Exception:
                    if time.monotonic() > deadline:
                        raise
            push = bench.triggered(triggered_path, triggered, "push", n)
            poll = bench.triggered(triggered_path, triggered, "polling", n)
            quiet = bench.steady(steady_path, steady, flood=False)
            flooded = bench.steady(steady_path, steady, flood=True)
            counters = bench.client.status()["counters"]
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"xgo-show serve, a simulated Mini on a pty, Zenoh on loopback, one CPU kept busy; "
          f"load average {load}")
    print(f"\n1. {n} sections released by triggers, ms")
    print(f"{'':<58} {'p50':>8} {'p99':>8} {'p99.9':>8} {'max':>8}")
    print(row("push client: trigger put -> first frame at the robot", push[0]))
    print(row(f"polling client ({POLL * 1000:.0f} ms): trigger query -> first frame", poll[0]))
    print(row("push client: show began holding -> first frame", push[1]))
    print(row("polling client: show began holding -> first frame", poll[1]))
    print("\n2. send-time error of a running show (arrival at the robot - planned), ms")
    print(f"{'':<58} {'p50':>8} {'p99':>8} {'p99.9':>8} {'max':>8}")
    print(row("no triggers", quiet))
    print(row("1,000 triggers a second nobody waits for", flooded))
    print(f"\nserver counters: {json.dumps(counters)}")


if __name__ == "__main__":
    main()
