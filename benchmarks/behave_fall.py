"""Reaction time of a behaviour: a simulated fall on the wire -> the first frame of the routine
the fallen rule plays.

A simulated Rider on a real pseudo-terminal; ``xgo-show``'s behaviour runner polls its
telemetry over pyserial and runs one safety rule, ``tilt_beyond: 60 -> play get_up``. Each
round the benchmark makes the robot fall (its status register reads "fallen" from that
instant), takes the time, and waits for the first frame of ``get_up`` to be written to the
port (the runtime's FrameSent event: the write call); then it stands the robot up and waits
for the rule to re-arm. Side by side, the same rounds with:

- the default: status and attitude read every 20 ms (``WATCH_INTERVAL``), battery in rotation
  every 0.25 s; one reader per port across executors (a hand-over waits for no reader);
- the default with the writer threads real-time (``behave``'s default where permitted:
  SCHED_FIFO), which keeps the tail short on a busy machine; the first row is ``--no-realtime``;
- the naive polling (last session's): the three items in rotation, one every 0.25 s, so the
  status register is read once per 0.75 s cycle;
- the naive polling at a fast rotation (one item every 0.02 s);
- relayed: the same Rider behind an ``xgo-show relay`` in its own process (Zenoh on
  127.0.0.1, scouting off, explicit endpoints; ``--map rio=zenoh:bench/rio``). The relay reads
  the status every 20 ms and its heartbeat answers (every 20 ms) bring the readings here; the
  rule's play goes back as ``stage_play`` by hash with a start time. Its first frame is timed
  where the robot received it (the simulator's clock, this machine's), the local ones at the
  write call (the pty adds ~0.1 ms).

Prints figures only (no asserts)::

    python benchmarks/behave_fall.py [--rounds 40]

What limits it: the fall is seen at the next status read (uniform over the 20 ms watch
period, plus the ~2 ms request/reply on the wire); then the engine thread wakes, the watcher's
writer is stopped and joined, and the routine's writer thread starts and writes. A fall with
no reaction within 5 s is counted and shown with the events before it.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import os
import socket
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from xgo_show.behave import load_behaviour
from xgo_show.behave.engine import BehaviourNote
from xgo_show.behave.ports import WATCH_INTERVAL, BehaviourRunner
from xgo_show.behave.relayed import RelayAccess
from xgo_show.net.session import SessionOptions, open_session
from xgo_show.relay.client import new_conductor
from xgo_show.runtime.events import Event, EventBus, FrameSent, TelemetryRead
from xgo_show.runtime.realtime import configure
from xgo_show.runtime.stats import percentile
from xgo_show.sim import create_robot
from xgo_show.sim.pty_server import PtyServer
from xgo_show.transports import open_transport
from xgo_show.transports.base import Transport

ROUTINE = """\
show: get up
performers: {rio: {model: rider}}
tracks:
  rio: [{move: {body_z: 80}, duration: 0.6}]
"""
BEHAVIOUR = """\
behaviour: fall reaction
performers: {rio: {model: rider}}
routines: {get_up: get_up.yaml}
rules:
  - {name: fallen, safety: true, when: [{tilt_beyond: 60, clear: 30}], do: [{play: get_up}]}
