"""Trigger latency over Zenoh: a client's trigger -> the first frame of the released section at
the robot, and a running show's timing under a flood of triggers.

Every part is its own OS process, as on a stage: ``xgo-show serve`` drives a simulated Mini on
a real pseudo-terminal; the simulator is a process of its own under SCHED_FIFO priority 20
(above the writers' 10: it stands in for a robot's UART, which is never late, so the figures
are the server's and not the instrument's waiting for a CPU) and records every frame's arrival;
the clients that fire the triggers are started from this script (``--client``); one more
process keeps a CPU busy the whole time. Zenoh runs on 127.0.0.1 with multicast scouting off.
All times are CLOCK_MONOTONIC, which every process on the host shares.

1. A show of 200 sections, each waiting for ``go``. Side by side, two clients release them:
   - *push*: subscribes to the ``wait`` events and puts ``NS/trigger/go`` the moment one says
     the show holds;
   - *polling*: asks ``NS/status`` every 20 ms and, when it sees the show holding, fires the
     trigger as a query (the way a client that polls does everything).
   For each: trigger sent -> the section's first scheduled frame at the simulator, and the show
   began holding (its ``wait`` event) -> that frame. Then the push client ``--runs`` times
   more, against a server started with ``--log`` (every run's figures, with the load average,
   and all runs pooled): where the time goes, from the run log's ``trigger`` records (sent ->
   the server's Zenoh callback -> decided (payload read, director released the wait) -> the
   writer thread took the release -> its first write -> the section's first frame written ->
   arrival at the simulator), and the steps of the slowest releases.
2. A 14 s show without waits, played ``--runs`` times alone and as often while a client puts
   1,000 triggers a second nobody waits for, alternately (alone, flood, alone, ...) in one
   server. Send-time error: each frame's arrival at the simulator minus its planned time (the
   start time the ``start`` reply gives, plus the frame's time). Per run and pooled, with the
   load average, the serve process's CPU and the flooding client's own (it shares the machine).
   Then the verdict on "p99 unchanged within 0.1 ms": the pooled p99's difference (flood -
   alone) with a 95 % bootstrap confidence interval (:func:`bootstrap_p99_difference`: the
   run pairs are resampled, not the frames, since frames of one run share its load and its
   stalls), over all frames and again with the frames that overlap a CPU stall the probe saw
   left out (the VM's stalls, not our process's).

Prints figures only (no asserts)::

    python benchmarks/trigger_latency.py [--triggers 200] [--runs 3]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import queue
import random
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zenoh

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.client import ControlClient
from xgo_show.control.keys import event_key, trigger_key
from xgo_show.runtime.runlog import read_log
from xgo_show.runtime.stats import percentile

NS = "bench-triggers"
SIM_FIFO = 20  # the simulator's SCHED_FIFO priority: above the writers' 10
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
    """Put ``rate`` triggers a second nobody waits for, for ``seconds``. At nice 19: it
    stands for senders on other hosts, so its own CPU is not what is measured."""
    os.nice(19)
    with _session(endpoint) as session:
        ControlClient(session, NS).status()
        print("ready", flush=True)
        key, start, sent = trigger_key(NS, "lights"), time.monotonic(), 0
        while (now := time.monotonic()) < start + seconds:
            while sent < int((now - start) * rate):
                session.put(key, b"{}", congestion_control=zenoh.CongestionControl.BLOCK)
                sent += 1
            time.sleep(0.002)
        print(f"flooded {sent} cpu {time.process_time():.3f}", flush=True)


# ---------------------------------------------------------------------- the stall probe

STALL_FIFO = 30  # the probe's SCHED_FIFO priority: above everything of the bench's
STALL_PERIOD = 0.001  # seconds it sleeps between looks at the clock
STALL_MIN = 0.002  # a wake-up this much later than asked is a stall (recorded)


def stall_probe(record: Path) -> None:
    """Child process: one thread per CPU, pinned to it, at SCHED_FIFO :data:`STALL_FIFO`,
    sleeps :data:`STALL_PERIOD` again and again and records each wake-up more than
    :data:`STALL_MIN` late (CPU, from, to). Nothing in this machine's scheduler can keep a
    thread of that priority off its CPU for milliseconds (it outranks every thread of the
    bench, and blocks at once): a stall is the CPU itself not running (the hypervisor, which
    this VM's kernel does not report as steal time) or the kernel not preempting."""
    import threading

    out = record.open("w", encoding="utf-8")
    lock = threading.Lock()

    def watch(cpu: int) -> None:
        os.sched_setaffinity(0, {cpu})
        with contextlib.suppress(OSError):
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(STALL_FIFO))
        last = time.monotonic()
        while True:
            time.sleep(STALL_PERIOD)
            now = time.monotonic()
            if now - last > STALL_PERIOD + STALL_MIN:
                with lock:
                    out.write(f"{cpu} {last + STALL_PERIOD:.6f} {now:.6f}\n")
                    out.flush()
            last = now

    for cpu in sorted(os.sched_getaffinity(0)):
        threading.Thread(target=watch, args=(cpu,), daemon=True).start()
    print("ready", flush=True)
    sys.stdin.read()


