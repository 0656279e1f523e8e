"""Where a frame's delivery time goes, from the writer's write() to the simulator's timestamp.

The set-up of ``benchmarks/runtime_timing.py`` (four simulated Minis on ptys, each in its own
process, 50 frames/s each, played by the runtime's ShowRunner with SCHED_FIFO writers), traced
with the kernel's own event tracer (ftrace, a private instance under /sys/kernel/tracing, on the
CLOCK_MONOTONIC time base the runner and the simulators use). Each frame's delivery
(simulator's receive time - the runner's issue time) is split into:

- ``write``: issue -> the write queues the pty's flip-buffer work (in the writer's syscall);
- ``kw wait``: queued -> a kernel worker (``kworker/u*``, normal priority, unbound) starts
  ``flush_to_ldisc``; for the slowest frames, what ran on that worker's CPU meanwhile;
- ``kw run``: worker started -> it wakes the simulator's serving thread;
- ``sim wait``: woken -> the serving thread is switched in (its run-queue wait);
- ``sim run``: switched in -> its timestamp (poll returns, read, time.monotonic());
- ``sim busy``: frames that found the serving thread already running (no wake-up needed):
  woken/queued -> timestamp.

It also records the kernel stack of every writer that goes to sleep uninterruptibly (state
D) and, for the latest issues, which of this process's threads were preempted meanwhile.

With ``--relays`` the same four robots are played, in the same run after the local runner,
by four ``xgo-show relay`` processes (one robot each, as ``benchmarks/relay_sync.py`` runs
them), with this process as their conductor (clock tracker, heartbeats); their writes' times
come from the relays' ``frames_host`` trace (``XGO_SHOW_TEST_TRACE``). For both it prints what
ran on the machine's CPUs between each write and its receipt, per frame: what a relayed
robot's delivery waits for that a local one's does not.

Needs root (or tracefs access). Prints figures only. Usage::

    python benchmarks/delivery_trace.py [--seconds 20] [--busy] [--sim fifo|nice|normal]
                                        [--no-realtime] [--worst 5] [--relays] [--processes]
                                        [--lockstep] [--only-relays]

``--processes`` plays the robots from one local process each too (the relays' shape without
Zenoh: the like-for-like comparison), ``--lockstep`` puts every robot's frames at the same
times, as a synced show does (``relay_sync.py``'s shows), instead of 3.7 ms apart.
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import dataclasses
import functools
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import runtime_timing as rt

from xgo_show.compiler.schedule import Schedule
from xgo_show.runtime import clock, realtime
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.events import Event, FrameSent
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.report import percentile
from xgo_show.transports import open_transport
from xgo_show.transports.base import Transport
from xgo_show.wire.xgo import TYPE_READ

TRACEFS = Path("/sys/kernel/tracing")
LINE = re.compile(r"^\s*(?P<comm>.+?)-(?P<pid>\d+)\s+\[(?P<cpu>\d+)\]\s+\S+\s+"
                  r"(?P<t>\d+\.\d+): (?P<event>\w+): (?P<rest>.*)$")
KV = re.compile(r"(\w+)=(\S+)")
#: seconds from a play's start command to its start (the trace runs meanwhile)
LEAD = 0.6


class Tracer:
    """A private ftrace instance with the events that follow a pty write to its reader."""

    def __init__(self, sim_tids: list[int]) -> None:
        if not (TRACEFS / "instances").is_dir():
            raise SystemExit("ftrace is not mounted: mount -t tracefs nodev /sys/kernel/tracing")
        self.dir = TRACEFS / "instances" / f"xgo-show-delivery-{os.getpid()}"
        self.dir.mkdir()
        sims = " || ".join(f"pid == {t}" for t in sim_tids)
        sim_pids = " || ".join(f"common_pid == {t}" for t in sim_tids)
        self.events = {
            "workqueue/workqueue_queue_work": "function.function == flush_to_ldisc",
            "workqueue/workqueue_execute_start": "function.function == flush_to_ldisc",
            "workqueue/workqueue_execute_end": "function.function == flush_to_ldisc",
            # The simulators' and the kernel workers' wake-ups; every switch (who ran).
            # ... and every real-time thread's (the writers', their wake-up latency)
            "sched/sched_waking": f'{sims} || comm ~ "kworker/u*" || prio < 100',
            "sched/sched_switch": "",
            "raw_syscalls/sys_exit": sim_pids,
        }
        # The kernel stack of a writer (SCHED_FIFO 10: kernel priority 89) that goes to sleep
        # uninterruptibly (state D): what in the kernel it waits for.
        self._write("events/sched/sched_switch/trigger",
                    "stacktrace if prev_prio == 89 && prev_state == 2")
        self._write("trace_clock", "mono")
        self._write("buffer_size_kb", "65536")
        for event, filt in self.events.items():
            if filt:
                self._write(f"events/{event}/filter", filt)
            self._write(f"events/{event}/enable", "1")

    def _write(self, name: str, value: str) -> None:
        (self.dir / name).write_text(value + "\n")

    def start(self) -> None:
        self._write("trace", "")
        self._write("tracing_on", "1")

    def stop(self) -> list[str]:
        self._write("tracing_on", "0")
        lost = (self.dir / "per_cpu" / "cpu0" / "stats").read_text()
        overrun = [ln for ln in lost.splitlines() if ln.startswith("overrun")]
        text = (self.dir / "trace").read_text()
        if overrun and overrun[0].split()[-1] != "0":
            print(f"  warning: the trace buffer overran ({overrun[0]})")
        return text.splitlines()

    def close(self) -> None:
        self._write("events/sched/sched_switch/trigger",
                    "!stacktrace if prev_prio == 89 && prev_state == 2")
        for event in self.events:
            self._write(f"events/{event}/enable", "0")
        self._write("trace", "")
        self.dir.rmdir()


@dataclass
class Trace:
    queued: dict[int, list[tuple[float, str]]] = field(default_factory=lambda: defaultdict(list))
    started: dict[str, list[tuple[float, int, int]]] = field(
        default_factory=lambda: defaultdict(list))  # work -> (t, worker pid, cpu)
    waking: dict[int, list[tuple[float, int]]] = field(
        default_factory=lambda: defaultdict(list))  # pid -> (t, target cpu)
    switched_in: dict[int, list[float]] = field(default_factory=lambda: defaultdict(list))
    # pid -> (t, its state: S sleeping, R preempted, D uninterruptible; cpu)
    switched_out: dict[int, list[tuple[float, str, int]]] = field(
        default_factory=lambda: defaultdict(list))
    # per CPU: (t, next comm, next pid, next prio), in time order
    switches: dict[int, list[tuple[float, str, int, int]]] = field(
        default_factory=lambda: defaultdict(list))


def parse(lines: list[str]) -> Trace:
    tr = Trace()
    for line in lines:
        m = LINE.match(line)
        if m is None:
            continue
        t, event, rest = float(m["t"]), m["event"], m["rest"]
        pid, cpu = int(m["pid"]), int(m["cpu"])
        if event == "workqueue_queue_work":
            tr.queued[pid].append((t, rest.split("=", 1)[1].split()[0]))
        elif event == "workqueue_execute_start":
            tr.started[rest.split()[2].rstrip(":")].append((t, pid, cpu))
        elif event == "sched_waking":
            kv = dict(KV.findall(rest))
            tr.waking[int(kv["pid"])].append((t, int(kv["target_cpu"])))
        elif event == "sched_switch":
            prev, nxt = rest.split("==> ", 1)
            pkv = dict(KV.findall(prev))
            tr.switched_out[int(pkv["prev_pid"])].append((t, pkv["prev_state"], cpu))
            kv = dict(KV.findall(nxt))
            tr.switches[cpu].append((t, kv["next_comm"], int(kv["next_pid"]),
                                     int(kv["next_prio"])))
            tr.switched_in[int(kv["next_pid"])].append(t)
    return tr


def first_at(times: list[float], t: float) -> int:
    return bisect.bisect_left(times, t)


def who_ran(tr: Trace, cpu: int, a: float, b: float,
            roles: dict[int, str] | None = None) -> dict[str, float]:
    """ms each task (comm/prio; its name in ``roles`` if there) ran on ``cpu`` between ``a``
    and ``b``."""
    sw = tr.switches[cpu]
    times = [s[0] for s in sw]
    i = max(0, bisect.bisect_right(times, a) - 1)
    out: dict[str, float] = defaultdict(float)
    while i < len(sw) and sw[i][0] < b:
        start = max(a, sw[i][0])
        end = min(b, sw[i + 1][0]) if i + 1 < len(sw) else b
        _, comm, pid, prio = sw[i]
        if roles is not None and pid in roles:
            comm = roles[pid]
        # kernel prio: < 100 real-time (99 - rt priority), 120 = nice 0
        out[f"{comm}({'rt' + str(99 - prio) if prio < 100 else 'n' + str(prio - 120)})"] += (
            (end - start) * 1000.0)
        i += 1
    return dict(out)


@dataclass
class Frame:
    perf: str
    tid: int
    issue: float
    receive: float
    parts: dict[str, float]  # ms
    kw_cpu: int | None
    kw_window: tuple[float, float] | None


PARTS = ["write", "kw wait", "kw run", "sim wait", "sim run", "sim busy"]


def breakdown(tr: Trace, issued: list[tuple[float, str, int]],
              received: dict[str, list[float]], sim_tid: dict[str, int]) -> list[Frame]:
    """One Frame per schedule frame: its delivery split into PARTS."""
    by_perf: dict[str, list[tuple[float, int]]] = defaultdict(list)
    for t, perf, tid in issued:
        by_perf[perf].append((t, tid))
    started_t = {w: [s[0] for s in v] for w, v in tr.started.items()}
    waking_t = {p: [w[0] for w in v] for p, v in tr.waking.items()}
    frames = []
    for perf, sends in by_perf.items():
        work = None
        sim = sim_tid[perf]
        sim_wakes = waking_t.get(sim, [])
        sim_in = tr.switched_in.get(sim, [])
        for (issue, tid), got in zip(sends, received[perf], strict=False):
            q_list = tr.queued.get(tid, [])
            qi = bisect.bisect_left(q_list, (issue, ""))
            q = q_list[qi] if qi < len(q_list) and q_list[qi][0] <= got else None
            if q is not None:
                work = q[1]
            if work is None:
                continue
            q_t = q[0] if q is not None else issue
            si = first_at(started_t[work], q_t)
            if si >= len(started_t[work]) or started_t[work][si] > got:
                continue
            s_t, kw_pid, kw_cpu = tr.started[work][si]
            # the worker's own wake-up before it started (if it was asleep)
            kw_wakes = [w for w in tr.waking.get(kw_pid, []) if q_t - 1e-6 <= w[0] <= s_t]
            kw_from, kw_on = (kw_wakes[0][0], kw_wakes[0][1]) if kw_wakes else (q_t, kw_cpu)
            wi = first_at(sim_wakes, s_t)
            parts = {"write": (q_t - issue) * 1000, "kw wait": (s_t - q_t) * 1000}
            if wi < len(sim_wakes) and sim_wakes[wi] <= got:
                k = sim_wakes[wi]
                ri = first_at(sim_in, k)
                r = sim_in[ri] if ri < len(sim_in) and sim_in[ri] <= got else k
                parts.update({"kw run": (k - s_t) * 1000, "sim wait": (r - k) * 1000,
                              "sim run": (got - r) * 1000})
            else:  # the serving thread was running: it picks the bytes up when it next reads
                parts["sim busy"] = (got - s_t) * 1000
            frames.append(Frame(perf, tid, issue, got, parts, kw_on, (kw_from, s_t)))
    return frames


@dataclass
class Played:
    """One traced play of the schedule: the trace, every frame's write, and who is who."""

    label: str
    lines: list[str]
    issued: list[tuple[float, str, int]]  # (write time, performer, writer thread)
    late: list[tuple[float, float, int]]  # (planned, issued, writer) of writes > 1 ms late
    names: dict[int, str]  # the writers' process's threads (in this process only)
    roles: dict[int, str]  # thread id -> a name for the tables of what ran
    windows: list[tuple[float, float]]  # the simulators' receive times that belong to it
    load: float = dataclasses.field(default_factory=lambda: os.getloadavg()[0])


