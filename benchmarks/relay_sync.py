"""How together do relays on several "hosts" start and stay? Clock sync vs the naive way.

Relays run as separate ``xgo-show relay`` processes, each owning one simulated robot served by
its own ``xgo-show simulate --record`` process on a real pseudo-terminal. Every relay's clock
is made wrong on purpose (``XGO_SHOW_TEST_CLOCK``): a random offset of up to +-100 s and a
rate error of up to +-100 ppm. The simulators timestamp what they receive with this machine's
monotonic clock, which they all share, so the spread of those timestamps is the true skew.

Each relay plays as ``xgo-show relay`` does by default (its writer thread under SCHED_FIFO
where permitted, docs/realtime.md); with ``--no-realtime-too`` a second group of relays with
``--no-realtime`` (normal priority) plays the same synced starts and drift show in the same
run. Two ways to start the same show on every relay, in the same run:

- **synced**: the conductor measures each relay's clock (NTP-style, lowest round trips) and
  pushes the timebase, which the relay's show clock follows; ``start`` carries a start time,
  so every relay starts at the same instant; a clock tracker keeps measuring during the show
  and the relays slew onto each new drift estimate;
- **naive**: ``start`` with ``start_in``: each relay starts a fixed lead after the command
  arrives on its own (uncorrected) clock, as a system without clock sync would.

Figures (ms, p50/p99/p99.9/max; with 20 starts p99 and up are the largest values), each
with the load average it was taken at:

1. start skew: spread of the first frame's receive time across the robots, per start, beside
   baselines started in turn with the relays (so every column sees the same load): the same
   robots driven by one local process, by N local processes (one robot each: the relays'
   shape with no network and no clock to estimate), and a bare wake-up floor (N processes
   whose one SCHED_FIFO thread only sleeps to the start). Its parts, per robot and as their
   spread across the robots: (a) the relay's clock estimate's error (where its clock put the
   start, on this machine's clock: ``XGO_SHOW_TEST_TRACE`` makes each relay log its first
   frame's planned and actual write time on both clocks), (b) issue lateness (the write
   against the planned time), (c) delivery (the simulator's receive time against the write);
2. skew after a long show (``--drift-seconds``, 60 by default): spread of the receive time of
   the show's first and last frame, synced with tracking, synced without tracking (offset
   only), naive, and the same show on the N local processes of part 1 (their own simulators;
   ``--drift-one-process``: on the one local process too), played in turn with the synced
   relays ``--drift-rounds`` times; and one table of every frame of its last 10 s
   (p50/p99/p99.9/max over 200 frames a show, the load average at the show's start and end),
   split into the same parts as a start (the relays' ``frames_host`` records, the local
   processes' own): (a) the spread of the planned write times (where each relay's slewing
   clock put the frame; for synced relays also each one's error against the true time),
   (b) issue lateness, (c) delivery; and (b) over the whole show;
3. send-time error at the robot (receive time - planned time) of a relayed robot vs the same
   schedule played by the local processes: what the relay adds;
4. the estimator with a test-only delay on every time-sync reply (5 ms +- 2 ms, one way): its
   error against the bound it reports, and the start skew it gives;
5. scale: the same start with ``--scale`` relays (16 by default): set-up time, start skew,
   command round trip, and the conductor's CPU per second while it keeps them synced.

Prints figures only (no asserts). It takes minutes: run it outside the land lock, under
``nice`` on a shared machine::

    python benchmarks/relay_sync.py [--relays 4] [--starts 20] [--drift-seconds 60] [--scale 16]
    python benchmarks/relay_sync.py --quick     # about a minute: 5 starts, 10 s drift, no scale

``--trace-ab`` plays relays without the tracer (``XGO_SHOW_TEST_TRACE``) in turn with the traced
ones, ``--before REV`` relays running revision REV's ``xgo_show`` (in the drift shows too); for
each, every frame's delivery and the p50 differences against the local processes, with a
bootstrap interval over the start rounds. ``--keep DIR`` keeps every record (simulators', relays'
run logs) and ``--thread-names`` has each relay note its threads' kernel ids and names there
(``relay_variants.py --threads``), to read a kernel trace of the run against them.
``--sim-realtime`` raises the simulators (the measuring instrument) to SCHED_FIFO 20, above the
writers, once they are ready, so their wake-ups (a robot has a CPU of its own) leave the
figures; ``--estimates 0`` skips part 4; ``--no-realtime-too`` adds relays and a local runner
with ``--no-realtime``.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import resource
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.errors import NetworkError, TimeSyncError
from xgo_show.net.keys import relay_key
from xgo_show.net.session import SessionOptions, open_session
from xgo_show.net.testhooks import CLOCK_ENV, DELAY_ENV, TRACE_ENV
from xgo_show.net.timesync import ClockTracker, measure
from xgo_show.profiles import get_profile
from xgo_show.relay.client import RelayClient
from xgo_show.relay.validate import schedule_digest
from xgo_show.runtime import realtime
from xgo_show.runtime.clock import MonotonicClock, hand_off_cpu, tighten_timer_slack
from xgo_show.runtime.events import EventBus, EventRecorder, FrameSent
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.realtime import enter_show_thread
from xgo_show.runtime.report import percentile
from xgo_show.transports import open_transport
from xgo_show.wire.xgo import write_frame

MODEL = "mini"
RATE = 20.0  # frames per second in the shows
LEAD = 0.5  # seconds between the start commands and the start
SHORT = 0.3  # seconds of show per start
WAKE = "bare wake-up"  # the floor: processes that only wake at the start (start_waker)
#: the relays' (and local runner's) real-time options, by group: the default and the opt-out
GROUPS: dict[str, tuple[str, ...]] = {"": (), " --no-realtime": ("--no-realtime",)}
#: with --sim-realtime: the simulators' SCHED_FIFO priority, so they wake at once like robots
SIM_PRIORITY: list[int] = []
#: with --thread-names: relays started through relay_variants.py --threads (see start_relays)
THREAD_NAMES: list[bool] = []


# ---------------------------------------------------------------------------- processes


@dataclass
class Sim:
    """One ``xgo-show simulate --record`` process."""

    proc: subprocess.Popen[str]
    path: str
    record: Path

    def frames(self) -> list[tuple[float, str]]:
        """(receive time, hex) of every frame, once the process has ended."""
        out = []
        for line in self.record.read_text(encoding="utf-8").splitlines():
            row = json.loads(line)
            out.append((float(row["t"]), str(row["hex"])))
        return out


@dataclass
class Relay:
    """One ``xgo-show relay`` process owning one simulated robot, and its client."""

    name: str
    port: int
    proc: subprocess.Popen[str]
    sim: Sim
    offset: float
    ppm: float
    log: Path | None = None  # its run log (--log)
    client: RelayClient | None = None
    tracker: ClockTracker | None = None
    sha: str = ""

    def sync(self, session: object, *, track: bool = True) -> None:
        """Measure the relay's clock and push the timebase; keep tracking it if ``track``."""
        assert self.client is not None
        self.unsync()
        self.tracker = ClockTracker(
            session,  # type: ignore[arg-type]
            relay_key("xgo-show", self.name, "time"),
            conductor=self.client.conductor.id,
            interval=1.0,
        )
        self.tracker.start()
        if not track:
            self.tracker.close()  # kept (closed): a claim again syncs it again

    def unsync(self) -> None:
        if self.tracker is not None:
            self.tracker.close()
            self.tracker = None