"""


@contextlib.contextmanager
def relayed(server: PtyServer) -> Iterator[RelayAccess]:
    """``server``'s robot behind a relay process named ``bench``; access to it from here."""
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "relay", "--name", "bench", "--map",
         f"rio={server.path}", "--listen", f"tcp/127.0.0.1:{port}", "--no-telemetry"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    session = None
    try:
        assert proc.stdout is not None
        banner = proc.stdout.readline()
        if "ready" not in banner:
            raise SystemExit(f"the relay did not start: {banner}{proc.stdout.read()}")
        session = open_session(SessionOptions(connect=(f"tcp/127.0.0.1:{port}",), listen=()))
        yield RelayAccess({"rio": "zenoh:bench/rio"}, session, new_conductor("benchmark"))
    finally:
        if session is not None:
            session.close()  # type: ignore[no-untyped-call]
        proc.terminate()
        proc.wait(5)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def measure(
    folder: Path, interval: float, watch: float | None, rounds: int, misses: list[str],
    realtime: bool = False, relay: bool = False,
) -> dict[str, list[float]]:
    """Seconds from each fall to the first frame of the reacting routine (``total``) and its
    stages: the fallen status read back (``read``), the rule fired (``rule``), the first frame
    written (``start``). A fall with no reaction within 5 s is added to ``misses``."""
    behaviour = load_behaviour(folder / "behaviour.yaml")
    bus = EventBus()
    first: list[float] = []
    got = threading.Event()

    def on_frame(event: Event) -> None:
        if isinstance(event, FrameSent) and event.kind == "frame" and event.index == 0:
            first.append(event.t)
            got.set()

    bus.subscribe(on_frame, FrameSent)
    last: dict[str, tuple[float, float]] = {}  # telemetry name -> (time read, value)

    recent: collections.deque[str] = collections.deque(maxlen=30)
    marks: dict[str, float] = {}  # this round: when the fall was read back, the rule fired

    def on_reading(event: Event) -> None:
        if isinstance(event, TelemetryRead):
            last[event.name] = (event.t, event.value)
            if event.name == "status" and event.value == 0:
                marks.setdefault("read", event.t)
                marks.setdefault("here", time.monotonic())  # relayed: after a heartbeat
        elif isinstance(event, BehaviourNote) and event.kind == "fired":
            # the note carries the reading's time: take the time the engine decided
            marks.setdefault("rule", time.monotonic())
        text = event.text if isinstance(event, BehaviourNote) else getattr(event, "name", "")
        recent.append(f"{event.t:.3f} {type(event).__name__} {text} {getattr(event, 'value', '')}")

    bus.subscribe(on_reading, TelemetryRead, BehaviourNote)
    out: dict[str, list[float]] = {"total": [], "read": [], "beat": [], "rule": [], "start": []}
    get_up = behaviour.routines["get_up"].performers[0].frames[0].data
    with contextlib.ExitStack() as stack:
        server = stack.enter_context(PtyServer(create_robot("rider", seed=1)))
        if relay:
            access: RelayAccess | None = stack.enter_context(relayed(server))
            transports: dict[str, Transport] = {}
        else:
            access = None
            transport = open_transport(server.path)
            transport.open()
            stack.callback(transport.close)
            transports = {"rio": transport}
        runner = BehaviourRunner(behaviour, transports, events=bus, relays=access,
                                 telemetry_interval=interval, watch_interval=watch)

        def arrived(after: float) -> float:
            """When the robot received get_up's first frame (after ``after``)."""
            with server.lock:
                return next(f.t for f in server.robot.received
                            if f.data == get_up and f.t >= after)

        # The writer threads raise themselves under "auto" (where permitted); the
        # simulator's threads keep normal priority.
        configure("auto" if realtime else "off")

        def run() -> None:
            runner.run()

        thread = threading.Thread(target=run)
        thread.start()
        try:
            time.sleep(2.0 if relay else 0.5)
            for _ in range(rounds):
                got.clear()
                marks.clear()
                with server.lock:
                    fell = time.monotonic()
                    server.robot.fall()  # type: ignore[attr-defined]
                if got.wait(5.0):
                    frame = arrived(fell) if relay else first[-1]
                    out["total"].append(frame - fell)
                    read, rule = marks.get("read", fell), marks.get("rule", fell)
                    here = marks.get("here", read)
                    out["read"].append(read - fell)
                    out["beat"].append(here - read)
                    out["rule"].append(rule - here)
                    out["start"].append(frame - rule)
                else:  # counted and shown: the last events before it
                    misses.append(f"fall at {fell:.3f}: " + " | ".join(recent))
                with server.lock:
                    server.robot.recover()  # type: ignore[attr-defined]
                    stood = time.monotonic()
                deadline = stood + 10
                # The rule's run ends with its routine (single mode: a fall seen while it
                # runs would be skipped), and status and roll read after the robot stood up
                # say it is upright (below clear): the rule is armed again.
                while time.monotonic() < deadline and not (
                    runner.engine.playing("rio") is None
                    and last.get("status", (0.0, 0.0))[0] > stood
                    and last["status"][1] != 0
                    and last.get("imu_roll", (0.0, 90.0))[0] > stood
                    and abs(last["imu_roll"][1]) < 30
                ):
                    time.sleep(0.01)
        finally:
            runner.stop()
            thread.join(5)
    return out


def row(name: str, values: list[float]) -> str:
    ms = sorted(v * 1000 for v in values) or [float("nan")]
    p = [percentile(ms, q) for q in (0.5, 0.99, 0.999)]
    return (f"{name:<40} {p[0]:8.1f} {p[1]:8.1f} {p[2]:8.1f} {ms[-1]:8.1f}  ({len(ms)} falls)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=40, help="falls per configuration")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "get_up.yaml").write_text(textwrap.dedent(ROUTINE))
        (folder / "behaviour.yaml").write_text(textwrap.dedent(BEHAVIOUR))
        misses: list[str] = []
        default = measure(folder, 0.25, WATCH_INTERVAL, args.rounds, misses)
        fifo = measure(folder, 0.25, WATCH_INTERVAL, args.rounds, misses, realtime=True)
        naive = measure(folder, 0.25, None, args.rounds, misses)
        naive_fast = measure(folder, 0.02, None, args.rounds, misses)
        remote = measure(folder, 0.25, WATCH_INTERVAL, args.rounds, misses, relay=True)
    print(f"fall on the wire -> first frame of the reacting routine, ms (load {load()})")
    print(f"{'':<40} {'p50':>8} {'p99':>8} {'p99.9':>8} {'max':>8}")
    print(row(f"--no-realtime: status every {WATCH_INTERVAL:g} s", default["total"]))
    print(row("  fall -> fallen status read back", default["read"]))
    print(row("  read -> rule fired", default["rule"]))
    print(row("  fired -> first frame written", default["start"]))
    print(row("default: SCHED_FIFO writers", fifo["total"]))
    print(row("  fall -> fallen status read back", fifo["read"]))
    print(row("  fired -> first frame written", fifo["start"]))
    print(row("naive: 3 items in turn, one per 0.25 s", naive["total"]))
    print(row("  fall -> fallen status read back", naive["read"]))
    print(row("naive: 3 items in turn, one per 0.02 s", naive_fast["total"]))
    print(row("relayed (relay process, Zenoh loopback)", remote["total"]))
    print(row("  fall -> fallen status read on the relay", remote["read"]))
    print(row("  read there -> reading here (heartbeat)", remote["beat"]))
    print(row("  reading here -> rule fired", remote["rule"]))
    print(row("  fired -> first frame at the robot", remote["start"]))
    print(f"falls with no reaction within 5 s: {len(misses)}")
    for miss in misses:
        print("  " + miss)
    print("(p99.9 of a few dozen falls is the max)")


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


if __name__ == "__main__":
    main()