def play_local(args: argparse.Namespace, schedule: Schedule, sims: rt.Sims,
               tracer: Tracer) -> Played:
    """The schedule played by a local runner in this process (``xgo-show run``'s way)."""
    links: dict[str, Transport] = {}
    busy = None
    stack = contextlib.ExitStack()
    try:
        for perf, path in zip(schedule.performers, sims.paths, strict=True):
            links[perf.name] = open_transport(path, baudrate=perf.link.baud)
            links[perf.name].open()
        if args.busy:
            busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            if args.busy_cpu is not None:
                os.sched_setaffinity(busy.pid, {args.busy_cpu})
        if args.raise_kworkers:
            workers = rt.RaisedWorkers()
            stack.enter_context(workers)
        issued: list[tuple[float, str, int]] = []
        late: list[tuple[float, float, int]] = []  # (planned, issued, writer) > 1 ms late

        def on_frame(event: Event) -> None:
            if isinstance(event, FrameSent) and event.kind == "frame":
                issued.append((event.t, event.performer, threading.get_native_id()))
                if event.error is not None and event.error > 0.001:
                    late.append((event.t - event.error, event.t, threading.get_native_id()))

        names: dict[int, str] = {}  # this process's threads: native id -> name
        sampling = threading.Event()

        def sample() -> None:  # rarely: this thread holds Python's lock meanwhile
            while not sampling.wait(2.0):
                names.update({th.native_id: th.name for th in threading.enumerate()
                              if th.native_id is not None})

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()

        runner = local_runner(schedule, links, clock=MonotonicClock())
        runner.events.subscribe(on_frame, FrameSent)
        saved = realtime.policy()
        realtime.configure("off" if args.no_realtime else "required")
        begin = time.monotonic()
        tracer.start()
        try:
            result = runner.run(lead=0.3, handle_signals=False)
            time.sleep(0.3)
        finally:
            lines = tracer.stop()
            realtime.restore(saved)
            sampling.set()
        if not result.completed:
            raise SystemExit(f"the run did not complete: {result.reason}")
        if args.raise_kworkers:
            stack.close()
            print(f"  {workers.raised} unbound kernel workers ran under SCHED_FIFO 5")
    finally:
        stack.close()
        if busy is not None:
            busy.kill()
            busy.wait()
        for link in links.values():
            link.close()
    roles = {tid: f"local:{name[:18]}" for tid, name in names.items()}
    return Played("local runner, one process, 4 robots", lines, issued, late, names, roles,
                  [(begin, time.monotonic())])


