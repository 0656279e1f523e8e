"""Send-time accuracy of the show runtime vs the vendor library's send-then-sleep loop.

Four simulated XGO robots run in their own processes (``xgo-show simulate --record``), each
on a real pseudo-terminal, timestamping every frame they receive with the machine-wide
monotonic clock. One more process keeps a CPU busy. The same four-performer schedule is played
twice in one run, first by the runtime's ShowRunner (telemetry on),
then by a naive loop per port that writes a frame and sleeps the interval to the next one (the
vendor library's pattern). Errors are measured from the simulators' receive times:

- send-time error: receive time - (start + planned time), per frame;
- end-of-show drift: median error over the last second - that over the first, per robot.

Prints figures only (no asserts). Usage::

    python benchmarks/runtime_timing.py [--seconds 60] [--rate 50] [--no-load]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.events import Event, FrameSent
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.preflight import request_realtime
from xgo_show.runtime.report import percentile
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


def serve_sim(record: Path) -> None:
    """Child process: serve one simulator on a pty until stdin closes.

    The simulator stands in for a robot's UART, which is never late: it asks for a high
    priority (nice -15) so that the measurement is not the simulator waiting for a CPU, and has
    a process (and a GIL) of its own. Not SCHED_FIFO: a real-time simulator polling every 2 ms
    starves the kernel worker that moves pty data, which then arrives tens of ms late.
    """
    from xgo_show.sim import PtyServer, create_robot

    try:
        os.nice(-15)
        priority = "nice-15"
    except OSError:
        priority = "normal-priority"
    with PtyServer(create_robot(MODEL), record=record) as server:
        print(priority, server.path, flush=True)
        sys.stdin.read()


def start_sims(tmp: Path) -> Sims:
    procs, paths, records, priority = [], [], [], ""
    for i in range(ROBOTS):
        record = tmp / f"robot{i}.jsonl"
        proc = subprocess.Popen(
            [sys.executable, __file__, "--serve-sim", str(record)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert proc.stdout is not None
        words = proc.stdout.readline().split()
        if len(words) != 2:
            raise SystemExit(f"simulator {i} did not start: {words!r}")
        priority = words[0]
        procs.append(proc)
        paths.append(words[1])
        records.append(record)
    return Sims(procs, paths, records, priority)


def stop_sims(sims: Sims) -> None:
    for proc in sims.procs:
        assert proc.stdin is not None
        proc.stdin.close()
    for proc in sims.procs:
        proc.wait(10)


def make_schedule(seconds: float, rate: float) -> Schedule:
    profile = get_profile(MODEL)
    reg = profile.register("body_z")
    performers = []
    for i in range(ROBOTS):
        # Each robot gets its own phase so the four ports are not written in lock-step.
        phase = i * 0.0037
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


def run_ours(
    schedule: Schedule, links: dict[str, Transport], *, hold_gc: bool = True
) -> tuple[dict[str, float], list[float]]:
    """Each performer's start time (monotonic time of show time 0), and the issue errors.

    Issue error (ms): when the runner issued each schedule frame's write minus when it was due,
    from the runner's own records. Against the receive-time error it tells our lateness apart
    from the time the bytes spent in the kernel (pty or serial driver) and the simulator.
    """
    runner = local_runner(schedule, links, clock=MonotonicClock(), hold_gc=hold_gc)
    issued: list[float] = []

    def on_frame(event: Event) -> None:
        if isinstance(event, FrameSent) and event.kind == "frame" and event.error is not None:
            issued.append(event.error * 1000.0)

    runner.events.subscribe(on_frame, FrameSent)
    result = runner.run(lead=0.3, handle_signals=False)
    if not result.completed:
        raise SystemExit(f"our run did not complete: {result.reason}")
    return {name: result.start_at for name in links}, issued


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
) -> tuple[list[float], list[float]]:
    """(all send-time errors in ms, per-robot drift in ms) for frames received in ``window``."""
    errors: list[float] = []
    drifts: list[float] = []
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
        if errs:
            # Drift: median error of the last second minus that of the first (single frames
            # carry jitter; drift is what accumulates).
            n = max(1, min(len(errs) // 4, int(rate)))
            drifts.append(percentile(errs[-n:], 0.5) - percentile(errs[:n], 0.5))
    return errors, drifts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="show length per run")
    parser.add_argument("--rate", type=float, default=50.0, help="frames per second per robot")
    parser.add_argument("--no-load", action="store_true", help="do not keep a CPU busy")
    parser.add_argument(
        "--realtime",
        action="store_true",
        help="ask SCHED_FIFO for this process (both the runtime and the naive loop get it)",
    )
    parser.add_argument(
        "--nice",
        type=int,
        default=0,
        help="run this process at this nice value (e.g. -10; both loops get it)",
    )
    parser.add_argument(
        "--gc-on",
        action="store_true",
        help="leave Python's cyclic garbage collector on during our run (the runner holds it)",
    )
    parser.add_argument("--serve-sim", metavar="RECORD", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serve_sim:
        serve_sim(Path(args.serve_sim))
        return
    schedule = make_schedule(args.seconds, args.rate)
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmpdir:
        # The simulators and the load start before this process changes its scheduling: a
        # child inherits SCHED_FIFO and nice values, and a SCHED_FIFO busy loop would take a
        # whole CPU from the kernel workers that move pty data and from the simulators.
        sims = start_sims(Path(tmpdir))
        busy = None
        if not args.no_load:
            busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
        realtime = request_realtime() if args.realtime else "normal priority"
        if args.nice:
            os.nice(args.nice)
            realtime += f", nice {args.nice}"
        links: dict[str, Transport] = {}
        try:
            for perf, path in zip(schedule.performers, sims.paths, strict=True):
                links[perf.name] = open_transport(path, baudrate=perf.link.baud)
                links[perf.name].open()
            print(
                f"{ROBOTS} simulated {MODEL}s on ptys ({sims.priority} simulator processes), "
                f"{args.rate:g} frames/s each for {args.seconds:g} s; CPU load: "
                f"{'none' if busy is None else '1 busy process'}; {os.cpu_count()} CPUs; "
                f"this process: {realtime}"
            )
            t0 = time.monotonic()
            ours_starts, ours_issued = run_ours(schedule, links, hold_gc=not args.gc_on)
            time.sleep(0.3)
            t1 = time.monotonic()
            naive_starts = run_naive(schedule, links)
            time.sleep(0.3)
            t2 = time.monotonic()
        finally:
            if busy is not None:
                busy.kill()
                busy.wait()
            for link in links.values():
                link.close()
            stop_sims(sims)
        records = {
            perf.name: read_records(record)
            for perf, record in zip(schedule.performers, sims.records, strict=True)
        }
    ours_err, ours_drift = measure(schedule, records, (t0, t1), ours_starts, args.rate)
    naive_err, naive_drift = measure(schedule, records, (t1, t2), naive_starts, args.rate)

    def row(label: str, ours: float, naive: float) -> str:
        ratio = naive / ours if ours else float("inf")
        return f"{label:<28}{ours:>12.3f}{naive:>12.3f}{ratio:>10.1f}x"

    def p(errs: list[float], q: float) -> float:
        return percentile([abs(e) for e in errs], q)

    print(f"{'(milliseconds)':<28}{'ours':>12}{'naive':>12}{'naive/ours':>11}")
    print(row("send error |p50|", p(ours_err, 0.5), p(naive_err, 0.5)))
    print(row("send error |p99|", p(ours_err, 0.99), p(naive_err, 0.99)))
    print(row("send error |p99.9|", p(ours_err, 0.999), p(naive_err, 0.999)))
    print(row("send error max", p(ours_err, 1.0), p(naive_err, 1.0)))
    print(
        row(
            "end-of-show drift (worst)",
            max(abs(d) for d in ours_drift),
            max(abs(d) for d in naive_drift),
        )
    )
    print(
        f"ours, write issued late by (runner's records): |p50| {p(ours_issued, 0.5):.3f}  "
        f"|p99| {p(ours_issued, 0.99):.3f}  |p99.9| {p(ours_issued, 0.999):.3f}  "
        f"max {p(ours_issued, 1.0):.3f}"
    )
    print("targets for ours: p99 <= 0.5 ms, p99.9 <= 2 ms, drift <= 1 ms"
          f"; garbage collector during our run: {'on' if args.gc_on else 'held'}")
    print(f"load average before/after: {load_before:.2f} / {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