def read_stalls(record: Path) -> list[tuple[int, float, float]]:
    """The probe's stalls so far: (CPU, from, to), clock seconds."""
    out = []
    with contextlib.suppress(OSError), record.open(encoding="utf-8") as fh:
        for line in fh:
            cpu, a, b = line.split()
            out.append((int(cpu), float(a), float(b)))
    return out


def stalls_within(stalls: list[tuple[int, float, float]], a: float, b: float) -> str:
    """The stalls overlapping [a, b], as words (empty: none)."""
    hits = [f"CPU{cpu} stalled {(min(y, b) - max(x, a)) * 1000:.2f} ms"
            for cpu, x, y in stalls if x < b and y > a]
    return "; ".join(hits)


# ---------------------------------------------------------------------- the bench


def serve_sim(record: Path) -> None:
    """Child process: a simulated Mini on a pty, every frame recorded, until stdin closes.

    Under SCHED_FIFO (where permitted) its thread runs the moment bytes arrive, so arrival
    times are the link's, not the simulator's wait for a CPU; its thread blocks in poll()
    between frames and takes no CPU from the kernel worker that moves them.
    """
    from xgo_show.sim import PtyServer, create_robot

    priority = "normal-priority"
    with contextlib.suppress(OSError):
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(SIM_FIFO))
        priority = f"SCHED_FIFO-{SIM_FIFO}"
    with PtyServer(create_robot("mini"), record=record) as server:
        print(priority, server.path, flush=True)
        sys.stdin.read()


def _free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


@contextmanager
def _process(*args: str, stdin: bool = False) -> Iterator[subprocess.Popen[str]]:
    proc = subprocess.Popen(list(args), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.PIPE if stdin else None, text=True)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            if stdin and proc.stdin is not None:
                proc.stdin.close()  # the simulator's cue to close (and write its last records)
                proc.stdin = None
            else:
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


class Sim:
    """The simulator process's recorded frames, read back from its record file."""

    def __init__(self, record: Path) -> None:
        self.record = record

    def frames_since(self, t: float) -> list[tuple[float, bytes]]:
        time.sleep(0.2)  # the last frames reach the record file
        out = []
        with self.record.open(encoding="utf-8") as fh:
            for line in fh:
                if line.strip():
                    rec = json.loads(line)
                    if rec["t"] >= t:
                        out.append((float(rec["t"]), bytes.fromhex(rec["hex"])))
        return out


@contextmanager
def serving(sim_path: str, *, log: Path | None = None
            ) -> Iterator[tuple[str, zenoh.Session, int]]:
    """A serve process driving the simulator, and an operator's session on it."""
    endpoint = _free_endpoint()
    with _process(sys.executable, "-m", "xgo_show", "serve", "--map", f"rex={sim_path}",
                  "--no-telemetry", "--listen", endpoint, "--namespace", NS,
                  *(["--log", str(log)] if log is not None else [])) as proc, \
            _session(endpoint) as session:
        deadline = time.monotonic() + 30
        while True:
            try:
                ControlClient(session, NS, timeout=1.0).status()
                break
            except Exception:
                if proc.poll() is not None or time.monotonic() > deadline:
                    proc.terminate()
                    raise SystemExit(f"serve did not answer: {proc.communicate()}") from None
        yield endpoint, session, proc.pid