class Group:
    """Players of the schedule that stay up between plays, so several kinds of players can
    play in turn, round after round (``--rounds``), each round under the same load."""

    label = ""

    def __init__(self) -> None:
        self.played: Played | None = None
        self.rounds: list[Played] = []

    def open(self) -> None:
        """Start the processes; return when they are ready to play."""

    def play_once(self, tracer: Tracer) -> Played:
        """One traced play of the schedule."""
        raise NotImplementedError

    def close(self) -> None:
        """Stop the processes."""

    def play(self, tracer: Tracer) -> None:
        """One traced play, added to the earlier ones (:attr:`played`, :attr:`rounds`)."""
        one = self.play_once(tracer)
        if not one.issued:
            return
        self.rounds.append(one)
        if self.played is None:  # a copy: the next rounds are added to it
            self.played = dataclasses.replace(
                one, lines=list(one.lines), issued=list(one.issued), late=list(one.late),
                roles=dict(one.roles), windows=list(one.windows))
            return
        p = self.played
        p.lines.extend(one.lines)
        p.issued.extend(one.issued)
        p.issued.sort()
        p.late.extend(one.late)
        p.roles.update(one.roles)
        p.windows.extend(one.windows)


class Processes(Group):
    """The schedule played by one local process per robot (``--play-child``): the relays'
    shape without Zenoh, a conductor or a clock to estimate."""

    def __init__(self, args: argparse.Namespace, schedule: Schedule, sims: rt.Sims,
                 tmp: Path) -> None:
        super().__init__()
        self.args, self.schedule, self.sims = args, schedule, sims
        self.threads = [tmp / f"proc{i}.threads" for i in range(len(schedule.performers))]
        self.procs: list[subprocess.Popen[str]] = []
        self.label = f"local, {len(schedule.performers)} processes, one robot each"

    def open(self) -> None:
        args = self.args
        for perf, path, names in zip(self.schedule.performers, self.sims.paths, self.threads,
                                     strict=True):
            self.procs.append(subprocess.Popen(
                [sys.executable, __file__, "--play-child", f"{perf.name}={path}",
                 "--threads-file", str(names),
                 "--seconds", str(args.seconds), *(["--lockstep"] if args.lockstep else []),
                 *(["--handoff-us", str(args.handoff_us)] if args.handoff_us else []),
                 *(["--no-realtime"] if args.no_realtime else [])],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True))
        for proc in self.procs:
            assert proc.stdout is not None
            if proc.stdout.readline().strip() != "ready":
                raise SystemExit("a local process did not start")

    def play_once(self, tracer: Tracer) -> Played:
        from relay_variants import read_threads

        issued: list[tuple[float, str, int]] = []
        late: list[tuple[float, float, int]] = []
        roles: dict[int, str] = {}
        begin = time.monotonic()
        tracer.start()
        try:
            start_at = time.monotonic() + LEAD
            for proc in self.procs:
                assert proc.stdin is not None
                proc.stdin.write(f"{start_at!r}\n")
                proc.stdin.flush()
            for i, proc in enumerate(self.procs):
                assert proc.stdout is not None
                reply = json.loads(proc.stdout.readline())
                if not reply["completed"]:
                    raise SystemExit(f"a local process did not complete: {reply['reason']}")
                named = read_threads(str(self.threads[i]))
                roles.update({t: f"proc{i}:{n}" for t, n in named.items()})
                for t, perf, tid, planned in reply["frames"]:
                    issued.append((t, perf, tid))
                    roles[tid] = f"proc{i}:writer"
                    if t - planned > 0.001:
                        late.append((planned, t, tid))
            time.sleep(0.3)
        finally:
            lines = tracer.stop()
        issued.sort()
        return Played(self.label, lines, issued, late, {}, roles, [(begin, time.monotonic())])

    def close(self) -> None:
        for proc in self.procs:
            if proc.stdin is not None:
                proc.stdin.close()
        for proc in self.procs:
            proc.wait(10)


