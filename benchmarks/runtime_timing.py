"""Send-time accuracy of the show runtime vs the vendor library's send-then-sleep loop.

Four simulated XGO robots run in their own processes (``xgo-show simulate --record``), each
on a real pseudo-terminal, timestamping every frame they receive with the machine-wide
monotonic clock. The same four-performer schedule is played by the runtime's ShowRunner
(telemetry on) as the commands play it by default (SCHED_FIFO writer threads where permitted,
docs/realtime.md), by the same runner with ``--no-realtime`` (normal priority: last session's
default), and by a naive loop per port that writes a frame and sleeps the interval to the
next one (the vendor library's pattern), first on a machine left alone and then with one more
process keeping a CPU busy, all in one run. Errors are measured from the simulators' receive
times:

- send-time error: receive time - (start + planned time), per frame: p50, p99, p99.9, max;
- end-of-show drift: median error over the last second - that over the first, per robot;
- issue lateness: when the runner issued each write minus when it was due (its own records):
  the runner's own error;
- delivery: receive time minus issue time, per frame: the pseudo-terminal (a kernel worker of
  normal priority moves the bytes) and the simulator's wake-up, i.e. the measuring instrument.
  send-time error = issue lateness + delivery, so the two columns tell the runner's share
  from the instrument's. A USB serial adapter has no such kernel worker.

The simulators are the instrument: with ``--sim-fifo`` (the default where permitted) each runs
under SCHED_FIFO priority 20, above the writers, standing in for a robot whose UART has a CPU
of its own and is never late; ``--sim-nice`` gives them nice -15 instead (last session's).

``--diagnose`` also plays the show with each suspect of late writes switched on or off, in
the same run: the cyclic garbage collector left on (pauses timed with ``gc.callbacks``), no
telemetry (no reader threads, no polls), a real-time writer's hand-off after each write
(:func:`~xgo_show.runtime.clock.hand_off_cpu`) of 0, 0.2 and 0.5 ms instead of 0.05, nice -10
instead of real time, and without the writers' final spin (at normal priority). For each it
counts the writes issued more than 1 ms late, how many of those came in bursts where three or
more writers were late together (a stall of the whole process: the collector, the GIL held,
the process off its CPU), the collector's pauses, and the process's involuntary context
switches (the OS taking its CPU).

``--suspects`` plays the README demo's situation instead (robots in lock-step, simulators
served by threads of this process as dry-run serves them, the live progress table drawn as on
a terminal, telemetry on, the collector held), then each suspect switched alone (the
collector, the progress display, telemetry, one CPU kept busy, the simulators in processes of
their own), each of session 9's cuts undone alone (the early wake-up, progress after an
instant) and the CPUs kept out of idle states (PM QoS, root), all in one run, with the VM's
own CPU stalls beside (trigger_latency.py's probe).

Prints figures only (no asserts). Usage::

    python benchmarks/runtime_timing.py [--seconds 60] [--rate 50] [--no-load | --only-load]
                                        [--sim-nice] [--diagnose] [--lockstep]
                                        [--suspects [ROWS]]

``--lockstep`` puts every robot's frames at the same times, as a show's grid does (the README
demo's five robots); by default they are 3.7 ms apart, which spares the writers the hand-overs
of Python's lock that frames due together cost (docs/realtime.md).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import gc
import io
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.profiles import get_profile
from xgo_show.runtime import clock as clock_module
from xgo_show.runtime import realtime, show_runner
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.events import Event, FrameSent, ProgressTick
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.report import ProgressPrinter, percentile
from xgo_show.sim.pty_server import PtyServer
from xgo_show.transports import open_transport
from xgo_show.transports.base import Transport
from xgo_show.wire.xgo import TYPE_READ, write_frame

MODEL = "mini"
ROBOTS = 4


@dataclass
class Sims:
    procs: list[subprocess.Popen[str]]
    paths: list[str]
    records: list[Path]
    priority: str
    tids: list[int]  # each simulator's serving thread
    servers: list[PtyServer] = field(default_factory=list)  # in this process (``inproc``)

    def received(self) -> list[list[tuple[float, bytes]]]:
        """Each simulator's receive records: (monotonic time, frame bytes)."""
        if self.servers:
            return [[(f.t, bytes(f.data)) for f in server.robot.received]
                    for server in self.servers]
        return [read_records(record) for record in self.records]