def cpu_seconds(pid: int) -> float:
    """CPU time (user + system) process ``pid`` has used so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def thread_cpu(pid: int) -> dict[str, float]:
    """CPU seconds per thread name of process ``pid`` (threads of one name summed)."""
    out: dict[str, float] = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(OSError):
            text = (task / "stat").read_text()
            name = text[text.index("(") + 1:text.rindex(")")]
            fields = text.rsplit(")", 1)[1].split()
            cpu = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
            out[name] = out.get(name, 0.0) + cpu
    return out


class Bench:
    """One serve process, the simulator and an operator's session."""

    def __init__(self, sim: Sim, session: zenoh.Session, endpoint: str, pid: int) -> None:
        self.sim = sim
        self.pid = pid  # the serve process
        self.endpoint = endpoint
        self.client = ControlClient(session, NS, timeout=30.0)
        self.session = session
        # wall clock -> monotonic, for the events' and replies' Unix times
        self.wall_offset = time.time() - time.monotonic()

    def wait_until_loaded(self) -> None:
        while self.client.status()["state"] != "loaded":
            time.sleep(0.05)

    def triggered(self, path: Path, schedule: Schedule, mode: str, n: int) -> Released:
        """Each section's release: when its trigger was sent, when the show began holding,
        when the section's first frame arrived."""
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
        frames = self.sim.frames_since(began)
        released = Released()
        for line in out.splitlines():
            if not line.startswith("sent "):
                continue
            _, section, stamp = line.split()
            sent = float(stamp)
            arrived = next((t for t, data in frames if t > sent and data == first[section]),
                           None)
            if arrived is None:
                near = [(round(t - sent, 4), d.hex()) for t, d in frames if abs(t - sent) < 0.3]
                raise SystemExit(f"section {section}'s first frame {first[section].hex()} never "
                                 f"arrived after its trigger; frames around: {near}")
            released.sent[section] = sent
            released.held[section] = waits[section] - self.wall_offset
            released.arrived[section] = arrived
        return released

    def steady(self, path: Path, schedule: Schedule, flood: bool, log: Path) -> Timing:
        """Each frame's send-time error (arrival - planned) and issue lateness (the server's
        write - planned), in seconds, from the simulator's record and the server's run log
        (its start time is on the monotonic clock: no wall-clock conversion)."""
        starts = len([r for r in read_log(log) if r.get("event") == "start"])
        self.client.command("load", path=str(path))
        flooder = _client(self.endpoint, "flood", "--seconds", str(schedule.duration + 2)) \
            if flood else None
        began, cpu = time.monotonic(), cpu_seconds(self.pid)
        threads = thread_cpu(self.pid)
        client_cpu = 0.0
        try:
            self.client.command("start", **{"in": 0.5})
            self.wait_until_loaded()
            took = time.monotonic() - began
            cpu = (cpu_seconds(self.pid) - cpu) / took
            threads = {name: (t - threads.get(name, 0.0)) / took
                       for name, t in thread_cpu(self.pid).items()}
        finally:
            if flooder is not None:
                out, _ = flooder.communicate(timeout=30)
                words = out.split()
                if "cpu" in words:  # its CPU over its whole life: the show's and 2 s more
                    client_cpu = float(words[words.index("cpu") + 1]) / (schedule.duration + 2)
        time.sleep(0.2)  # the log's last records reach its file
        records = read_log(log)
        first = [i for i, r in enumerate(records) if r.get("event") == "start"][starts]
        start = records[first]["start_at"]
        timing = Timing(cpu=cpu, client_cpu=client_cpu, threads=threads)
        written = []
        for r in records[first:]:
            if r["kind"] == "frame" and r["send"] == "frame":
                timing.issue.append(r["actual"] - r["planned"])
                written.append(start + r["actual"])
        planned = [start + f.t for f in schedule.performers[0].frames]
        datas = [f.data for f in schedule.performers[0].frames]
        i = 0
        for t, data in self.sim.frames_since(began):
            if i < len(datas) and data == datas[i]:
                timing.error.append(t - planned[i])
                timing.spans.append((planned[i], t))
                if i < len(written):
                    timing.delivery.append(t - written[i])
                i += 1
        if i != len(datas):
            raise SystemExit(f"only {i} of {len(datas)} frames of the steady show arrived")
        return timing