class Relays(Group):
    """The schedule played by one ``xgo-show relay`` process per robot, this process their
    conductor (heartbeats every 0.1 s, a clock tracker each, as ``run`` does); with ``rev``,
    the relays run that revision's xgo_show. ``silent`` (an experiment): the conductor stops
    its heartbeats and clock tracking once the start is sent, and the relays play on
    (link-loss policy ``continue``): what the heartbeats and clock bursts cost a delivery (one
    play only: the relays then let their silent conductor go).
    ``variant``: the relays run with that one thing changed (``relay_variants.py``)."""

    def __init__(self, args: argparse.Namespace, schedule: Schedule, sims: rt.Sims,
                 tmp: Path, rev: str = "", silent: bool = False, variant: str = "base",
                 group: int = 0) -> None:
        super().__init__()
        self.args, self.schedule, self.sims, self.tmp = args, schedule, sims, tmp
        self.rev, self.silent, self.variant = rev, silent, variant
        self.names = [f"trace{group}-{i}" for i in range(len(schedule.performers))]
        tag = f"{group}"
        self.logs = [tmp / f"relay{i}-{tag}.jsonl" for i in range(len(schedule.performers))]
        self.threads = [tmp / f"relay{i}-{tag}.threads" for i in range(len(schedule.performers))]
        self.procs: list[subprocess.Popen[str]] = []
        self.roles: dict[int, str] = {}
        self.session: Any = None
        self.clients: list[Any] = []
        self.trackers: list[Any] = []
        self.texts: list[str] = []
        self.shas: list[str] = []
        self.seen = [0] * len(schedule.performers)  # frames_host records already read
        self.label = ("relays, one process per robot" + (f" (revision {rev})" if rev else "")
                      + (" (conductor silent during the show)" if silent else "")
                      + (f" (variant {variant})" if variant != "base" else ""))

    def open(self) -> None:
        import socket

        from relay_sync import extract

        from xgo_show.compiler.artifact import schedule_to_bytes
        from xgo_show.net.keys import relay_key
        from xgo_show.net.session import SessionOptions, open_session
        from xgo_show.net.testhooks import TRACE_ENV
        from xgo_show.net.timesync import ClockTracker
        from xgo_show.relay.client import RelayClient
        from xgo_show.relay.validate import schedule_digest

        args, rev = self.args, self.rev
        ports = []
        paths = {"PYTHONPATH": str(extract(rev, self.tmp / f"rev-{rev}"))} if rev else {}
        for i, (perf, path) in enumerate(zip(self.schedule.performers, self.sims.paths,
                                             strict=True)):
            with socket.socket() as sock:
                sock.bind(("127.0.0.1", 0))
                ports.append(int(sock.getsockname()[1]))
            self.procs.append(subprocess.Popen(
                [*_xgo_show(args, self.variant, self.threads[i]), "relay",
                 "--name", self.names[i], "--map", f"{perf.name}={path}",
                 "--listen", f"tcp/127.0.0.1:{ports[-1]}", "--no-telemetry",
                 "--log", str(self.logs[i]), *(["--no-realtime"] if args.no_realtime else [])],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                env={**os.environ, TRACE_ENV: "1", **paths}))
        for proc in self.procs:
            assert proc.stdout is not None
            if "ready" not in proc.stdout.readline():
                err = proc.stderr.read() if proc.stderr else ""
                raise SystemExit(f"a relay did not start: {err}")
        self.session = open_session(SessionOptions(
            connect=tuple(f"tcp/127.0.0.1:{p}" for p in ports), listen=("tcp/127.0.0.1:0",)))
        for name, perf in zip(self.names, self.schedule.performers, strict=True):
            client = RelayClient(self.session, name)
            client.request("hello", timeout=10.0)  # resent until the session has a route
            client.start_heartbeat(period=0.1, watchdog=0.5)
            self.clients.append(client)
            tracker = ClockTracker(self.session, relay_key("xgo-show", name, "time"),
                                   conductor=client.conductor.id, interval=1.0)
            tracker.start()
            self.trackers.append(tracker)
            self.texts.append(schedule_to_bytes(
                dataclasses.replace(self.schedule, performers=(perf,))).decode("ascii"))
            self.shas.append(schedule_digest(self.texts[-1]))

    def _sample(self) -> None:
        """The relays' threads, with their names (Zenoh's: rx-0, tx-0...; Python's, all
        "python" in /proc, from relay_variants.py's notes)."""
        from relay_variants import read_threads

        for i, proc in enumerate(self.procs):
            named = read_threads(str(self.threads[i]))
            self.roles.update({t: f"relay{i}:{named.get(t, c)}"
                               for t, c in _tasks(proc.pid).items()})
        self.roles.update({t: f"conductor:{c}" for t, c in _tasks(os.getpid()).items()})

    def play_once(self, tracer: Tracer) -> Played:
        if self.silent and self.played is not None:
            return Played(self.label, [], [], [], {}, {}, [])
        for client, text, sha in zip(self.clients, self.texts, self.shas, strict=True):
            if not client.upload(text, sha, watchdog_ms=3000,
                                 link_loss="continue" if self.silent else "stop")["preflight_ok"]:
                raise SystemExit(f"relay {client.relay}: the pre-flight failed")
        sampling = threading.Event()

        def sample() -> None:
            while True:
                self._sample()
                if sampling.wait(0.5):
                    return

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        begin = time.monotonic()
        tracer.start()
        clients = self.clients
        try:
            start_at = time.monotonic() + LEAD
            for client, sha in zip(clients, self.shas, strict=True):
                client.request("start", sha256=sha, start_at=start_at, offset=0.0)
            deadline = start_at + self.schedule.duration + 15.0
            if self.silent:  # nothing from the conductor until the show is over
                for client in clients:
                    client.stop_heartbeat()
                for tracker in self.trackers:
                    tracker.close()
                self.trackers = []
                time.sleep(max(0.0, start_at + self.schedule.duration + 1.0 - time.monotonic()))
                clients = []  # released by now (their watchdog): nothing to ask them
            for client in clients:
                while client.command("heartbeat")["show"]["state"] not in ("ended", "idle"):
                    if time.monotonic() > deadline:
                        raise SystemExit(f"relay {client.relay}: the show did not end")
                    time.sleep(0.1)
            time.sleep(0.3)
        finally:
            lines = tracer.stop()
            sampling.set()
            sampler.join()
        self._sample()
        issued: list[tuple[float, str, int]] = []
        late: list[tuple[float, float, int]] = []
        queued = parse([ln for ln in lines if "workqueue_queue_work" in ln]).queued
        for i, (perf, log) in enumerate(zip(self.schedule.performers, self.logs, strict=True)):
            mine = [t for t, role in self.roles.items() if role.startswith(f"relay{i}:")]
            writer = max(mine, key=lambda t: len(queued.get(t, [])))  # the one that writes
            self.roles[writer] = f"relay{i}:writer"
            records = [rec for rec in map(json.loads, log.read_text(encoding="utf-8")
                                          .splitlines()) if rec.get("event") == "frames_host"]
            new, self.seen[i] = records[self.seen[i]:], len(records)
            for rec in new:
                for _index, planned, actual, _seen in rec["frames"][perf.name]:
                    issued.append((float(actual), perf.name, writer))
                    if actual - planned > 0.001:
                        late.append((float(planned), float(actual), writer))
            if not new:  # no tracer (--variants no-tracer): the kernel saw the writes queued
                n = len(perf.frames)
                issued.extend((t, perf.name, writer) for t, _work in
                              [q for q in queued.get(writer, []) if q[0] >= start_at][:n])
        issued.sort()
        return Played(self.label, lines, issued, late, {}, dict(self.roles),
                      [(begin, time.monotonic())])

    def close(self) -> None:
        for client in self.clients:
            client.stop_heartbeat()
        for tracker in self.trackers:
            tracker.close()
        if self.session is not None:
            self.session.close()
        for proc in self.procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        for proc in self.procs:
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5)