SIM_FIFO = 20  # the simulators' SCHED_FIFO priority with --sim-fifo: above the writers' 10


def serve_sim(record: Path, mode: str) -> None:
    """Child process: serve one simulator on a pty until stdin closes.

    ``mode`` is the simulator's priority: ``fifo`` (SCHED_FIFO 20; its serving thread blocks
    in poll() until bytes arrive, so it takes no CPU from the kernel worker that moves them),
    ``nice`` (nice -15) or ``normal``. It has a process (and a GIL) of its own.
    """
    from xgo_show.sim import PtyServer, create_robot

    priority = "normal-priority"
    try:
        if mode == "fifo":
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(SIM_FIFO))
            priority = f"SCHED_FIFO-{SIM_FIFO}"
        elif mode == "nice":
            os.nice(-15)
            priority = "nice-15"
    except OSError:
        pass
    with PtyServer(create_robot(MODEL), record=record) as server:
        # The serving thread's id (the only thread but this one), for tracing it.
        tids = [int(t) for t in os.listdir("/proc/self/task") if int(t) != os.getpid()]
        print(priority, server.path, ",".join(map(str, tids)), flush=True)
        sys.stdin.read()


def start_sims(tmp: Path, mode: str) -> Sims:
    if mode == "inproc":
        # As dry-run serves them: threads of this process, normal priority, nothing recorded
        # to a file (each robot keeps what it received, with its receive time).
        from xgo_show.sim import create_robot

        servers = [PtyServer(create_robot(MODEL)).start() for _ in range(ROBOTS)]
        return Sims([], [sv.path for sv in servers], [], "in this process, normal priority",
                    [], servers)
    procs, paths, records, priority, tids = [], [], [], "", []
    for i in range(ROBOTS):
        record = tmp / f"robot{i}.jsonl"
        proc = subprocess.Popen(
            [sys.executable, __file__, "--serve-sim", str(record), "--sim-mode", mode],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert proc.stdout is not None
        words = proc.stdout.readline().split()
        if len(words) != 3:
            raise SystemExit(f"simulator {i} did not start: {words!r}")
        priority = words[0]
        procs.append(proc)
        paths.append(words[1])
        records.append(record)
        tids.append(int(words[2].split(",")[0]))
    return Sims(procs, paths, records, priority, tids)


def stop_sims(sims: Sims) -> None:
    for server in sims.servers:
        server.close()
    for proc in sims.procs:
        assert proc.stdin is not None
        proc.stdin.close()
    for proc in sims.procs:
        proc.wait(10)


class RaisedWorkers:
    """While entered: every unbound kernel worker (``kworker/u*``, the threads that move a
    pseudo-terminal's bytes) runs under SCHED_FIFO ``priority``; set back to normal after.

    An intervention for measuring, not a fix (root only; it changes the whole machine while
    it lasts): it shows what the robot would receive if the pty's worker never waited for a
    CPU, as a USB serial adapter's write needs no worker. The pool starts new workers when
    it needs them, so a child process looks again every 0.1 s (a thread of this process
    would hold Python's lock while it reads /proc, and make the writers wait for it).
    """

    def __init__(self, priority: int = 5) -> None:
        self.priority = priority
        self.raised = 0
        self._proc: subprocess.Popen[str] | None = None

    def __enter__(self) -> RaisedWorkers:
        self._proc = subprocess.Popen(
            [sys.executable, __file__, "--raise-workers-child", str(self.priority)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self._proc.stdout is not None
        if not self._proc.stdout.readline().strip().isdigit():
            raise SystemExit("could not raise the kernel workers (needs root)")
        return self

    def __exit__(self, *exc: object) -> None:
        assert self._proc is not None and self._proc.stdin is not None
        assert self._proc.stdout is not None
        self._proc.stdin.close()
        self.raised = int(self._proc.stdout.read().strip() or 0)
        self._proc.wait(10)


def raise_workers_child(priority: int) -> None:
    """Child process of :class:`RaisedWorkers`: raise, look again every 0.1 s until stdin
    closes, set every one back, print how many were raised."""
    raised: set[int] = set()
    done = threading.Event()

    def scan() -> None:
        for pid in os.listdir("/proc"):
            if not pid.isdigit() or int(pid) in raised:
                continue
            try:
                if Path(f"/proc/{pid}/comm").read_text().startswith("kworker/u"):
                    os.sched_setscheduler(int(pid), os.SCHED_FIFO, os.sched_param(priority))
                    raised.add(int(pid))
            except OSError:  # gone, or not permitted
                continue

    def watch_stdin() -> None:
        sys.stdin.read()
        done.set()

    scan()
    print(len(raised) if raised else "refused", flush=True)
    threading.Thread(target=watch_stdin, daemon=True).start()
    while not done.wait(0.1):
        scan()
    for pid in raised:
        with contextlib.suppress(OSError):
            os.sched_setscheduler(pid, os.SCHED_OTHER, os.sched_param(0))
    print(len(raised), flush=True)


def make_schedule(seconds: float, rate: float, *, lockstep: bool = False) -> Schedule:
    profile = get_profile(MODEL)
    reg = profile.register("body_z")
    performers = []
    for i in range(ROBOTS):
        # Each robot gets its own phase so the four ports are not written in lock-step, unless
        # ``lockstep``: every robot's frames at the same times, as a show's grid puts them.
        phase = 0.0 if lockstep else i * 0.0037
        n = int(seconds * rate)
        frames = tuple(
            ScheduledFrame(
                phase + k / rate,
                write_frame(reg.address, bytes((0x40 + (k % 128),)), write_type=profile.write_type),
            )
            for k in range(n)
        )
        performers.append(
            PerformerSchedule(f"robot{i}", MODEL, profile.link, frames, end=frames[-1].t + 0.05)
        )
    return Schedule("timing benchmark", "-", tuple(performers), rate)


@dataclass
class Variant:
    """One way of playing the show with our runner: which suspects are switched off."""

    name: str
    hold_gc: bool = True
    telemetry: bool = True
    realtime: bool = True  # the default: SCHED_FIFO writers (False: --no-realtime)
    nice: int = 0  # this thread's nice value during the show (the writers inherit it)
    clock: MonotonicClock | None = None
    handoff: float | None = None  # seconds a real-time writer sleeps after a write
    raise_workers: bool = False  # the pty's kernel workers under SCHED_FIFO (RaisedWorkers)
    helpers: bool = True  # readers and the supervising thread raised too (False: writers only)
    progress: str = "none"  # the progress display: "live" (a terminal's), "lines" or "none"
    busy: bool = False  # one more process keeps a CPU busy during this row only
    early: float | None = None  # clock.EARLY: a real-time wait's last part on the CPU (s)
    awake: bool = False  # idle CPUs kept out of idle states for the row (cpus_awake)
    aligned: bool | None = None  # progress published just after a grid instant (or not)


@dataclass
class OursRun:
    starts: dict[str, float]
    issued: list[tuple[float, str, float]]  # (clock time, performer, issue lateness ms)
    sends: dict[str, list[float]]  # per performer, each schedule frame's issue time
    gc_pauses: list[float]  # seconds each collection took
    gc_late: int  # writes issued > 1 ms late while or just after a collection ran
    involuntary: int  # involuntary context switches of this process during the show
    policy: str


LATE_MS = 1.0  # a write issued later than this counts as late


def run_ours(schedule: Schedule, links: dict[str, Transport], variant: Variant) -> OursRun:
    """Play ``schedule`` with our runner as ``variant`` says; what the runner's own records
    and this process tell about it (see :class:`OursRun`)."""
    runner = local_runner(schedule, links, clock=variant.clock or MonotonicClock(),
                          hold_gc=variant.hold_gc, telemetry=variant.telemetry)
    issued: list[tuple[float, str, float]] = []
    sends: dict[str, list[float]] = {name: [] for name in links}
    pauses: list[tuple[float, float]] = []
    began: list[float] = []

    def on_frame(event: Event) -> None:
        if isinstance(event, FrameSent) and event.kind == "frame" and event.error is not None:
            issued.append((event.t, event.performer, event.error * 1000.0))
            sends[event.performer].append(event.t)

    def on_gc(phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            began.append(time.monotonic())
        elif began:
            pauses.append((began.pop(), time.monotonic()))

    runner.events.subscribe(on_frame, FrameSent)
    live = None
    if variant.progress == "live":  # what a terminal shows: rich redraws the table 4 times/s
        from xgo_show.cli.live import LiveView

        live = LiveView(schedule, _Terminal())
        runner.events.subscribe(live.on_event, ProgressTick)
    elif variant.progress == "lines":  # standard output not a terminal: a line every 2 s
        runner.events.subscribe(ProgressPrinter(out=_Terminal(), tty=False).on_event,
                                ProgressTick)
    saved, handoff = realtime.policy(), clock_module.HANDOFF
    early, after = clock_module.EARLY, show_runner.PROGRESS_AFTER
    if variant.aligned is not None:
        show_runner.PROGRESS_AFTER = 0.001 if variant.aligned else None
    if variant.handoff is not None:
        clock_module.HANDOFF = variant.handoff
    if variant.early is not None:
        clock_module.EARLY = variant.early
    # As the commands do: the writer threads raise themselves; this thread stays normal.
    policy = realtime.configure("required" if variant.realtime else "off").summary
    if variant.nice:
        try:  # Linux: this thread and the threads it starts
            os.setpriority(os.PRIO_PROCESS, 0, variant.nice)
        except OSError:  # a higher priority needs root or CAP_SYS_NICE
            policy = f"nice {variant.nice} refused"
        else:
            policy = f"nice {os.getpriority(os.PRIO_PROCESS, 0)}"
    gc.callbacks.append(on_gc)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_nivcsw
    workers = RaisedWorkers() if variant.raise_workers else contextlib.nullcontext()
    try:
        with (workers, writers_only(not variant.helpers), busy_cpu(variant.busy),
              cpus_awake(variant.awake)):
            result = runner.run(lead=0.3, handle_signals=False)
    finally:
        involuntary = resource.getrusage(resource.RUSAGE_SELF).ru_nivcsw - before
        gc.callbacks.remove(on_gc)
        realtime.restore(saved)
        clock_module.HANDOFF = handoff
        clock_module.EARLY, show_runner.PROGRESS_AFTER = early, after
        if live is not None:
            live.finish()
        if variant.nice:
            os.setpriority(os.PRIO_PROCESS, 0, 0)
    if not result.completed:
        raise SystemExit(f"our run did not complete: {result.reason}")
    if not variant.helpers:
        policy += "; readers and supervisor normal"
    if isinstance(workers, RaisedWorkers):
        policy += f"; {workers.raised} pty workers SCHED_FIFO {workers.priority}"
    # Only collections while the show played (the runner's own gc.collect() before it starts
    # and the one after it ends are no stall of a write).
    first, last = result.start_at, max((t for t, _, _ in issued), default=result.start_at)
    pauses = [(a, b) for a, b in pauses if b >= first and a <= last]
    late = [t for t, _, err in issued if err > LATE_MS]
    gc_late = sum(1 for t in late
                  if any(a <= t - LATE_MS / 1000 <= b + 0.002 or a <= t <= b for a, b in pauses))
    return OursRun({name: result.start_at for name in links}, issued, sends,
                   [b - a for a, b in pauses], gc_late, involuntary, policy)


class _Terminal(io.StringIO):
    """A terminal that keeps nothing: what a progress display draws on, as on a user's."""

    def isatty(self) -> bool:
        return True

    def write(self, text: str) -> int:
        return len(text)


@contextlib.contextmanager
def cpus_awake(active: bool) -> Iterator[None]:
    """While entered (if ``active``): Linux's PM QoS device held at 0 us, so that idle CPUs
    poll instead of halting (on this VM: instead of leaving the CPU to the hypervisor). A
    measurement (root only, the whole machine): the runtime does not do it (docs/realtime.md
    says why)."""
    if not active:
        yield
        return
    try:
        fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY)
    except OSError as exc:
        raise SystemExit(f"cannot keep the CPUs awake: {exc}") from exc
    try:
        os.write(fd, (0).to_bytes(4, sys.byteorder))
        yield
    finally:
        os.close(fd)


@contextlib.contextmanager
def busy_cpu(active: bool) -> Iterator[None]:
    """While entered (if ``active``): one more process keeps a CPU busy (normal priority,
    started from this thread, which is of normal priority too)."""
    if not active:
        yield
        return
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.2)
        yield
    finally:
        busy.kill()
        busy.wait()


@contextlib.contextmanager
def writers_only(active: bool) -> Iterator[None]:
    """While entered (if ``active``): only the writers are raised, as before the readers and
    the supervising thread were (the benchmark swaps the function the runtime calls)."""
    if not active:
        yield
        return
    from xgo_show.runtime import executor, show_runner

    def enter(priority: int = realtime.PRIORITY) -> bool:
        return priority == realtime.PRIORITY and realtime.enter_show_thread(priority)

    name = "enter_show_thread"  # each module's own reference to realtime's function
    saved = [(mod, getattr(mod, name)) for mod in (executor, show_runner)]
    for mod, _ in saved:
        setattr(mod, name, enter)
    try:
        yield
    finally:
        for mod, original in saved:
            setattr(mod, name, original)


def bursts(issued: list[tuple[float, str, float]], writers: int = 3) -> int:
    """Late writes that came with late writes of ``writers``-1 other performers within 2 ms of
    them: the whole process stalled rather than one thread."""
    late = sorted((t, name) for t, name, err in issued if err > LATE_MS)
    count = 0
    for i, (t, _) in enumerate(late):
        near = {name for u, name in late[max(0, i - 8):i + 9] if abs(u - t) <= 0.002}
        count += len(near) >= writers
    return count


def run_naive(schedule: Schedule, links: dict[str, Transport]) -> dict[str, float]:
    """Per port: write, then sleep until the next frame's offset from this one."""
    start = time.monotonic() + 0.3
    starts: dict[str, float] = {}

    def loop(perf: PerformerSchedule) -> None:
        link = links[perf.name]
        frames = perf.frames
        starts[perf.name] = start
        time.sleep(max(0.0, start + frames[0].t - time.monotonic()))
        for k, frame in enumerate(frames):
            link.write(frame.data)
            if k + 1 < len(frames):
                time.sleep(frames[k + 1].t - frame.t)

    threads = [threading.Thread(target=loop, args=(p,)) for p in schedule.performers]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    return starts


def read_records(path: Path) -> list[tuple[float, bytes]]:
    out = []
    with path.open(encoding="utf-8") as fh:
        for line in fh:
            if line.strip():
                rec = json.loads(line)
                out.append((float(rec["t"]), bytes.fromhex(rec["hex"])))
    return out


def measure(
    schedule: Schedule,
    records: dict[str, list[tuple[float, bytes]]],
    window: tuple[float, float],
    starts: dict[str, float],
    rate: float,
    sends: dict[str, list[float]] | None = None,
) -> tuple[list[float], list[float], list[float]]:
    """(all send-time errors, per-robot drift, deliveries: receive - issue time where ``sends``
    gives the issue times), in ms, for frames received in ``window``."""
    errors: list[float] = []
    drifts: list[float] = []
    deliveries: list[float] = []
    wanted = {bytes(f.data) for p in schedule.performers for f in p.frames}
    for perf in schedule.performers:
        got = [
            t
            for t, data in records[perf.name]
            if window[0] <= t < window[1] and data[3] != TYPE_READ and data in wanted
        ]
        if len(got) != len(perf.frames):
            print(f"  warning: {perf.name}: {len(got)} of {len(perf.frames)} frames received")
        errs = [
            (t - (starts[perf.name] + f.t)) * 1000.0
            for t, f in zip(got, perf.frames, strict=False)
        ]
        errors.extend(errs)
        if sends is not None:
            deliveries += [(t - s) * 1000.0 for t, s in zip(got, sends[perf.name], strict=False)]
        if errs:
            # Drift: median error of the last second minus that of the first (single frames
            # carry jitter; drift is what accumulates).
            n = max(1, min(len(errs) // 4, int(rate)))
            drifts.append(percentile(errs[-n:], 0.5) - percentile(errs[:n], 0.5))
    return errors, drifts, deliveries


def variants(diagnose: bool, raise_workers: bool) -> list[Variant]:
    out = [Variant("ours (default)"), Variant("ours --no-realtime", realtime=False)]
    out.append(Variant("  writers only raised", helpers=False))
    if raise_workers:
        out.append(Variant("  pty workers raised", raise_workers=True))
    if diagnose:
        out += [
            Variant("  gc on (no hold)", hold_gc=False),
            Variant("  no telemetry", telemetry=False),
            Variant("  hand-off 0", handoff=0.0),
            Variant("  hand-off 0.2 ms", handoff=0.0002),
            Variant("  hand-off 0.5 ms", handoff=0.0005),
            Variant("  no-rt, nice -10", realtime=False, nice=-10),
            Variant("  no-rt, no final spin", realtime=False,
                    clock=MonotonicClock(aim=0.0, spin=0.0)),
        ]
    return out


def suspects(rows: str) -> list[Variant]:
    """``--suspects``: the README demo's situation (robots in lock-step, simulators served by
    threads of this process as dry-run serves them, its live progress table drawn 4 times a
    second, telemetry on, the collector held), then one suspect of late writes switched at a
    time (the collector, the progress display, telemetry, the OS with one CPU busy) and each
    cut undone alone (the early wake-up, progress after an instant) or the CPUs kept out of
    idle states, then the same again. ``rows`` adds rows (comma-separated: ``early=MS``,
    ``aligned``, ``unaligned``, ``awake``); ``only:ROWS`` plays only those."""
    base = Variant("the demo's situation", progress="live")
    only = rows.startswith("only:")
    rows = rows.removeprefix("only:")
    out = [] if only else [
        base,
        dataclasses.replace(base, name="  gc not held", hold_gc=False),
        dataclasses.replace(base, name="  progress as lines", progress="lines"),
        dataclasses.replace(base, name="  no progress display", progress="none"),
        dataclasses.replace(base, name="  no telemetry", telemetry=False),
        dataclasses.replace(base, name="  one CPU busy", busy=True),
        dataclasses.replace(base, name="  no early wake-up", early=0.0),
        dataclasses.replace(base, name="  progress unaligned", aligned=False),
        dataclasses.replace(base, name="  CPUs kept awake", awake=True),
    ]
    for row in filter(None, rows.split(",")):
        key, _, value = row.partition("=")
        if key == "early":
            out.append(dataclasses.replace(base, name=f"  early {value} ms",
                                           early=float(value) / 1000))
        elif key in ("aligned", "unaligned"):
            out.append(dataclasses.replace(base, name=f"  progress {key}",
                                           aligned=key == "aligned"))
        elif key == "awake":
            out.append(dataclasses.replace(base, name="  CPUs kept awake", awake=True))
        else:
            raise SystemExit(f"--suspects: unknown row {row!r}")
    if not only:
        out.append(dataclasses.replace(base, name="the demo's again"))
    return out


def p(errs: list[float], q: float) -> float:
    return percentile([abs(e) for e in errs], q)


def play(schedule: Schedule, links: dict[str, Transport], sims: Sims,
         plays: list[Variant | None], diagnose: bool, stalls: Path | None = None) -> None:
    """Play the show once per entry (None: the naive loop) and print one row each."""
    windows: list[tuple[Variant | None, float, float, dict[str, float], OursRun | None,
                        float]] = []
    for variant in plays:
        t0 = time.monotonic()
        if variant is None:
            run, starts = None, run_naive(schedule, links)
        else:
            run = run_ours(schedule, links, variant)
            starts = run.starts
        time.sleep(0.3)
        # The 1-minute load average as the row ends: about the row's own minute.
        windows.append((variant, t0, time.monotonic(), starts, run, os.getloadavg()[0]))
    time.sleep(0.2)  # the simulators' last records reach their files
    got = {perf.name: received
           for perf, received in zip(schedule.performers, sims.received(), strict=True)}
    for variant, t0, t1, starts, run, load in windows:
        errs, drifts, delivery = measure(schedule, got, (t0, t1), starts, schedule.control_rate,
                                         None if run is None else run.sends)
        name = "naive (write, sleep)" if variant is None else variant.name
        line = (f"{name:<22} {load:>4.1f} | {p(errs, 0.5):>7.3f} {p(errs, 0.99):>7.3f}"
                f" {p(errs, 0.999):>7.3f} {p(errs, 1.0):>7.2f} {max(abs(d) for d in drifts):>6.2f}")
        if run is not None:
            issued = [e for _, _, e in run.issued]
            line += (f" | {p(issued, 0.5):>6.3f} {p(issued, 0.99):>6.3f} {p(issued, 0.999):>7.3f}"
                     f" {p(issued, 1.0):>6.2f} | {p(delivery, 0.99):>7.3f}"
                     f" {p(delivery, 0.999):>7.3f} {p(delivery, 1.0):>7.2f}")
            if diagnose:
                late = sum(1 for e in issued if e > LATE_MS)
                gcs = (f"{len(run.gc_pauses)}/{max(run.gc_pauses) * 1000:.1f}"
                       if run.gc_pauses else "0")
                line += (f" |{late:>5}{bursts(run.issued):>6}{run.gc_late:>4} {gcs:>8}"
                         f"{run.involuntary:>7}")
            if stalls is not None:
                # trigger_latency's probe and record (imported once the rows are played: it
                # imports Zenoh, which has no business in the process measured)
                from trigger_latency import read_stalls

                line += " | " + stalled(read_stalls(stalls), t0, t1, run.issued)
            if variant is not None:
                line += f"  ({run.policy})"
        print(line)


def stalled(stalls: list[tuple[int, float, float]], t0: float, t1: float,
            issued: list[tuple[float, str, float]]) -> str:
    """The CPU stalls the probe saw within [t0, t1] (count, longest ms) and how many of the
    writes issued over 1 ms late were due while a CPU stood still."""
    mine = [(a, b) for _, a, b in stalls if a < t1 and b > t0]
    late = [(t - err / 1000, t) for t, _, err in issued if err > LATE_MS]
    hit = sum(1 for due, t in late if any(a < t and b > due for a, b in mine))
    longest = max((b - a for a, b in mine), default=0.0) * 1000
    return f"{len(mine):>3} {longest:>6.1f} {len(late):>5} {hit:>5}"


def header(diagnose: bool, *, stalls: bool = False) -> None:
    print(f"{'':<22}{'load':>5} |{'send-time error (receive - planned)':^39} |"
          f"{'issue lateness':^29} |{'delivery (pty+sim)':^24} |")
    line = (f"{'ms':<22}{'avg':>5} |{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>8}{'drift':>7}"
            f" |{'p50':>7}{'p99':>7}{'p99.9':>8}{'max':>7} |{'p99':>8}{'p99.9':>8}{'max':>8}")
    if diagnose:
        line += f" |{'>1ms':>5}{'burst':>6}{'gc':>4}{'gc n/max':>9}{'invol':>7}"
    if stalls:
        line += f" |{'stall':>4}{'max':>7}{'>1ms':>6}{'in st':>6}"
    print(line)


def on_sims(schedule: Schedule, tmp: Path, mode: str, plays: list[Variant | None],
            diagnose: bool, stalls: Path | None = None) -> None:
    """Start simulators of priority ``mode``, play ``plays`` on them, stop them."""
    sims = start_sims(tmp, mode)
    links: dict[str, Transport] = {}
    try:
        for perf, path in zip(schedule.performers, sims.paths, strict=True):
            links[perf.name] = open_transport(path, baudrate=perf.link.baud)
            links[perf.name].open()
        print(f"   (simulators: {sims.priority})")
        play(schedule, links, sims, plays, diagnose, stalls)
    finally:
        for link in links.values():
            link.close()
        stop_sims(sims)


def run_suspects(args: argparse.Namespace) -> None:
    """``--suspects``: one row per suspect switched, the demo's situation before and after."""
    schedule = make_schedule(args.seconds, args.rate, lockstep=True)
    print(f"{ROBOTS} simulated {MODEL}s on ptys, {args.rate:g} frames/s each in lock-step for "
          f"{args.seconds:g} s per row; {os.cpu_count()} CPUs; load average "
          f"{os.getloadavg()[0]:.2f} at the start")
    header(False, stalls=True)
    with tempfile.TemporaryDirectory() as tmpdir:
        # The VM's own stalls (a CPU that stands still: the hypervisor), seen by a probe of
        # trigger_latency.py: a SCHED_FIFO 30 thread per CPU waking every ms.
        record = Path(tmpdir) / "stalls.txt"
        probe = subprocess.Popen(
            [sys.executable, str(Path(__file__).with_name("trigger_latency.py")),
             "--stall-probe", str(record)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            text=True)
        assert probe.stdout is not None and probe.stdin is not None
        probe.stdout.readline()
        try:
            on_sims(schedule, Path(tmpdir), "inproc", [*suspects(args.suspects)], False, record)
            if not args.suspects.startswith("only:"):
                on_sims(schedule, Path(tmpdir), "normal",
                        [Variant("  sims in own processes", progress="live")], False, record)
        finally:
            probe.stdin.close()
            probe.wait(10)
    print("\nstall: CPU stalls of 2 ms or more during the row, max the longest (ms); "
          ">1ms: writes issued over 1 ms late, in st: those due while a CPU stood still.")
    print("send-time error: the simulators' receive times (in this process but the last "
          "row); issue lateness: the runner's own. load avg: the 1-minute load average as the "
          "row ended.")
    print(f"load average at the end: {os.getloadavg()[0]:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="show length per run")
    parser.add_argument("--rate", type=float, default=50.0, help="frames per second per robot")
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--no-load", action="store_true", help="only with no CPU kept busy")
    which.add_argument("--only-load", action="store_true", help="only with one CPU kept busy")
    parser.add_argument("--diagnose", action="store_true",
                        help="also play with each suspect of late writes switched off")
    parser.add_argument("--sim", choices=["fifo", "nice", "normal"], default="fifo",
                        help="the simulators' priority: SCHED_FIFO 20 (default), nice -15, or "
                        "normal")
    parser.add_argument("--compare-sim", action="store_true",
                        help="also play the default with normal-priority simulators")
    parser.add_argument("--raise-workers", action="store_true",
                        help="also play the default with the pty's kernel workers under "
                        "SCHED_FIFO 5 (root; an intervention that shows their share)")
    parser.add_argument("--lockstep", action="store_true",
                        help="every robot's frames at the same times, as a show's grid puts "
                        "them (default: 3.7 ms apart)")
    parser.add_argument("--suspects", nargs="?", const="", metavar="ROWS",
                        help="the README demo's situation (lock-step, simulators in this "
                        "process, live progress table), then each suspect of late writes "
                        "switched alone, in one run (ROWS: extra rows, e.g. early=0.2,awake)")
    parser.add_argument("--serve-sim", metavar="RECORD", help=argparse.SUPPRESS)
    parser.add_argument("--sim-mode", default="fifo", help=argparse.SUPPRESS)
    parser.add_argument("--raise-workers-child", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.raise_workers_child is not None:
        raise_workers_child(args.raise_workers_child)
        return
    if args.serve_sim:
        serve_sim(Path(args.serve_sim), args.sim_mode)
        return
    if args.suspects is not None:
        run_suspects(args)
        return
    schedule = make_schedule(args.seconds, args.rate, lockstep=args.lockstep)
    loads = [False] if args.no_load else [True] if args.only_load else [False, True]
    print(f"{ROBOTS} simulated {MODEL}s on ptys, {args.rate:g} frames/s each "
          f"({'in lock-step' if args.lockstep else '3.7 ms apart'}) for "
          f"{args.seconds:g} s per row; {os.cpu_count()} CPUs; load average "
          f"{os.getloadavg()[0]:.2f} at the start")
    with tempfile.TemporaryDirectory() as tmpdir:
        # The simulators and the load start before this process changes its scheduling: a
        # child inherits SCHED_FIFO and nice values, and a SCHED_FIFO busy loop would take a
        # whole CPU from the kernel workers that move pty data and from the simulators.
        for loaded in loads:
            busy = None
            if loaded:
                busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            try:
                print(f"\n-- {'one CPU kept busy' if loaded else 'no extra load'}; load "
                      f"average {os.getloadavg()[0]:.2f}")
                header(args.diagnose)
                plays: list[Variant | None] = [*variants(args.diagnose, args.raise_workers),
                                               None]
                on_sims(schedule, Path(tmpdir), args.sim, plays, args.diagnose)
                if args.compare_sim and args.sim != "normal":
                    on_sims(schedule, Path(tmpdir), "normal",
                            [Variant("  simulators normal")], args.diagnose)
            finally:
                if busy is not None:
                    busy.kill()
                    busy.wait()
    print("\ntargets for ours: send-time error p99 <= 0.5 ms, p99.9 <= 2 ms, drift <= 1 ms "
          "(with one CPU busy). load avg: the 1-minute load average as the row ended.")
    if args.diagnose:
        print("Issued late: >1ms counts writes issued over 1 ms late, burst those of them "
              "with 3+ writers late within 2 ms, gc those during or just after a collection; "
              "gc n/max: collections and the longest (ms); invol: involuntary context "
              "switches")
    print(f"load average at the end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