@dataclass
class Timing:
    """A steady run's send-time errors and the server's issue lateness, seconds per frame."""

    error: list[float] = field(default_factory=list)
    issue: list[float] = field(default_factory=list)
    delivery: list[float] = field(default_factory=list)  # arrival - the server's write
    cpu: float = 0.0  # the serve process's CPU use meanwhile, share of one CPU
    client_cpu: float = 0.0  # the flooding client's, share of one CPU over the show
    spans: list[tuple[float, float]] = field(default_factory=list)  # (planned, arrived)
    threads: dict[str, float] = field(default_factory=dict)  # serve's CPU share per thread

    def busiest(self, k: int = 4) -> str:
        top = sorted(self.threads.items(), key=lambda kv: -kv[1])[:k]
        return ", ".join(f"{name} {share:.1%}" for name, share in top if share > 0)

    def late_in_stalls(self, stalls: list[tuple[int, float, float]],
                       over: float = 0.001) -> str:
        """How many frames arrived more than ``over`` s late, and how many of them while a
        CPU stalled (the probe's record)."""
        late = [(a, b) for a, b in self.spans if b - a > over]
        hit = sum(1 for a, b in late if any(x < b and y > a for _, x, y in stalls))
        return f"{len(late)} frames > {over * 1000:g} ms late, {hit} of them during a CPU stall"


@dataclass
class Released:
    """Clock times per section: trigger sent, show began holding, first frame arrived."""

    sent: dict[str, float] = field(default_factory=dict)
    held: dict[str, float] = field(default_factory=dict)
    arrived: dict[str, float] = field(default_factory=dict)

    def sent_to_frame(self) -> list[float]:
        return [self.arrived[s] - self.sent[s] for s in self.sent]

    def held_to_frame(self) -> list[float]:
        return [self.arrived[s] - self.held[s] for s in self.sent]


def _wait(sample: zenoh.Sample, waits: dict[str, float]) -> None:
    event = json.loads(sample.payload.to_bytes())
    if event["state"] == "waiting":
        waits[event["section"]] = event["time"]


def _frame_at(schedule: Schedule, t: float) -> bytes:
    return next(f.data for f in schedule.performers[0].frames if abs(f.t - t) < 1e-9)


#: The steps of a release, from the run log's ``trigger`` records: (label, from, to).
STEPS = (
    ("sent -> server's Zenoh callback", "sent", "received"),
    ("callback -> payload read", "received", "parsed"),
    ("payload read -> decided (wait released)", "parsed", "decided"),
    ("decided -> writer took the release", "decided", "woke"),
    ("writer took it -> its first write", "woke", "first_write"),
    ("first write -> section's first frame written", "first_write", "first_frame"),
    ("first frame written -> arrival at the robot", "first_frame", "arrived"),
    ("total: sent -> arrival", "sent", "arrived"),
)


def breakdown(released: Released, log: Path) -> list[tuple[str, list[float]]]:
    """Per step of :data:`STEPS`, the seconds each release took."""
    traces = {r["section"]: r for r in read_log(log) if r["kind"] == "trigger"}
    rows: list[tuple[str, list[float]]] = []
    for label, a, b in STEPS:
        values = []
        for section, sent in released.sent.items():
            trace = traces.get(section)
            if trace is None:
                continue
            times = {**trace, "sent": sent, "arrived": released.arrived[section]}
            if times.get(a) is not None and times.get(b) is not None:
                values.append(times[b] - times[a])
        rows.append((label, values))
    return rows


def slowest(released: Released, log: Path, stalls: list[tuple[int, float, float]],
            k: int = 3) -> list[str]:
    """The ``k`` slowest releases, each step's ms, and the probe's stalls meanwhile: where a
    tail came from."""
    traces = {r["section"]: r for r in read_log(log) if r["kind"] == "trigger"}
    worst = sorted(released.sent, key=lambda s: released.sent[s] - released.arrived[s])[:k]
    out = []
    for section in worst:
        trace = traces.get(section)
        if trace is None:
            continue
        times = {**trace, "sent": released.sent[section], "arrived": released.arrived[section]}
        parts = [f"{b} +{(times[b] - times[a]) * 1000:.2f}" for _, a, b in STEPS[:-1]
                 if times.get(a) is not None and times.get(b) is not None]
        total = (times["arrived"] - times["sent"]) * 1000
        stalled = stalls_within(stalls, times["sent"], times["arrived"])
        out.append(f"   {section}: {total:.2f} ms = " + ", ".join(parts)
                   + f"; {stalled or 'no CPU stalled'}")
    return out