def play_child(pair: str, args: argparse.Namespace) -> None:
    """``--play-child NAME=PTY``: play robot NAME's part of the schedule on PTY at the start
    time read from stdin; print every frame's (write time, NAME, writer thread, planned)."""
    from relay_variants import name_threads

    if args.threads_file:
        name_threads(args.threads_file)
    name, _, path = pair.partition("=")
    full = make_schedule(args)
    schedule = dataclasses.replace(
        full, performers=tuple(p for p in full.performers if p.name == name))
    link = open_transport(path, baudrate=schedule.performers[0].link.baud)
    link.open()
    realtime.configure("off" if args.no_realtime else "required")
    print("ready", flush=True)
    try:
        for line in sys.stdin:
            frames: list[tuple[float, str, int, float]] = []
            # No telemetry: the relays play with --no-telemetry (like for like).
            runner = local_runner(schedule, {name: link}, clock=MonotonicClock(),
                                  telemetry=False)
            runner.events.subscribe(functools.partial(_note_frame, frames), FrameSent)
            result = runner.run(start_at=float(line), lead=0.0, handle_signals=False)
            print(json.dumps({"completed": result.completed, "reason": result.reason,
                              "frames": frames}), flush=True)
    finally:
        link.close()


def _note_frame(frames: list[tuple[float, str, int, float]], event: Event) -> None:
    """A play child's listener: (write time, performer, writer thread, planned) per frame."""
    if isinstance(event, FrameSent) and event.kind == "frame":
        frames.append((event.t, event.performer, threading.get_native_id(),
                       event.t if event.planned is None else event.planned))


def make_schedule(args: argparse.Namespace) -> Schedule:
    """``runtime_timing``'s show at 50 frames/s; with ``--lockstep`` every robot's frames at
    the same times (as a synced show plays them), not each robot 3.7 ms after the previous."""
    return rt.make_schedule(args.seconds, 50.0, lockstep=args.lockstep)


def _xgo_show(args: argparse.Namespace, variant: str = "base", threads: Path | None = None
              ) -> list[str]:
    """The command that runs ``xgo-show``: through ``relay_variants.py``, which notes the
    process's Python threads in ``threads`` and changes ``variant``'s one thing (and the
    hand-off, with ``--handoff-us``)."""
    return [sys.executable, str(Path(__file__).resolve().parent / "relay_variants.py"),
            "--variant", variant, *(["--threads", str(threads)] if threads else []),
            *(["--handoff-us", str(args.handoff_us)] if args.handoff_us else []), "--"]


def _tasks(pid: int) -> dict[int, str]:
    """A process's threads: id -> its name (comm), {} once it has gone."""
    out = {}
    with contextlib.suppress(OSError):
        for task in os.listdir(f"/proc/{pid}/task"):
            with contextlib.suppress(OSError):
                out[int(task)] = Path(f"/proc/{pid}/task/{task}/comm").read_text().strip()
    return out


def _kind(label: str) -> str:
    """A task's kind: its name without the numbers that tell one relay, robot or worker from
    another (relay2:rx-1(n0) -> relay:rx-N(n0))."""
    return re.sub(r"(relay|sim|rx-|tx-|acc-|app-|net-|kworker/u\d+:)\d+", r"\1N", label)


def during_delivery(tr: Trace, frames: list[Frame], roles: dict[int, str]) -> None:
    """What ran on every CPU between each frame's write and its receipt (ms per frame, and
    when it first ran after the write), and how long the frame's own writer ran in that time
    (its hand-off's wake-up, its listeners)."""
    cpus = sorted(tr.switches)
    cpu_times = {cpu: [x[0] for x in tr.switches[cpu]] for cpu in cpus}
    total: dict[str, float] = defaultdict(float)
    first: dict[str, list[float]] = defaultdict(list)
    own: list[float] = []
    for f in frames:
        mine = 0.0
        began: dict[str, float] = {}
        for cpu in cpus:
            sw = tr.switches[cpu]
            i = max(0, bisect.bisect_right(cpu_times[cpu], f.issue) - 1)
            while i < len(sw) and sw[i][0] < f.receive:
                t, comm, pid, prio = sw[i]
                end = min(f.receive, sw[i + 1][0]) if i + 1 < len(sw) else f.receive
                start = max(f.issue, t)
                if pid == f.tid:
                    mine += (end - start) * 1000
                name = roles.get(pid, comm) if roles else comm
                level = f"rt{99 - prio}" if prio < 100 else f"n{prio - 120}"
                kind = _kind(f"{name}({level})")
                total[kind] += (end - start) * 1000
                if end > start:
                    began[kind] = min(began.get(kind, end), start)
                i += 1
        own.append(mine)
        for k, t in began.items():
            first[k].append((t - f.issue) * 1000)
    n = max(1, len(frames))
    print(f"the frame's own writer on a CPU between its write and the receipt: p50 "
          f"{percentile(own, .5):.3f} / p99 {percentile(own, .99):.3f} / mean "
          f"{sum(own) / n:.3f} ms")
    print(f"what ran between a frame's write and its receipt, on the {len(cpus)} CPUs, by kind: "
          "ms per frame, share of frames it ran in, and p50 of when it first ran (ms after the "
          "write)")
    for k, v in sorted(total.items(), key=lambda kv: -kv[1])[:16]:
        print(f"  {k:<40}{v / n:8.3f}{len(first[k]) / n * 100:7.1f} %"
              f"{percentile(first[k], .5) if first[k] else 0.0:9.3f}")