@dataclass
class Rig:
    """Every process of one configuration; :meth:`close` ends them all."""

    tmp: Path
    relays: list[Relay] = field(default_factory=list)
    sims: list[Sim] = field(default_factory=list)
    locals: list[subprocess.Popen[str]] = field(default_factory=list)  # --local-child ones

    def close(self) -> None:
        for proc in self.locals:
            if proc.stdin is not None:
                proc.stdin.close()  # its end of input: it closes its ports and exits
        for proc in self.locals:
            _wait(proc)
        for relay in self.relays:
            if relay.client is not None:
                relay.client.stop_heartbeat()
            relay.unsync()
            if relay.proc.poll() is None:
                relay.proc.send_signal(signal.SIGINT)
        for relay in self.relays:
            _wait(relay.proc)
        for sim in self.sims:
            if sim.proc.poll() is None:
                sim.proc.send_signal(signal.SIGINT)
        for sim in self.sims:
            _wait(sim.proc)


def _wait(proc: subprocess.Popen[str]) -> None:
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
    for stream in (proc.stdin, proc.stdout, proc.stderr):
        if stream is not None:
            stream.close()


def _free_port() -> int:
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def start_sim(tmp: Path, name: str) -> Sim:
    record = tmp / f"{name}.jsonl"
    command = [sys.executable, "-m", "xgo_show", "simulate", "--model", MODEL, "--record"]
    proc = subprocess.Popen(
        [*command, str(record)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    assert proc.stdout is not None
    path = proc.stdout.readline().strip()
    if not path.startswith("/dev/"):
        raise SystemExit(f"simulator {name} did not start")
    if SIM_PRIORITY:
        # Raised once ready, every thread: its start-up (imports) must not run above every
        # other process on the machine.
        subprocess.run(
            ["chrt", "-a", "-f", "-p", str(SIM_PRIORITY[0]), str(proc.pid)],
            check=True,
            stdout=subprocess.DEVNULL,
        )
    return Sim(proc, path, record)


def start_relays(
    rig: Rig,
    count: int,
    rng: random.Random,
    *,
    prefix: str,
    env: dict[str, str] | None = None,
    ppm: bool = True,
    flags: Sequence[str] = (),
) -> list[Relay]:
    """``count`` relays with random clock errors (ppm 0 if not ``ppm``); waits until ready."""
    made = []
    for i in range(count):
        name = f"{prefix}{i}"
        sim = start_sim(rig.tmp, name)
        rig.sims.append(sim)
        offset = rng.uniform(-100.0, 100.0)
        rate = rng.uniform(-100.0, 100.0) if ppm else 0.0
        port = _free_port()
        log = rig.tmp / f"{name}-run.jsonl"
        # --thread-names: through relay_variants.py, which notes each Python thread's kernel
        # id and name (NAME-threads.txt: a kernel trace names the threads with it)
        names = rig.tmp / f"{name}-threads.txt"
        via = [str(Path(__file__).with_name("relay_variants.py")), "--threads", str(names), "--"]
        proc = subprocess.Popen(
            [
                sys.executable,
                *(via if THREAD_NAMES else ["-m", "xgo_show"]),
                "relay",
                "--name",
                name,
                "--map",
                f"bot={sim.path}",
                "--listen",
                f"tcp/127.0.0.1:{port}",
                "--no-telemetry",
                "--log",
                str(log),
                *flags,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, CLOCK_ENV: f"offset={offset!r},ppm={rate!r}", **(env or {})},
        )
        made.append(Relay(name, port, proc, sim, offset, rate, log))
        rig.relays.append(made[-1])
    for relay in made:
        assert relay.proc.stdout is not None
        if "ready" not in relay.proc.stdout.readline():
            err = relay.proc.stderr.read() if relay.proc.stderr else ""
            raise SystemExit(f"relay {relay.name} did not start: {err}")
    return made


def connect(relays: Sequence[Relay]) -> object:
    return open_session(
        SessionOptions(
            connect=tuple(f"tcp/127.0.0.1:{r.port}" for r in relays),
            listen=("tcp/127.0.0.1:0",),
        )
    )


def claim(session: object, relay: Relay, *, sync: bool = True) -> None:
    for attempt in range(3):
        client = RelayClient(session, relay.name)  # type: ignore[arg-type]
        client.request("hello", timeout=10.0)  # resent until the session has a route
        # 3 s, as the relays' watchdog in upload(): a conductor that hears no answer for its
        # watchdog gives the relay up and stops heartbeating it (seen at load 15: a drift
        # show's relay then let its holder go, and the run ended with a traceback).
        client.start_heartbeat(period=0.1, watchdog=3.0)
        relay.client = client
        if not sync:
            return
        try:
            relay.sync(session)
            return
        except TimeSyncError as exc:
            # A relay process starved for its watchdog time (the machine is shared) lets its
            # holder go; claim it again rather than lose the run.
            print(f"   ({relay.name}: {exc}; claiming it again; its log: {released(relay)})")
            client.stop_heartbeat()
            if attempt == 2:
                raise


# ---------------------------------------------------------------------------- shows


def make_schedule(seconds: float, names: Sequence[str] = ("bot",)) -> Schedule:
    """Robots swaying body_z every 1/RATE s (every frame's byte tells its index mod 128)."""
    profile = get_profile(MODEL)
    reg = profile.register("body_z")
    n = max(2, round(seconds * RATE))
    frames = tuple(
        ScheduledFrame(
            k / RATE, write_frame(reg.address, bytes((k % 128,)), write_type=profile.write_type)
        )
        for k in range(n)
    )
    parts = tuple(
        PerformerSchedule(name, MODEL, profile.link, frames, end=frames[-1].t + 0.05)
        for name in names
    )
    return Schedule("relay sync benchmark", "-", parts, RATE)


def upload(relays: Sequence[Relay], schedule: Schedule) -> None:
    text = schedule_to_bytes(schedule).decode("ascii")
    sha = schedule_digest(text)
    for relay in relays:
        assert relay.client is not None
        for _attempt in range(3):
            try:
                # 3 s without a heartbeat before a relay lets go: the machine is shared, and
                # a relay process starved for half a second must not end the measurement.
                reply = relay.client.upload(text, sha, watchdog_ms=3000)
            except NetworkError as exc:
                if "does not hold" not in str(exc):
                    raise
                print(f"   ({exc}; its log: {released(relay)}; claiming it again)")
                claim(relay.client.session, relay, sync=relay.tracker is not None)
                continue
            if reply["preflight_ok"]:
                break
            # A simulator starved past the pre-flight's 0.5 s reply time: not what is measured.
            print(f"   (relay {relay.name}: pre-flight failed, again: {reply['preflight']})")
        else:
            raise SystemExit(f"relay {relay.name}: no upload in 3 attempts")
        relay.sha = sha


def lead(relays: Sequence[Relay]) -> float:
    """Seconds from the first start command to the start: enough for one command per relay."""
    return LEAD + 0.15 * len(relays)


def start(relays: Sequence[Relay], *, naive: bool) -> float:
    """Start every relay's uploaded show; return the intended start (monotonic time)."""
    start_at = time.monotonic() + lead(relays)
    for relay in relays:
        assert relay.client is not None
        if naive:
            relay.client.request("start", sha256=relay.sha, start_in=lead(relays), offset=0.0)
        else:
            relay.client.request("start", sha256=relay.sha, start_at=start_at, offset=0.0)
    return start_at


def released(relay: Relay) -> list[dict[str, object]]:
    """The relay's run-log records about losing its holder."""
    if relay.log is None:
        return []
    out = []
    for line in relay.log.read_text(encoding="utf-8").splitlines():
        rec = json.loads(line)
        if rec.get("event") in ("hello", "release", "link_lost"):
            out.append(rec)
    return out[-4:]


def wait_ended(relays: Sequence[Relay], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    for relay in relays:
        assert relay.client is not None
        while relay.client.command("heartbeat")["show"]["state"] not in ("ended", "idle"):
            if time.monotonic() > deadline:
                raise SystemExit(f"relay {relay.name}: the show did not end")
            time.sleep(0.05)


# ---------------------------------------------------------------------------- figures


def stats(values_ms: Sequence[float]) -> str:
    """p50/p99/p99.9/max of values in ms."""
    if not values_ms:
        return "(no data)"
    v = sorted(values_ms)
    return (
        f"p50 {percentile(v, 0.50):7.3f}  p99 {percentile(v, 0.99):7.3f}  "
        f"p99.9 {percentile(v, 0.999):7.3f}  max {v[-1]:7.3f}  (n={len(v)})"
    )


@dataclass(frozen=True)
class Run:
    """One show on every relay: from when the commands went out to when it had ended."""

    mode: str
    sent: float
    ended: float
    start_at: float | None  # the intended start (synced runs)
    # robot -> (planned, actual) time of its first frame's write, on this machine's clock
    writes: dict[str, tuple[float, float]] = field(default_factory=dict)
    load: float = 0.0  # the 1-minute load average when it started
    load_end: float = 0.0  # and when it had ended
    # robot -> (planned, actual) write time of every scheduled frame, in order: on this
    # machine's clock (local processes) or on the relay's show clock, which reads the
    # conductor's time, this machine's clock here, to within its estimate's error (part (a))
    frames: dict[str, list[tuple[float, float]]] = field(default_factory=dict)

    def lates(self) -> list[float]:
        """Every frame's write - planned time (s)."""
        return [a - p for rows in self.frames.values() for p, a in rows]


def received_in(sim: Sim, run: Run) -> list[float]:
    """Receive times of the frames ``sim`` got during ``run``."""
    return [t for t, _ in sim.frames() if run.sent <= t < run.ended]


def skew(relays: Sequence[Relay], run: Run, index: int) -> float | None:
    """Spread (ms) of the ``index``-th frame's receive time across the robots (None: missing)."""
    times = []
    for relay in relays:
        got = received_in(relay.sim, run)
        if not got or index >= len(got) or -index > len(got):
            return None
        times.append(got[index])
    return (max(times) - min(times)) * 1000


def log_frames(relay: Relay) -> dict[float, list[tuple[float, float]]]:
    """start time -> every scheduled frame's (planned, actual) write time in that show, from
    the relay's run log (show times: seconds from the start, on its show clock)."""
    assert relay.log is not None
    out: dict[float, list[tuple[float, float]]] = {}
    current: list[tuple[float, float]] | None = None
    for line in relay.log.read_text(encoding="utf-8").splitlines():
        rec = json.loads(line)
        if rec.get("event") == "start":
            current = out.setdefault(round(float(rec["start_at"]) - float(rec["offset"]), 6), [])
        elif (
            rec.get("kind") == "frame"
            and rec.get("send") == "frame"
            and rec.get("planned") is not None
            and current is not None
        ):
            current.append((float(rec["planned"]), float(rec["actual"])))
    return out


def first_frames(relay: Relay) -> dict[float, tuple[float, float]]:
    """start time -> (planned, actual) time of that show's first frame on this machine's
    clock, from the relay's run log (its ``first_frame`` records, ``XGO_SHOW_TEST_TRACE``)."""
    assert relay.log is not None
    out: dict[float, tuple[float, float]] = {}
    for line in relay.log.read_text(encoding="utf-8").splitlines():
        rec = json.loads(line)
        if rec.get("event") == "first_frame":
            out[round(float(rec["start_at"]), 6)] = (
                float(rec["planned_host"]),
                float(rec["actual_host"]),
            )
    return out


def after_writes(relay: Relay, since: float, until: float) -> list[float]:
    """The writer thread's work after each write (ms), until the tracer saw the frame: its
    CPU hand-off and the listeners before the tracer (the run log, the event collector), for
    every show that started between ``since`` and ``until`` (``frames_host`` records)."""
    assert relay.log is not None
    out = []
    for line in relay.log.read_text(encoding="utf-8").splitlines():
        rec = json.loads(line)
        if rec.get("event") == "frames_host" and since <= rec["start_host"] <= until:
            out += [(row[3] - row[2]) * 1000 for rows in rec["frames"].values() for row in rows]
    return out


#: the parts of a robot's first-frame receive time against the intended start
PARTS = (
    ("clock", "(a) planned - start: the relay's clock estimate's error"),
    ("late", "(b) write - planned: issue lateness (wake-up, GIL, CPU)"),
    ("delivery", "(c) receive - write: the pseudo-terminal and the simulator"),
    ("total", "receive - start"),
)


def parts(robots: Sequence[Relay], runs: Sequence[Run]) -> dict[str, tuple[list[float], ...]]:
    """Where the start skew comes from, over ``runs`` (ms): for each part of :data:`PARTS`,
    every robot's value and, per start, the spread of the values across the robots."""
    values: dict[str, list[float]] = {k: [] for k, _ in PARTS}
    spreads: dict[str, list[float]] = {k: [] for k, _ in PARTS}
    for run in runs:
        assert run.start_at is not None
        got = {r.name: received_in(r.sim, run) for r in robots}
        if any(not got[r.name] or r.name not in run.writes for r in robots):
            continue
        rows = {k: [] for k, _ in PARTS}
        for r in robots:
            planned, actual = run.writes[r.name]
            rows["clock"].append((planned - run.start_at) * 1000)
            rows["late"].append((actual - planned) * 1000)
            rows["delivery"].append((got[r.name][0] - actual) * 1000)
            rows["total"].append((got[r.name][0] - run.start_at) * 1000)
        for k, row in rows.items():
            values[k] += row
            spreads[k].append(max(row) - min(row))
    return {k: (values[k], spreads[k]) for k, _ in PARTS}


def print_parts(label: str, robots: Sequence[Relay], runs: Sequence[Run]) -> None:
    print(f"   {label}")
    for k, (every, spread) in parts(robots, runs).items():
        what = dict(PARTS)[k]
        print(f"     {what:58s} {stats(every)}")
        print(f"     {'  its spread across the robots, per start':58s} {stats(spread)}")


#: seconds at the end of a long show whose every frame the drift figures split into parts
DRIFT_WINDOW = 10.0


def host_frames(relay: Relay, run: Run) -> dict[int, tuple[float, float]]:
    """schedule index -> (planned, actual) write time on this machine's clock of every
    scheduled frame of ``run``: the relay's ``frames_host`` record (``XGO_SHOW_TEST_TRACE``),
    or a local process's robot's writes (no log: its process sent them back, :class:`Run`)."""
    if relay.log is None:
        assert run.start_at is not None
        rows = run.frames.get(relay.name, [])
        return {round((p - run.start_at) * RATE): (p, a) for p, a in rows}
    for line in relay.log.read_text(encoding="utf-8").splitlines():
        rec = json.loads(line)
        if rec.get("event") == "frames_host" and run.sent <= rec["start_host"] <= run.ended:
            rows = rec["frames"].get("bot", [])
            return {int(row[0]): (float(row[1]), float(row[2])) for row in rows}
    return {}


def scheduled_received(sim: Sim, run: Run, schedule: Schedule) -> dict[int, float]:
    """schedule index -> receive time of the frames ``sim`` got during ``run``, matched in
    order by their bytes (stop and rest frames the show ends with are not the schedule's)."""
    want = [f.data.hex() for f in schedule.performers[0].frames]
    out: dict[int, float] = {}
    k = 0
    for t, data in sim.frames():
        if not run.sent <= t < run.ended:
            continue
        j = k
        while j < len(want) and want[j] != data and j < k + 3:
            j += 1  # a frame lost on the way is skipped, not matched to a later one's bytes
        if j < len(want) and want[j] == data:
            out[j] = t
            k = j + 1
    return out


def drift_rows(
    robots: Sequence[Relay], run: Run, window: float, schedule: Schedule
) -> dict[str, list[float]] | None:
    """Every frame of the last ``window`` seconds of a long show: its skew (the spread of
    its receive time across the robots) and the spread of each part, (a) where each robot's
    clock put the frame, (b) issue lateness, (c) delivery (ms; None: a relay left no
    ``frames_host`` record); and, for synced relays, each one's planned time against the
    true one (``error``)."""
    traced = [host_frames(r, run) for r in robots]
    got = [scheduled_received(r.sim, run, schedule) for r in robots]
    n = len(schedule.performers[0].frames)
    if not all(traced):
        return None
    first = max(0, n - round(window * RATE))
    rows: dict[str, list[float]] = {k: [] for k in (*dict(PARTS), "error")}
    for k in range(first, n):
        if any(k not in t for t in traced) or any(k not in g for g in got):
            continue
        planned = [t[k][0] for t in traced]
        late = [(t[k][1] - t[k][0]) * 1000 for t in traced]
        delivery = [(g[k] - t[k][1]) * 1000 for g, t in zip(got, traced, strict=True)]
        recv = [g[k] for g in got]
        rows["clock"].append((max(planned) - min(planned)) * 1000)
        rows["late"].append(max(late) - min(late))
        rows["delivery"].append(max(delivery) - min(delivery))
        rows["total"].append((max(recv) - min(recv)) * 1000)
        if run.start_at is not None and robots[0].log is not None:  # relays' own clocks
            rows["error"] += [abs(p - run.start_at - k / RATE) * 1000 for p in planned]
    return rows


#: the drift table's rows, in print order
DRIFT_PARTS = (
    ("total", "skew: spread of the receive time"),
    ("clock", "(a) spread of the planned write time"),
    ("error", "(a) each relay: abs(planned - true)"),
    ("late", "(b) spread of the issue lateness"),
    ("delivery", "(c) spread of the delivery"),
)


def report_drift(
    args: argparse.Namespace,
    runs: Sequence[Run],
    robots_of: dict[str, list[Relay]],
    schedule: Schedule,
) -> None:
    """Part 2: the first and the last frame's skew of each long show, and one table of every
    frame of its last :data:`DRIFT_WINDOW` seconds, split into parts, with the load average
    at the show's start and end beside each row."""
    n = len(schedule.performers[0].frames)
    print(
        f"\n2. skew after {args.drift_seconds:g} s of show: spread of the first and of the last "
        "scheduled frame's receive time across the robots (ms)"
    )
    seen: dict[str, int] = {}
    labels = []
    for r in runs:
        seen[r.mode] = seen.get(r.mode, 0) + 1
        many = sum(x.mode == r.mode for x in runs) > 1
        labels.append(r.mode[6:] + (f" #{seen[r.mode]}" if many else ""))
    for label, r in zip(labels, runs, strict=True):
        got = [scheduled_received(x.sim, r, schedule) for x in robots_of[r.mode]]
        ends = []
        for k in (0, n - 1):
            times = [g[k] for g in got if k in g]
            ends.append((max(times) - min(times)) * 1000 if len(times) == len(got) else 0.0)
        print(
            f"   {label:34s} first {ends[0]:8.3f}   last {ends[1]:8.3f}   "
            f"(load average {r.load:.2f}-{r.load_end:.2f})"
        )
    window = min(DRIFT_WINDOW, args.drift_seconds / 2)
    print(
        f"   every frame of the last {window:g} s ({round(window * RATE)} frames a show): "
        "its skew and the spread of each part across the robots (ms)"
    )
    print("   | show | what | p50 | p99 | p99.9 | max | n | load average |")
    print("   | --- | --- | --- | --- | --- | --- | --- | --- |")
    for label, r in zip(labels, runs, strict=True):
        rows = drift_rows(robots_of[r.mode], r, window, schedule)
        if rows is None:
            print(f"   | {label} | (no frames_host record: not split) | | | | | | |")
            continue
        for key, what in DRIFT_PARTS:
            v = sorted(rows[key])
            if not v:
                continue
            figures = " | ".join(
                f"{x:.3f}" for x in (percentile(v, 0.5), percentile(v, 0.99),
                                     percentile(v, 0.999), v[-1])
            )
            print(
                f"   | {label} | {what} | {figures} | {len(v)} | {r.load:.2f}-{r.load_end:.2f} |"
            )
    print(
        f"   issue lateness (b) over the whole {args.drift_seconds:g} s: its spread across the "
        "robots per frame (ms), and the frames it put 0.4 ms or more apart"
    )
    for label, r in zip(labels, runs, strict=True):
        rows = drift_rows(robots_of[r.mode], r, args.drift_seconds, schedule)
        if rows is not None:
            late = rows["late"]
            apart = sum(x >= 0.4 for x in late)
            print(f"   {label:34s} {stats(late)}  {apart:4d} >= 0.4 ms")


def send_errors(relays: Sequence[Relay], run: Run, schedule: Schedule) -> list[float]:
    """Receive time - planned time (ms) of every frame of a synced run, every robot."""
    assert run.start_at is not None
    planned = [run.start_at + f.t for f in schedule.performers[0].frames]
    out = []
    for relay in relays:
        got = received_in(relay.sim, run)
        out += [(t - p) * 1000 for t, p in zip(got, planned, strict=False)]
    return out


def play(relays: Sequence[Relay], schedule: Schedule, mode: str) -> Run:
    """Upload ``schedule`` to every relay and play it; a ``mode`` ending in ``naive`` starts
    each relay when its command arrives, any other at one start time."""
    upload(relays, schedule)
    load = os.getloadavg()[0]
    sent = time.monotonic()
    naive = mode.endswith("naive")
    try:
        start_at = start(relays, naive=naive)
    except NetworkError as exc:  # counted as a failed start, not measured
        print(f"   ({mode}: {exc}; every relay stopped, start not counted)")
        for relay in relays:
            assert relay.client is not None
            try:
                relay.client.command("stop", reason="benchmark: a start failed")
            except NetworkError as why:  # it let us go: say why (its log), claim it again
                print(f"   ({why}; its log: {released(relay)})")
                claim(relay.client.session, relay)
        wait_ended(relays, 10)
        return Run("failed", sent, time.monotonic(), None, load=load)
    wait_ended(relays, lead(relays) + schedule.duration + 10)
    ended = time.monotonic()
    start_time = None if naive else start_at
    return Run(mode, sent, ended, start_time, load=load, load_end=os.getloadavg()[0])


# ---------------------------------------------------------------------------- phases


def phase_main(tmp: Path, args: argparse.Namespace, rng: random.Random) -> None:
    rig = Rig(tmp / "main")
    rig.tmp.mkdir()
    short, long = make_schedule(SHORT), make_schedule(args.drift_seconds)
    runs: list[Run] = []
    rates: list[str] = []
    n = args.relays
    trace = {TRACE_ENV: "1"}
    try:
        # The baselines, started in turn with the relays so that every column sees the same
        # load: N robots driven by one process, and N processes driving one robot each (the
        # relays' shape without Zenoh and without a clock to estimate).
        locals_: dict[str, list[LocalProcess]] = {
            "local, one process": [start_local(rig, [f"one{i}" for i in range(n)], rt=True)],
            f"local, {n} processes": [start_local(rig, [f"each{i}"], rt=True) for i in range(n)],
            WAKE: [start_waker(rig, f"wake{i}") for i in range(n)],
        }
        relays = start_relays(rig, n, rng, prefix="stage", env=trace)
        plain: list[Relay] = []
        if args.no_realtime_too:
            locals_["local, one process --no-realtime"] = [
                start_local(rig, [f"nort{i}" for i in range(n)], rt=False)
            ]
            plain = start_relays(
                rig, n, rng, prefix="plain", env=trace, flags=GROUPS[" --no-realtime"]
            )
        # --trace-ab: relays without the tracer (XGO_SHOW_TEST_TRACE), in turn with the
        # traced ones: what the instrument itself costs a relayed robot
        quiet = start_relays(rig, n, rng, prefix="quiet") if args.trace_ab else []
        # --before REV: relays running REV's xgo_show (traced too), in turn with these
        before: list[Relay] = []
        if args.before:
            old = {**trace, "PYTHONPATH": str(extract(args.before, tmp / "before"))}
            before = start_relays(rig, n, rng, prefix="before", env=old)
        session = connect([*relays, *plain, *quiet, *before])
        for relay in [*relays, *plain, *quiet, *before]:
            claim(session, relay)
        groups = {
            "": relays,
            " --no-realtime": plain,
            " untraced": quiet,
            f" {args.before}": before,
        }
        groups = {k: v for k, v in groups.items() if v}
        for _ in range(args.starts):
            runs.append(play(relays, short, "start synced"))
            for mode, procs in locals_.items():
                runs.append(play_local(procs, mode, lead(relays)))
            for group, members in groups.items():
                if group:
                    runs.append(play(members, short, f"start synced{group}"))
            if not args.no_naive:
                runs.append(play(relays, short, "start naive"))
        if args.starts > 0:
            report_starts(args, runs, groups, locals_, short)
        # the drift show's groups of robots, by mode: the relays three ways, and the same
        # show on the start's local processes (their own simulators), played in turn
        drifting: dict[str, list[Relay]] = {
            "drift synced --no-realtime": plain,
            "drift synced": relays,
            f"drift synced {args.before}": before,
            **{
                f"drift {mode}": [r for p in procs for r in p.robots]
                for mode, procs in locals_.items()
                if mode != WAKE and (args.drift_one_process or "one process" not in mode)
            },
        }
        drifting = {k: v for k, v in drifting.items() if v}
        for _ in range(args.drift_rounds if args.drift_seconds > 0 else 0):
            for mode in drifting:
                if mode.startswith("drift synced"):
                    runs.append(play(drifting[mode], long, mode))
                else:
                    procs = locals_[mode[6:]]
                    runs.append(play_local(procs, mode, lead(relays), args.drift_seconds))
            for relay in relays:
                assert relay.client is not None and relay.tracker is not None
                tb = relay.tracker.timebase
                assert tb is not None
                rates.append(
                    f"{relay.name}: {relay.ppm:+8.3f} ppm set, {tb.rate * 1e6:+8.3f} "
                    f"+- {tb.rate_bound * 1e6:.3f} ppm estimated, offset bound "
                    f"{tb.bound * 1e3:.3f} ms"
                )
        if args.drift_seconds > 0 and not args.no_naive:
            for relay in relays:
                # offset only: one burst (rate unknown, taken as 0), then no tracking
                relay.sync(session, track=False)
            runs.append(play(relays, long, "drift offset only"))
            for relay in relays:  # a naive relay runs on its own, uncorrected clock
                assert relay.client is not None
                relay.client.stop_heartbeat()
                relay.client.command("release")
                claim(session, relay, sync=False)
            runs.append(play(relays, long, "drift naive"))
            drifting |= {"drift offset only": relays, "drift naive": relays}
    finally:
        rig.close()
    if args.drift_seconds > 0:
        report_drift(args, [r for r in runs if r.mode in drifting], drifting, long)
        print("   the clock tracker's drift estimates at the end of each synced show:")
        for line in rates:
            print(f"     {line}")


def report_starts(
    args: argparse.Namespace,
    runs: Sequence[Run],
    groups: dict[str, Sequence[Relay]],
    locals_: dict[str, list[LocalProcess]],
    short: Schedule,
) -> None:
    """Parts 1 and 3: the start skew and its parts, the send-time error (printed while the
    processes still run: their records are flushed as they go). ``groups``: the relays by
    the suffix of their runs' mode ("" the default ones)."""
    relays = groups[""]
    n = len(relays)
    every_relay = [r for members in groups.values() for r in members]
    logged = {relay.name: first_frames(relay) for relay in every_relay}
    frames = {relay.name: log_frames(relay) for relay in every_relay}
    for run in runs:
        if run.start_at is not None and run.mode.startswith("start synced"):
            for name, writes in logged.items():
                if (t := writes.get(round(run.start_at, 6))) is not None:
                    run.writes[name] = t
            for name, shows in frames.items():
                if (rows := shows.get(round(run.start_at, 6))) is not None:
                    # show times (offset 0) on the show clock that started at start_at
                    run.frames[name] = [(run.start_at + p, run.start_at + a) for p, a in rows]
    loads = [r.load for r in runs if r.mode.startswith("start")]
    print(
        f"\n{n} relays, clocks off by up to +-100 s and +-100 ppm "
        f"({', '.join(f'{r.offset:+.1f} s {r.ppm:+.0f} ppm' for r in relays)}); "
        f"load average (1 min) during the starts {min(loads):.2f}-{max(loads):.2f}"
    )
    print(f"\n1. start skew: spread of the first frame across the robots, {args.starts} starts, ms")
    for mode in [f"synced{g}" for g in groups] + ([] if args.no_naive else ["naive"]):
        group = groups[mode[6:]] if mode.startswith("synced") else relays
        values = [skew(group, r, 0) for r in runs if r.mode == f"start {mode}"]
        print(f"   {'relayed, ' + mode:34s} {stats([v for v in values if v is not None])}")
    local_robots = {
        mode: [r for p in procs for r in p.robots]
        for mode, procs in locals_.items()
        if mode != WAKE
    }
    for mode, robots in local_robots.items():
        values = [skew(robots, r, 0) for r in runs if r.mode == mode]
        print(f"   {mode:34s} {stats([v for v in values if v is not None])}")
    late, spread = wake_spreads([r for r in runs if r.mode == WAKE])
    print(f"   {WAKE + f' of {n} processes':34s} {stats(spread)}")
    print(f"     (their lateness: {stats(late)})")
    print("     (the floor: a SCHED_FIFO thread in each of N processes, woken at the start)")
    print("   its parts (ms): every robot's value, and the spread of each part across the robots")
    for group, members in groups.items():
        started = [r for r in runs if r.mode == f"start synced{group}"]
        print_parts(f"relayed{group}", members, started)
    for mode, robots in local_robots.items():
        print_parts(mode, robots, [r for r in runs if r.mode == mode])
    print("\n3. send-time error at the robot: receive time - planned time (ms)")
    for group, members in groups.items():
        relayed = [e for r in runs if r.mode == f"start synced{group}"
                   for e in send_errors(members, r, short)]
        print(f"   {'relayed' + group:34s} {stats(relayed)}")
    for mode, robots in local_robots.items():
        errors = [e for r in runs if r.mode == mode for e in send_errors(robots, r, short)]
        print(f"   {mode:34s} {stats(errors)}")
    print("   its relay's writer thread after each write, until the tracer: hand-off, listeners")
    for group, members in groups.items():
        started = [r for r in runs if r.mode == f"start synced{group}"]
        busy = [
            x for relay in members for r in started
            for x in after_writes(relay, r.sent, r.ended)
        ]
        print(f"   {'relayed' + group:34s} {stats(busy)}")
    print("   its issue lateness: write - planned time of every frame (ms)")
    for group in groups:
        late = [x * 1000 for r in runs if r.mode == f"start synced{group}" for x in r.lates()]
        print(f"   {'relayed' + group:34s} {stats(late)}")
    for mode in local_robots:
        late = [x * 1000 for r in runs if r.mode == mode for x in r.lates()]
        print(f"   {mode:34s} {stats(late)}")
    print_per_frame(runs, groups, local_robots, short)


def deliveries(robots: Sequence[Relay], run: Run, frames: slice = slice(None)) -> list[float]:
    """Receive time - write time (ms) of every scheduled frame of ``run`` (or of the
    ``frames`` of each show), every robot."""
    out = []
    for robot in robots:
        rows = run.frames.get(robot.name, [])
        got = received_in(robot.sim, run)
        pairs = list(zip(got, rows, strict=False))[frames]
        out += [(t - actual) * 1000 for t, (_, actual) in pairs]
    return out


def extract(rev: str, into: Path) -> Path:
    """``rev``'s xgo_show package under ``into`` (for PYTHONPATH)."""
    import tarfile

    into.mkdir()
    archive = into / "src.tar"
    repo = Path(__file__).resolve().parent.parent
    with archive.open("wb") as fh:
        subprocess.run(["git", "-C", str(repo), "archive", rev, "xgo_show"], stdout=fh, check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(into, filter="data")
    return into


PerRun = list[list[float]]  # per run (in the order played), its per-frame values (ms)


def bootstrap_p50_difference(
    a: PerRun, b: PerRun, *, resamples: int = 2000, seed: int = 1
) -> tuple[float, float, float]:
    """Pooled p50 of ``b`` minus that of ``a`` and its 95 % bootstrap interval, resampling
    the pairs of runs (``a[k]`` and ``b[k]`` played one after the other), not the frames:
    frames of one run share its load (as ``benchmarks/trigger_latency.py`` does for p99)."""

    def p50(runs: PerRun) -> float:
        return percentile(sorted(x for run in runs for x in run), 0.5)

    rng = random.Random(seed)
    k = min(len(a), len(b))
    diffs = []
    for _ in range(resamples):
        picked = [rng.randrange(k) for _ in range(k)]
        diffs.append(p50([b[i] for i in picked]) - p50([a[i] for i in picked]))
    diffs.sort()
    return p50(b[:k]) - p50(a[:k]), percentile(diffs, 0.025), percentile(diffs, 0.975)


def print_per_frame(
    runs: Sequence[Run],
    groups: dict[str, Sequence[Relay]],
    local_robots: dict[str, list[Relay]],
    short: Schedule,
) -> None:
    """Every frame's delivery (receive - write) and, run pair by run pair, what a relayed
    robot adds over the local processes (and the tracer over untraced relays)."""
    robots_of = {f"start synced{g}": list(m) for g, m in groups.items()} | local_robots
    measures = {
        "send-time error": lambda robots, run: send_errors(robots, run, short),
        "delivery": deliveries,
        "issue lateness": lambda robots, run: [x * 1000 for x in run.lates()],
    }
    per_run: dict[str, dict[str, PerRun]] = {}
    for mode, robots in robots_of.items():
        mine = [r for r in runs if r.mode == mode]
        per_run[mode] = {m: [f(robots, r) for r in mine] for m, f in measures.items()}
    print("   delivery: receive - write time of every frame (ms; a relay's write time is on its")
    print("   show clock, the conductor's: this machine's to within its estimate's error (a))")
    for mode in robots_of:
        name = mode.replace("start synced", "relayed")
        print(f"   {name:34s} {stats([x for run in per_run[mode]['delivery'] for x in run])}")
        mine = [r for r in runs if r.mode == mode]
        firsts = [x for r in mine for x in deliveries(robots_of[mode], r, slice(0, 1))]
        rest = [x for r in mine for x in deliveries(robots_of[mode], r, slice(1, None))]
        print(f"     {'its first frames':32s} {stats(firsts)}")
        print(f"     {'the others':32s} {stats(rest)}")
    local = next((m for m in local_robots if m.endswith("processes")), None)
    pairs: list[tuple[str, str]] = [(local, f"start synced{g}") for g in groups if local]
    pairs += [(f"start synced{g}", "start synced") for g in groups if g and g[1:] not in (
        "--no-realtime",
    )]
    print("   p50 differences, 95 % bootstrap interval resampling the start rounds (ms):")
    for a, b in pairs:
        for m in measures:
            est, lo, hi = bootstrap_p50_difference(per_run[a][m], per_run[b][m])
            what = " - ".join(x.replace("start synced", "relayed") for x in (b, a))
            print(f"     {m:16s} {what:44s} {est:+7.3f} [{lo:+7.3f}, {hi:+7.3f}]")


@dataclass
class LocalProcess:
    """A process (this script with ``--local-child``) that plays the short show on its own
    robots with a local runner: no Zenoh, no clock to estimate, the floor a relay is compared
    with. It reads start times (this machine's clock) on stdin and answers each with its
    robots' first writes."""

    proc: subprocess.Popen[str]
    robots: list[Relay]  # stand-ins holding the simulators, for skew() and parts()

    def start(self, start_at: float, seconds: float = SHORT) -> None:
        """Play a show of ``seconds`` (:func:`make_schedule`) from ``start_at``."""
        assert self.proc.stdin is not None
        self.proc.stdin.write(f"{start_at!r} {seconds!r}\n")
        self.proc.stdin.flush()

    def writes(self) -> tuple[dict[str, tuple[float, float]], dict[str, list[tuple[float, float]]]]:
        """Each robot's first (planned, actual) write, and every frame's."""
        assert self.proc.stdout is not None
        reply = json.loads(self.proc.stdout.readline())
        if not reply["completed"]:
            raise SystemExit(f"a local run did not complete: {reply['reason']}")
        firsts = {name: (float(p), float(a)) for name, (p, a) in reply["writes"].items()}
        rows = reply.get("frames", {})  # (a wake-up process has none)
        every = {name: [(float(p), float(a)) for p, a in r] for name, r in rows.items()}
        return firsts, every


def start_local(rig: Rig, names: Sequence[str], *, rt: bool) -> LocalProcess:
    """A :class:`LocalProcess` for robots ``names`` (a simulator each), writers under
    SCHED_FIFO with ``rt`` (``run``'s default), else at normal priority."""
    sims = [start_sim(rig.tmp, name) for name in names]
    rig.sims += sims
    pairs = [f"{n}={s.path}" for n, s in zip(names, sims, strict=True)]
    proc = subprocess.Popen(
        [sys.executable, __file__, "--local-child", *pairs, *([] if rt else ["--no-realtime"])],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    if proc.stdout.readline().strip() != "ready":
        raise SystemExit("a local process did not start")
    rig.locals.append(proc)
    robots = [Relay(n, 0, proc, s, 0.0, 0.0) for n, s in zip(names, sims, strict=True)]
    return LocalProcess(proc, robots)


def play_local(
    procs: Sequence[LocalProcess], mode: str, lead_s: float, seconds: float = SHORT
) -> Run:
    """The show of ``seconds`` on every local process, all at one start ``lead_s`` from now."""
    load = os.getloadavg()[0]
    sent = time.monotonic()
    start_at = sent + lead_s
    for proc in procs:
        proc.start(start_at, seconds)
    writes: dict[str, tuple[float, float]] = {}
    frames: dict[str, list[tuple[float, float]]] = {}
    for proc in procs:
        firsts, every = proc.writes()
        writes.update(firsts)
        frames.update(every)
    ended = time.monotonic()
    return Run(mode, sent, ended, start_at, writes, load, os.getloadavg()[0], frames)


def start_waker(rig: Rig, name: str) -> LocalProcess:
    """A process whose one SCHED_FIFO thread only sleeps to each start and notes when it woke
    (``--wake-child``): the floor of N processes woken at one instant on this machine, with
    neither a show, a port nor a robot."""
    proc = subprocess.Popen(
        [sys.executable, __file__, "--wake-child", name],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    if proc.stdout.readline().strip() != "ready":
        raise SystemExit("a wake-up process did not start")
    rig.locals.append(proc)
    return LocalProcess(proc, [])


def wake_child(name: str) -> int:
    """``--wake-child NAME``: see :func:`start_waker`."""
    realtime.configure("required")
    tighten_timer_slack()
    enter_show_thread()  # as a writer thread does
    clock = MonotonicClock()
    print("ready", flush=True)
    for line in sys.stdin:
        start_at = float(line.split()[0])
        clock.sleep_until(start_at)
        woke = clock.now()
        hand_off_cpu()  # as a writer does after its write
        reply = {"completed": True, "reason": "", "writes": {name: [start_at, woke]}}
        print(json.dumps(reply), flush=True)
    return 0


def wake_spreads(runs: Sequence[Run]) -> tuple[list[float], list[float]]:
    """Every waker's lateness and, per start, their spread (ms)."""
    late: list[float] = []
    spread: list[float] = []
    for run in runs:
        row = [(woke - planned) * 1000 for planned, woke in run.writes.values()]
        late += row
        spread.append(max(row) - min(row))
    return late, spread


def local_child(pairs: Sequence[str], rt: bool) -> int:
    """``--local-child NAME=PTY...``: see :class:`LocalProcess`."""
    names = [p.partition("=")[0] for p in pairs]
    schedules = {SHORT: make_schedule(SHORT, names)}  # by length: the starts', the drift show's
    links = {
        n: open_transport(p.partition("=")[2], baudrate=schedules[SHORT].performers[0].link.baud)
        for n, p in zip(names, pairs, strict=True)
    }
    realtime.configure("required" if rt else "off")  # as run does: writers raise themselves
    for link in links.values():
        link.open()
    print("ready", flush=True)
    try:
        for line in sys.stdin:
            start_at, seconds = (float(x) for x in line.split())
            if seconds not in schedules:
                schedules[seconds] = make_schedule(seconds, names)
            schedule = schedules[seconds]
            bus = EventBus()
            recorder = EventRecorder(bus, FrameSent)
            runner = local_runner(
                schedule, links, clock=MonotonicClock(), events=bus, telemetry=False
            )
            result = runner.run(start_at=start_at, lead=0.0, handle_signals=False)
            writes: dict[str, tuple[float, float]] = {}
            frames: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
            for ev in recorder.sent():
                if ev.kind == "frame" and ev.planned is not None:
                    frames[ev.performer].append((ev.planned, ev.t))
                    writes.setdefault(ev.performer, (ev.planned, ev.t))
            recorder.close()
            reply = {
                "completed": result.completed,
                "reason": result.reason,
                "writes": writes,
                "frames": frames,
            }
            print(json.dumps(reply), flush=True)
    finally:
        for link in links.values():
            link.close()
    return 0


def phase_delay(tmp: Path, args: argparse.Namespace, rng: random.Random) -> None:
    """Relays whose time-sync replies are held back 5 ms +- 2 ms (one way, so asymmetric)."""
    rig = Rig(tmp / "delay")
    rig.tmp.mkdir()
    short = make_schedule(SHORT)
    runs: list[Run] = []
    errors: list[float] = []
    bounds: list[float] = []
    inside = 0
    try:
        env = {DELAY_ENV: "mean=0.005,jitter=0.002"}
        # ppm 0: the true offset is then the configured one at any time
        relays = start_relays(rig, args.relays, rng, prefix="slow", env=env, ppm=False)
        session = connect(relays)
        for relay in relays:
            claim(session, relay)
        for _ in range(args.estimates):
            for relay in relays:
                key = relay_key("xgo-show", relay.name, "time")
                est = measure(session, key, n=25)  # type: ignore[arg-type]
                error = est.offset - relay.offset
                errors.append(abs(error) * 1000)
                bounds.append(est.bound * 1000)
                inside += abs(error) <= est.bound
        for _ in range(max(1, args.starts // 2)):
            runs.append(play(relays, short, "start synced"))
    finally:
        rig.close()
    print("\n4. time-sync replies delayed 5 ms +- 2 ms (one way) on every relay")
    print(f"   |estimator error| {stats(errors)}")
    print(f"   reported bound    {stats(bounds)}")
    print(f"   error within the bound: {inside} of {len(errors)}")
    values = [skew(relays, r, 0) for r in runs if r.mode != "failed"]
    print(f"   start skew        {stats([v for v in values if v is not None])}")


def phase_scale(tmp: Path, args: argparse.Namespace, rng: random.Random) -> None:
    """``--scale`` relays on one conductor."""
    rig = Rig(tmp / "scale")
    rig.tmp.mkdir()
    short = make_schedule(SHORT)
    runs: list[Run] = []
    try:
        t0 = time.monotonic()
        relays = start_relays(rig, args.scale, rng, prefix="many")
        spawned = time.monotonic() - t0
        session = connect(relays)
        t0 = time.monotonic()
        for relay in relays:
            claim(session, relay)
        claimed = time.monotonic() - t0
        time.sleep(2.0)
        before = resource.getrusage(resource.RUSAGE_SELF)
        idle = 10.0
        time.sleep(idle)
        after = resource.getrusage(resource.RUSAGE_SELF)
        cpu = (after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime) / idle
        rtts = []
        for _ in range(5):
            for relay in relays:
                assert relay.client is not None
                t = time.monotonic()
                relay.client.command("heartbeat")
                rtts.append((time.monotonic() - t) * 1000)
        t0 = time.monotonic()
        upload(relays, short)
        uploaded = time.monotonic() - t0
        for _ in range(5):
            runs.append(play(relays, short, "start synced"))
    finally:
        rig.close()
    print(f"\n5. {args.scale} relays on one conductor")
    print(
        f"   relay processes ready {spawned:6.2f} s; hello + clock sync + heartbeats for all "
        f"{claimed:6.2f} s; upload + pre-flight to all {uploaded:6.2f} s"
    )
    print(
        f"   conductor CPU while keeping them synced (8 pings/s and 10 heartbeats/s each): "
        f"{cpu * 100:.1f} % of one core"
    )
    print(f"   command round trip {stats(rtts)}")
    values = [skew(relays, r, 0) for r in runs if r.mode != "failed"]
    print(f"   start skew         {stats([v for v in values if v is not None])}")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--relays", type=int, default=4)
    parser.add_argument("--starts", type=int, default=20)
    parser.add_argument("--drift-seconds", type=float, default=60.0)
    parser.add_argument(
        "--estimates", type=int, default=10, help="bursts per delayed relay (0: skip that part)"
    )
    parser.add_argument("--scale", type=int, default=16, help="relays in the scale test (0: skip)")
    parser.add_argument(
        "--drift-rounds",
        type=int,
        default=1,
        help="drift shows synced and on the local processes, in turn, this many times",
    )
    parser.add_argument(
        "--drift-one-process",
        action="store_true",
        help="the drift show on the one local process too (a minute more a round)",
    )
    parser.add_argument(
        "--thread-names",
        action="store_true",
        help="relays note their threads' kernel ids and names (with --keep, for a kernel trace)",
    )
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--keep", type=Path, metavar="DIR", help="keep the records in DIR (a new directory)"
    )
    parser.add_argument(
        "--quick", action="store_true", help="5 starts, 10 s drift, 3 bursts, no scale test"
    )
    parser.add_argument(
        "--sim-realtime",
        action="store_true",
        help="simulators under SCHED_FIFO (chrt): a robot has its own CPU; here they share ours",
    )
    parser.add_argument(
        "--no-realtime-too",
        action="store_true",
        help="also relays and a local runner with --no-realtime (4 more relays, 4 more robots)",
    )
    parser.add_argument(
        "--trace-ab",
        action="store_true",
        help="also relays without the tracer (XGO_SHOW_TEST_TRACE), in turn with the others",
    )
    parser.add_argument(
        "--no-naive",
        action="store_true",
        help="no naive starts, no naive or offset-only drift shows (time)",
    )
    parser.add_argument(
        "--before",
        metavar="REV",
        help="also relays running revision REV's xgo_show, in turn with the others",
    )
    parser.add_argument("--wake-child", metavar="NAME", help=argparse.SUPPRESS)
    parser.add_argument("--local-child", nargs="+", metavar="NAME=PTY", help=argparse.SUPPRESS)
    parser.add_argument("--no-realtime", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.wake_child:
        return wake_child(args.wake_child)
    if args.local_child:
        return local_child(args.local_child, not args.no_realtime)
    if args.sim_realtime:
        SIM_PRIORITY.append(20)
    if args.thread_names:
        THREAD_NAMES.append(True)
    if args.quick:
        args.starts, args.drift_seconds, args.estimates, args.scale = 5, 10.0, 3, 0
    rng = random.Random(args.seed)
    with tempfile.TemporaryDirectory(prefix="relay-sync-") as tmp:
        if args.keep:  # every record (the simulators', the relays' run logs) kept there
            args.keep.mkdir(parents=True)
            tmp = str(args.keep)
        phase_main(Path(tmp), args, rng)
        if args.estimates > 0:
            phase_delay(Path(tmp), args, rng)
        if args.scale > 0:
            phase_scale(Path(tmp), args, rng)
    return 0


if __name__ == "__main__":
    sys.exit(main())