Runs = Sequence[Sequence[float]]  # one list of per-frame values (seconds) per run


def pooled_p99(runs: Runs) -> float:
    """The p99 of every run's values together."""
    return percentile([x for run in runs for x in run], 0.99)


def bootstrap_p99_difference(alone: Runs, flood: Runs, *, resamples: int = 2000,
                             level: float = 0.95, seed: int = 1,
                             unit: str = "run") -> tuple[float, float, float]:
    """The pooled p99 of ``flood`` minus that of ``alone``, and a ``level`` bootstrap
    confidence interval of that difference (percentile method): (estimate, low, high).

    ``alone[k]`` and ``flood[k]`` are the per-frame values of the k-th pair of runs, played
    one after the other. ``unit="run"`` resamples the pairs with replacement (a cluster
    bootstrap): frames of one run are not independent draws (a stall or a busy neighbour
    delays several frames in a row, and a run shares its load), and the spread between runs
    is what a repeat of the bench would see, so this is the interval to believe; keeping the
    pairs together keeps what the alternation controls for (a load that drifts over the bench).
    ``unit="frame"`` resamples the frames of every run within that run (the runs stay as they
    are): an interval that assumes independent frames, too narrow when runs differ, for
    comparison. Deterministic for a given ``seed``.
    """
    if len(alone) != len(flood) or not alone:
        raise ValueError(f"need as many flood runs as alone runs, at least one: "
                         f"{len(alone)} alone, {len(flood)} flood")
    if unit not in ("run", "frame"):
        raise ValueError(f"unit is 'run' or 'frame', not {unit!r}")
    rng = random.Random(seed)
    pairs = len(alone)
    diffs = []
    for _ in range(resamples):
        if unit == "run":
            picked = [rng.randrange(pairs) for _ in range(pairs)]
            a: Runs = [alone[k] for k in picked]
            f: Runs = [flood[k] for k in picked]
        else:
            a = [rng.choices(run, k=len(run)) for run in alone]
            f = [rng.choices(run, k=len(run)) for run in flood]
        diffs.append(pooled_p99(f) - pooled_p99(a))
    diffs.sort()
    tail = (1 - level) / 2
    return (pooled_p99(flood) - pooled_p99(alone),
            percentile(diffs, tail), percentile(diffs, 1 - tail))


def outside_stalls(errors: Sequence[float], spans: Sequence[tuple[float, float]],
                   stalls: Sequence[tuple[int, float, float]]) -> list[float]:
    """The ``errors`` of the frames whose span (planned, arrived) overlaps no stall (any CPU,
    the probe's record): what is left when the VM's own stalls are taken out."""
    return [e for e, (a, b) in zip(errors, spans, strict=True)
            if not any(x < max(a, b) and y > min(a, b) for _, x, y in stalls)]


def difference_row(name: str, alone: Runs, flood: Runs) -> str:
    """"name: pooled p99 alone, flood, flood - alone [95 % CI over run pairs] (frame CI)",
    in ms."""
    if len(alone) < 2:
        return f"{name}: fewer than 2 run pairs, no interval"
    est, lo, hi = bootstrap_p99_difference(alone, flood)
    _, flo, fhi = bootstrap_p99_difference(alone, flood, unit="frame")
    n = sum(len(r) for r in alone), sum(len(r) for r in flood)
    return (f"{name}: p99 alone {pooled_p99(alone) * 1000:.2f}, flood "
            f"{pooled_p99(flood) * 1000:.2f} (n={n[0]}/{n[1]}); flood - alone "
            f"{est * 1000:+.2f} ms, 95 % CI [{lo * 1000:+.2f}, {hi * 1000:+.2f}] resampling "
            f"the {len(alone)} run pairs ([{flo * 1000:+.2f}, {fhi * 1000:+.2f}] resampling "
            f"frames within runs, as if independent)")