def runs_of(tr: Trace, window: tuple[float, float]) -> dict[int, list[tuple[float, float]]]:
    """Every task's time on a CPU within ``window``: pid -> [(from, to)], in time order."""
    out: dict[int, list[tuple[float, float]]] = defaultdict(list)
    a, b = window
    for sw in tr.switches.values():
        for i, (t, _comm, pid, _prio) in enumerate(sw):
            end = sw[i + 1][0] if i + 1 < len(sw) else b
            if end <= a or t >= b or pid == 0:
                continue
            out[pid].append((max(a, t), min(b, end)))
    for runs in out.values():
        runs.sort()
    return out


def cpu_by_thread(tr: Trace, played: Played) -> None:
    """CPU time per frame of every thread over the whole show (not only during deliveries),
    by kind, and how often it was switched in; then the writers' own: before the write (from
    the wake-up that ends the frame's wait) and after it (hand-off, listeners, the loop to the
    next wait), how many times a writer ran per frame, and its wake-up latency (woken ->
    on a CPU). What a relay process runs that a local one does not shows here whole."""
    if not played.issued:
        return
    windows = play_windows(played)
    runs: dict[int, list[tuple[float, float]]] = defaultdict(list)
    for window in windows:
        for pid, rs in runs_of(tr, window).items():
            runs[pid].extend(rs)
    n = len(played.issued)
    total: dict[str, float] = defaultdict(float)
    count: dict[str, int] = defaultdict(int)
    comms = {pid: comm for sw in tr.switches.values() for _t, comm, pid, _p in sw}
    for pid, rs in runs.items():
        name = played.roles.get(pid)
        kind = _kind(name) if name else "other:" + re.sub(r"\d+", "N", comms.get(pid, "?"))
        total[kind] += sum(e - s for s, e in rs) * 1e6
        count[kind] += len(rs)
    print(f"CPU over the whole show, every thread, by kind: us per frame ({n} frames) and runs "
          "per frame")
    for k, v in sorted(total.items(), key=lambda kv: -kv[1])[:18]:
        print(f"  {k:<40}{v / n:9.1f}{count[k] / n:8.2f}")
    w = writer_stats(tr, played, windows, runs)
    before, after, per_frame, wake = w["before"], w["after"], w["runs"], w["wake"]
    if before:
        print(f"the writers, us per frame: wake-up to write p50 {percentile(before, .5):.1f} / "
              f"mean {sum(before) / len(before):.1f}; write to the next wait p50 "
              f"{percentile(after, .5):.1f} / mean {sum(after) / len(after):.1f}; runs per frame "
              f"mean {sum(per_frame) / len(per_frame):.2f}; wake-up latency p50 "
              f"{percentile(wake, .5) if wake else 0.0:.1f} / p99 "
              f"{percentile(wake, .99) if wake else 0.0:.1f} (n={len(wake)})")


def play_windows(played: Played) -> list[tuple[float, float]]:
    """Each play's first write - 5 ms to its last write + 25 ms (the trace has nothing
    between two plays)."""
    windows = []
    for a, b in played.windows:
        ts = [t for t, _perf, _tid in played.issued if a <= t <= b]
        if ts:
            windows.append((ts[0] - 0.005, ts[-1] + 0.025))
    return windows


def writer_stats(tr: Trace, played: Played, windows: list[tuple[float, float]],
                 runs: dict[int, list[tuple[float, float]]]) -> dict[str, list[float]]:
    """The writers' CPU per frame (us): ``before`` its write (from the wake-up that ended
    the frame's wait), ``after`` it (to the next frame's wake-up: the write's return, the
    hand-off, the listeners, the loop to the next wait); ``runs`` per frame; ``wake`` latency
    (woken -> on a CPU)."""
    writers: dict[int, list[float]] = defaultdict(list)
    for t, _perf, tid in played.issued:
        writers[tid].append(t)
    before: list[float] = []
    after: list[float] = []
    per_frame: list[float] = []
    for tid, issues in writers.items():
        rs = runs.get(tid, [])
        starts = [r[0] for r in rs]
        for k, t in enumerate(issues):
            nxt = issues[k + 1] if k + 1 < len(issues) else t + 0.02
            if nxt - t > 0.1:  # the last frame of a play: the next is another play's
                continue
            i = max(0, bisect.bisect_right(starts, t) - 1)
            if not rs or not rs[i][0] <= t <= rs[i][1] + 1e-5:
                continue
            before.append((t - rs[i][0]) * 1e6)
            j = bisect.bisect_right(starts, nxt) - 1  # the run holding the next write
            mine = [(max(s, t), min(e, nxt if m == j else e)) for m, (s, e) in
                    enumerate(rs[i:j + 1], start=i)]
            after.append(sum(e - s for s, e in mine if e > s) * 1e6)
            per_frame.append(float(j - i))
    wake: list[float] = []
    for tid in writers:
        ins = tr.switched_in.get(tid, [])
        for w, _cpu in tr.waking.get(tid, []):
            if any(a <= w <= b for a, b in windows):
                i = first_at(ins, w)
                if i < len(ins):
                    wake.append((ins[i] - w) * 1e6)
    return {"before": before, "after": after, "runs": per_frame, "wake": wake}


def received_of(played: Played, schedule: Schedule, sims: rt.Sims) -> dict[str, list[float]]:
    """Each robot's receive times of the schedule's frames in ``played``'s plays."""
    received = {}
    wanted = {bytes(f.data) for p in schedule.performers for f in p.frames}
    for perf, record in zip(schedule.performers, sims.records, strict=True):
        received[perf.name] = [t for t, data in rt.read_records(record)
                               if data[3] != TYPE_READ and data in wanted
                               and any(a <= t <= b for a, b in played.windows)]
    return received


def by_round(groups: list[Group], schedule: Schedule, sims: rt.Sims) -> None:
    """Every round's figures side by side (the groups played in turn, so a round's columns
    saw the same load), and each group's difference from the first, round by round."""
    sim_tid = {p.name: tid for p, tid in zip(schedule.performers, sims.tids, strict=True)}
    rows: dict[str, dict[str, list[float]]] = {}
    for g in groups:
        cols: dict[str, list[float]] = defaultdict(list)
        for one in g.rounds:
            tr = parse(one.lines)
            frames = breakdown(tr, one.issued, received_of(one, schedule, sims), sim_tid)
            windows = play_windows(one)
            runs: dict[int, list[tuple[float, float]]] = defaultdict(list)
            for window in windows:
                for pid, rs in runs_of(tr, window).items():
                    runs[pid].extend(rs)
            w = writer_stats(tr, one, windows, runs)
            cols["delivery p50 (ms)"].append(
                percentile([(f.receive - f.issue) * 1000 for f in frames], .5) if frames else 0)
            cols["kw first ran p50 (ms)"].append(percentile(
                [f.parts["write"] + f.parts["kw wait"] for f in frames], .5) if frames else 0)
            for key, label in (("before", "writer before write (us/frame)"),
                               ("after", "writer after write (us/frame)")):
                cols[label].append(sum(w[key]) / len(w[key]) if w[key] else 0.0)
            # in all (a relay without the tracer has its write time from the kernel's trace,
            # where the write queues the bytes: later than the runtime's, so "before" is longer)
            cols["writer in all (us/frame)"].append(
                cols["writer before write (us/frame)"][-1]
                + cols["writer after write (us/frame)"][-1])
            cols["loadavg"].append(one.load)
        rows[g.label] = cols
    if not rows:
        return
    first = groups[0].label
    print(f"\n== round by round ({len(groups[0].rounds)} rounds; groups in turn, the order "
          "rotated each round)")
    for metric in next(iter(rows.values())):
        print(f"{metric}:")
        for label, cols in rows.items():
            vals = cols[metric]
            text = " ".join(f"{v:7.3f}" if metric.endswith("(ms)") else f"{v:7.1f}"
                            for v in vals)
            line = f"  {label[:58]:<58} {text}"
            if label != first and metric != "loadavg":
                diffs = sorted(a - b for a, b in zip(vals, rows[first][metric], strict=False))
                if diffs:
                    mid = diffs[len(diffs) // 2] if len(diffs) % 2 else (
                        diffs[len(diffs) // 2 - 1] + diffs[len(diffs) // 2]) / 2
                    line += f"   - first: median {mid:+.3f} [{diffs[0]:+.3f}, {diffs[-1]:+.3f}]"
            print(line)


def report(played: Played, schedule: Schedule, sims: rt.Sims, worst: int) -> None:
    """The figures of one play."""
    lines = played.lines
    received = received_of(played, schedule, sims)
    print(f"\n== {played.label}: {len(lines)} trace lines")
    stacks: dict[str, int] = defaultdict(int)
    for i, line in enumerate(lines):
        if "<stack trace>" in line:
            frames = []
            for follow in lines[i + 1:i + 20]:
                if not follow.lstrip().startswith("=>"):
                    break
                frames.append(follow.strip()[3:].split("+")[0])
            stacks[" < ".join(frames[4:14])] += 1
    if stacks:
        print("writers gone to sleep uninterruptibly (state D), by kernel stack:")
        for stack, n in sorted(stacks.items(), key=lambda kv: -kv[1])[:6]:
            print(f"  {n:4d}  {stack}")
    tr = parse(lines)
    sim_tid = {p.name: tid for p, tid in zip(schedule.performers, sims.tids, strict=True)}
    frames = breakdown(tr, played.issued, received, sim_tid)
    if not frames:
        print("no frame followed through the trace")
        return
    delivery = [(f.receive - f.issue) * 1000 for f in frames]
    print(f"{len(frames)} of {len(played.issued)} frames followed through the trace")
    print(f"{'ms':<10}{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>8}{'n':>7}   "
          f"(among the 1 % slowest deliveries: share of their time)")
    slow = sorted(frames, key=lambda f: f.receive - f.issue)[-max(1, len(frames) // 100):]
    slow_total = sum((f.receive - f.issue) * 1000 for f in slow)
    print(f"{'delivery':<10}{percentile(delivery, .5):>8.3f}{percentile(delivery, .99):>8.3f}"
          f"{percentile(delivery, .999):>8.3f}{max(delivery):>8.2f}{len(delivery):>7}")
    for part in PARTS:
        vals = [f.parts[part] for f in frames if part in f.parts]
        if not vals:
            continue
        share = sum(f.parts.get(part, 0.0) for f in slow) / slow_total * 100
        print(f"{part:<10}{percentile(vals, .5):>8.3f}{percentile(vals, .99):>8.3f}"
              f"{percentile(vals, .999):>8.3f}{max(vals):>8.2f}{len(vals):>7}   {share:5.1f} %")
    during_delivery(tr, frames, played.roles)
    cpu_by_thread(tr, played)
    late_issues(tr, played.late, played.names, worst)
    slowest = sorted(frames, key=lambda f: f.receive - f.issue)[-worst:]
    slow_writes = [f for f in sorted(frames, key=lambda f: f.parts["write"])[-worst:]
                   if f.parts["write"] > 0.5 and f not in slowest]
    print(f"\nthe {worst} slowest deliveries, and the slowest writes over 0.5 ms:")
    for f in slowest + slow_writes:
        parts = ", ".join(f"{k} {v:.2f}" for k, v in f.parts.items())
        print(f"  {f.perf} at {f.issue:.4f}: {(f.receive - f.issue) * 1000:.2f} ms = {parts}")
        if f.parts["write"] > 0.5:  # the writer left its CPU before its write queued the bytes
            q = f.issue + f.parts["write"] / 1000
            outs = [o for o in tr.switched_out.get(f.tid, []) if f.issue <= o[0] <= q]
            for t, state, cpu in outs:
                ins = [i for i in tr.switched_in.get(f.tid, []) if i >= t]
                back = ins[0] if ins else q
                ran = who_ran(tr, cpu, t, back, played.roles)
                top = sorted(ran.items(), key=lambda kv: -kv[1])[:4]
                print(f"    writer off its CPU {cpu} ({state}) for {(back - t) * 1000:.2f} ms: "
                      + ", ".join(f"{k} {v:.2f}" for k, v in top))
        if f.kw_window is not None and f.kw_cpu is not None and f.parts["kw wait"] > 0.5:
            ran = who_ran(tr, f.kw_cpu, *f.kw_window, played.roles)
            top = sorted(ran.items(), key=lambda kv: -kv[1])[:5]
            print(f"    while the worker waited on CPU {f.kw_cpu}: "
                  + ", ".join(f"{k} {v:.2f}" for k, v in top))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--busy", action="store_true", help="one more process keeps a CPU busy")
    parser.add_argument("--sim", choices=["fifo", "nice", "normal"], default="fifo",
                        help="the simulators' priority (default: SCHED_FIFO 20)")
    parser.add_argument("--no-realtime", action="store_true", help="normal-priority writers")
    parser.add_argument("--worst", type=int, default=6, help="frames to show in detail")
    parser.add_argument("--busy-cpu", type=int, help="pin the busy process to this CPU")
    parser.add_argument("--raise-kworkers", action="store_true",
                        help="an intervention, not a fix: the unbound kernel workers run under "
                        "SCHED_FIFO 5 for the run (root; set back to normal after)")
    parser.add_argument("--relays", action="store_true",
                        help="then play the same robots through 4 relay processes, one robot each")
    parser.add_argument("--only-relays", action="store_true", help="the relays alone")
    parser.add_argument("--processes", action="store_true",
                        help="also one local process per robot (the relays' shape, no Zenoh)")
    parser.add_argument("--lockstep", action="store_true",
                        help="every robot's frames at the same times (as a synced show)")
    parser.add_argument("--before", metavar="REV",
                        help="with --relays: then the relays of revision REV's xgo_show too")
    parser.add_argument("--handoff-us", type=float, default=0.0,
                        help="an experiment: the writers' hand-off after a write (runtime/clock"
                        ".py's HANDOFF, 50 us) in the local processes and relays")
    parser.add_argument("--silent-conductor", action="store_true",
                        help="an experiment: with --relays, then relays whose conductor sends "
                        "nothing during the show (no heartbeats, no clock bursts)")
    parser.add_argument("--variants", nargs="+", default=[], metavar="NAME",
                        help="with --relays: then relays with one thing changed each (an "
                        "experiment; relay_variants.py: no-bookkeeping, plain-clock, "
                        "no-tracer), in turn in the same run")
    parser.add_argument("--rounds", type=int, default=1,
                        help="play the local processes and the relays (every kind asked for) "
                        "in turn this many times, each --seconds long, and print every round's "
                        "figures side by side")
    parser.add_argument("--lock", metavar="FILE",
                        help="hold an exclusive flock on FILE while playing (/work/bench.lock), "
                        "not while working the figures out")
    parser.add_argument("--play-child", metavar="NAME=PTY", help=argparse.SUPPRESS)
    parser.add_argument("--threads-file", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.handoff_us:
        clock.HANDOFF = args.handoff_us * 1e-6
    if args.play_child:
        play_child(args.play_child, args)
        return
    schedule = make_schedule(args)
    print(f"load average {os.getloadavg()[0]:.2f}; sims {args.sim}; writers "
          f"{'normal' if args.no_realtime else 'SCHED_FIFO 10'}; "
          f"{'one CPU busy' if args.busy else 'no extra load'}; {args.seconds:g} s")
    played: list[Played] = []
    groups: list[Group] = []
    lock = contextlib.ExitStack()
    if args.lock:  # held while playing only: the figures are worked out after
        import fcntl

        held = lock.enter_context(open(args.lock, "a+b"))  # noqa: SIM115
        fcntl.flock(held, fcntl.LOCK_EX)
        print(f"{args.lock} taken, load average {os.getloadavg()[0]:.2f}", flush=True)
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        sims = rt.start_sims(tmp, args.sim)
        tracer = Tracer(sims.tids)
        try:
            if not args.only_relays:
                played.append(play_local(args, schedule, sims, tracer))
                print(f"local runner done, load average {os.getloadavg()[0]:.2f}")
            if args.processes:
                groups.append(Processes(args, schedule, sims, tmp))
            if args.relays or args.only_relays:
                groups.append(Relays(args, schedule, sims, tmp, group=len(groups)))
                if args.before:
                    groups.append(Relays(args, schedule, sims, tmp, args.before,
                                         group=len(groups)))
                for variant in args.variants:
                    groups.append(Relays(args, schedule, sims, tmp, variant=variant,
                                         group=len(groups)))
                if args.silent_conductor:
                    groups.append(Relays(args, schedule, sims, tmp, silent=True,
                                         group=len(groups)))
            for g in groups:
                g.open()
            for r in range(args.rounds):
                order = groups[r % len(groups):] + groups[:r % len(groups)] if groups else []
                for g in order:
                    g.play(tracer)
                print(f"round {r + 1} of {args.rounds} done, load average "
                      f"{os.getloadavg()[0]:.2f}", flush=True)
        finally:
            tracer.close()
            for g in groups:
                g.close()
            rt.stop_sims(sims)
            lock.close()
        print(f"played; load average {os.getloadavg()[0]:.2f}", flush=True)
        played.extend(g.played for g in groups if g.played is not None)
        for p in played:
            p.roles.update({tid: f"sim{i}" for i, tid in enumerate(sims.tids)})
        for g in groups:
            for one in g.rounds:
                one.roles.update({tid: f"sim{i}" for i, tid in enumerate(sims.tids)})
        for p in played:
            report(p, schedule, sims, args.worst)
        if args.rounds > 1:
            by_round(groups, schedule, sims)

def late_issues(tr: Trace, late: list[tuple[float, float, int]], names: dict[int, str],
                worst: int) -> None:
    """For the latest issues: what the writer did meanwhile, and which other threads of this
    process were preempted (runnable, off their CPU) while it waited: a thread preempted while
    holding Python's lock keeps a real-time writer waiting for it."""
    print(f"\n{len(late)} writes issued more than 1 ms late; the {worst} latest:")
    for planned, issued, tid in sorted(late, key=lambda x: x[1] - x[0])[-worst:]:
        print(f"  {names.get(tid, tid)} at {planned:.4f}: issued {(issued - planned) * 1000:.2f}"
              " ms late")
        for pid, name in sorted(names.items()):
            for t, state, cpu in tr.switched_out.get(pid, []):
                ins = [i for i in tr.switched_in.get(pid, []) if i >= t]
                back = ins[0] if ins else issued
                if back < planned or t > issued:
                    continue
                if pid != tid and not state.startswith("R"):
                    continue  # another thread that blocked on its own: not in the writer's way
                ran = who_ran(tr, cpu, max(t, planned), min(back, issued))
                top = sorted(ran.items(), key=lambda kv: -kv[1])[:3]
                print(f"    {name} ({'the writer' if pid == tid else 'preempted'}, {state}) off "
                      f"CPU {cpu} {(t - planned) * 1000:+.2f} to {(back - planned) * 1000:+.2f}"
                      " ms: " + ", ".join(f"{k} {v:.2f}" for k, v in top))


if __name__ == "__main__":
    main()