def row(name: str, seconds: list[float]) -> str:
    if not seconds:
        return f"{name:<58} {'-':>8} {'-':>8} {'-':>8} {'-':>8}  (n=0)"
    ms = sorted(s * 1000 for s in seconds)
    p = [percentile(ms, q) for q in (0.5, 0.99, 0.999)]
    return f"{name:<58} {p[0]:8.2f} {p[1]:8.2f} {p[2]:8.2f} {ms[-1]:8.2f}  (n={len(ms)})"


def load_average() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--triggers", type=int, default=200, help="triggers per client")
    parser.add_argument("--runs", type=int, default=3,
                        help="runs of the push client against serve --log; plays of the steady "
                        "show alone, and as many under the flood")
    parser.add_argument("--no-polling", action="store_true", help="leave the polling client out")
    parser.add_argument("--no-steady", action="store_true", help="leave part 2 out")
    parser.add_argument("--client", choices=("push", "polling", "flood"), help=argparse.SUPPRESS)
    parser.add_argument("--connect", help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--seconds", type=float, default=0.0, help=argparse.SUPPRESS)
    parser.add_argument("--serve-sim", help=argparse.SUPPRESS)
    parser.add_argument("--stall-probe", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.client == "push":
        return push_client(args.connect, args.count)
    if args.client == "polling":
        return polling_client(args.connect, args.count)
    if args.client == "flood":
        return flood_client(args.connect, 1000, args.seconds)
    if args.serve_sim:
        return serve_sim(Path(args.serve_sim))
    if args.stall_probe:
        return stall_probe(Path(args.stall_probe))
    n = args.triggers
    with tempfile.TemporaryDirectory() as tmp:
        triggered_path, steady_path = Path(tmp) / "triggered.yaml", Path(tmp) / "steady.yaml"
        triggered_path.write_text(triggered_routine(n), encoding="utf-8")
        steady_path.write_text(STEADY, encoding="utf-8")
        triggered, steady = (compile_show(load_show(p)) for p in (triggered_path, steady_path))
        record, log = Path(tmp) / "robot.jsonl", Path(tmp) / "serve.jsonl"
        stall_record = Path(tmp) / "stalls.txt"
        with _process(sys.executable, "-c", "while True: pass"), \
                _process(sys.executable, __file__, "--stall-probe", str(stall_record),
                         stdin=True) as probe, \
                _process(sys.executable, __file__, "--serve-sim", str(record),
                         stdin=True) as simproc:
            assert probe.stdout is not None
            probe.stdout.readline()
            assert simproc.stdout is not None
            priority, sim_path = simproc.stdout.readline().split()
            sim = Sim(record)
            quiet: list[Timing] = []
            flooded: list[Timing] = []
            loads: list[str] = []
            poll: Released | None = None
            with serving(sim_path) as (endpoint, session, pid):
                bench = Bench(sim, session, endpoint, pid)
                push = bench.triggered(triggered_path, triggered, "push", n)
                if not args.no_polling:
                    poll = bench.triggered(triggered_path, triggered, "polling", n)
            logged: list[tuple[Released, str]] = []
            steps: list[tuple[str, list[float]]] = []
            worst: list[str] = []
            with serving(sim_path, log=log) as (endpoint, session, pid):
                bench = Bench(sim, session, endpoint, pid)
                for _ in range(max(1, args.runs)):
                    run = bench.triggered(triggered_path, triggered, "push", n)
                    logged.append((run, f"{os.getloadavg()[0]:.1f}"))
                    run_steps = breakdown(run, log)
                    steps = [(label, values + more) for (label, values), (_, more)
                             in zip(steps, run_steps, strict=True)] if steps else run_steps
                    worst += slowest(run, log, read_stalls(stall_record), 2)
                for _ in range(0 if args.no_steady else args.runs):
                    quiet.append(bench.steady(steady_path, steady, False, log))
                    loads.append(f"{os.getloadavg()[0]:.1f}")
                    flooded.append(bench.steady(steady_path, steady, True, log))
                    loads.append(f"{os.getloadavg()[0]:.1f}")
                counters = bench.client.status()["counters"]
            stalls = read_stalls(stall_record)
    print(f"xgo-show serve, a simulated Mini on a pty ({priority}), Zenoh on loopback, one CPU "
          f"kept busy; load average {load_average()}")
    print(f"CPU stalls (a SCHED_FIFO-{STALL_FIFO} probe per CPU woke > {STALL_MIN * 1000:g} ms "
          f"late) during the bench: {len(stalls)}, " + (
              f"longest {max(b - a for _, a, b in stalls) * 1000:.1f} ms" if stalls else ""))
    head = f"{'':<58} {'p50':>8} {'p99':>8} {'p99.9':>8} {'max':>8}"
    print(f"\n1. {n} sections released by triggers, ms\n{head}")
    print(row("push client: trigger put -> first frame at the robot", push.sent_to_frame()))
    if poll is not None:
        print(row(f"polling client ({POLL * 1000:.0f} ms): trigger query -> first frame",
                  poll.sent_to_frame()))
    print(row("push client: show began holding -> first frame", push.held_to_frame()))
    if poll is not None:
        print(row("polling client: show began holding -> first frame", poll.held_to_frame()))
    print(f"\n   push client against serve --log, {len(logged)} runs of {n}, ms\n{head}")
    for k, (run, load) in enumerate(logged):
        print(row(f"   run {k + 1} (load {load}): trigger put -> first frame",
                  run.sent_to_frame()))
    print(row("   all runs: trigger put -> first frame",
              [x for run, _ in logged for x in run.sent_to_frame()]))
    print(f"\n   where the time goes (push client, serve --log, all runs), ms\n{head}")
    for label, values in steps:
        print(row("   " + label, values))
    print("\n   the slowest releases of each run, step by step (ms after the step before)")
    print("\n".join(worst))
    if quiet:
        print("\n2. send-time error of a running show (arrival at the robot - planned), ms, "
              f"alone and under 1,000 triggers a second nobody waits for, alternately\n{head}")
        for k, (q, f) in enumerate(zip(quiet, flooded, strict=True)):
            print(row(f"run {k + 1} alone (load {loads[2 * k]}, serve {q.cpu:.0%} CPU)",
                      q.error))
            print(row(f"run {k + 1} flood (load {loads[2 * k + 1]}, serve {f.cpu:.0%}, "
                      f"client {f.client_cpu:.0%} CPU)", f.error))
        for k, (q, f) in enumerate(zip(quiet, flooded, strict=True)):
            print(f"   run {k + 1}: alone {q.late_in_stalls(stalls)}; "
                  f"flood {f.late_in_stalls(stalls)}")
            print(f"      serve's threads alone: {q.busiest()}; flood: {f.busiest()}")
        print(row("all runs alone", [e for q in quiet for e in q.error]))
        print(row("all runs under the flood", [e for f in flooded for e in f.error]))
        print("\n   flood - alone, pooled p99, with a bootstrap 95 % confidence interval "
              "(target: within 0.1 ms)")
        print("   " + difference_row("all frames", [q.error for q in quiet],
                                      [f.error for f in flooded]))
        calm = ([outside_stalls(q.error, q.spans, stalls) for q in quiet],
                [outside_stalls(f.error, f.spans, stalls) for f in flooded])
        left = (sum(len(q.error) for q in quiet) - sum(map(len, calm[0])),
                sum(len(f.error) for f in flooded) - sum(map(len, calm[1])))
        print("   " + difference_row(f"frames in no CPU stall ({left[0]} alone and {left[1]} "
                                      "flood frames left out)", *calm))
        print(f"\n   the server's issue lateness (its write - planned, run log), ms\n{head}")
        print(row("   all runs alone", [e for q in quiet for e in q.issue]))
        print(row("   all runs under the flood", [e for f in flooded for e in f.issue]))
        print(f"\n   delivery (arrival at the robot - the server's write: the pty), ms\n{head}")
        print(row("   all runs alone", [e for q in quiet for e in q.delivery]))
        print(row("   all runs under the flood", [e for f in flooded for e in f.delivery]))
        print(f"\nserver counters: {json.dumps(counters)}")


if __name__ == "__main__":
    main()
