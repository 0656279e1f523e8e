"""What happens to a walking robot when the conductor is killed with SIGKILL (kill -9).

Each round plays a 3-second walking show on one simulated XGO-Mini served on a real
pseudo-terminal in this process (so its receive times share this machine's monotonic clock),
kills the conductor 0.5 s into the show with SIGKILL, and measures the time from the kill to
the last frame of the robot's safe stop arriving at the simulator (or "never" within 2 s):

- ``in-process`` (the naive way, ``run --in-process``): the conductor owns the port; nothing
  is left to stop the robot;
- ``relay child`` (``run``'s default): a relay child owns the port and safe-stops the robot on
  the parent-death signal;
- ``remote relay``: a relay started on its own, conducted with ``--map rex=zenoh:...``; only its
  heartbeat watchdog (``--watchdog-ms``, 500 by default) can notice.

Also reports, from process start, how long the conductor takes to send the first frame with and
without the relay child. Prints figures only (no asserts). Usage::

    python benchmarks/relay_failsafe.py [--rounds 10] [--watchdog-ms 500]
"""

from __future__ import annotations

import argparse
import math
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from xgo_show.compiler.artifact import save_schedule
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.profiles import get_profile
from xgo_show.runtime.safety import stop_frames
from xgo_show.runtime.stats import percentile
from xgo_show.sim import PtyServer, create_robot
from xgo_show.wire.xgo import write_frame

KILL_AT = 0.5  # seconds into the show
NEVER = 2.0  # seconds after the kill: no stop by then counts as never


def walking_show(seconds: float = 3.0) -> Schedule:
    """vx forward at once, then body_z changes every 50 ms."""
    profile = get_profile("mini")
    vx, body_z = profile.register("vx"), profile.register("body_z")
    wt = profile.write_type
    frames = [ScheduledFrame(0.0, write_frame(vx.address, vx.encode_value(0.2), write_type=wt))]
    frames += [
        ScheduledFrame(i * 0.05, write_frame(body_z.address, bytes((i % 100,)), write_type=wt))
        for i in range(1, int(seconds / 0.05))
    ]
    perf = PerformerSchedule("rex", "mini", profile.link, tuple(frames), end=seconds)
    return Schedule("failsafe", "bench", (perf,), 20.0)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def received(server: PtyServer) -> list[tuple[float, bytes]]:
    with server.lock:
        return [(f.t, f.data) for f in server.robot.received]


def one_round(show_file: Path, mode: str, watchdog_ms: int) -> tuple[float, float]:
    """(seconds from the kill to the safe stop, or inf; seconds from start to first frame)."""
    server = PtyServer(create_robot("mini")).start()
    relay: subprocess.Popen[str] | None = None
    first = walking_show().performers[0].frames[0].data
    last_stop = stop_frames(get_profile("mini"))[-1].data
    try:
        cmd = [sys.executable, "-m", "xgo_show", "run", str(show_file), "--countdown", "0",
               "--no-telemetry", "--watchdog-ms", str(watchdog_ms)]
        if mode == "remote relay":
            port = free_port()
            relay = subprocess.Popen(
                [sys.executable, "-m", "xgo_show", "relay", "--name", "bench", "--map",
                 f"rex={server.path}", "--listen", f"tcp/127.0.0.1:{port}", "--no-telemetry"],
                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
            )
            assert relay.stdout is not None
            select.select([relay.stdout], [], [], 20)
            relay.stdout.readline()
            cmd += ["--map", "rex=zenoh:bench/rex", "--connect", f"tcp/127.0.0.1:{port}"]
        else:
            cmd += ["--map", f"rex={server.path}"]
            if mode == "in-process":
                cmd.append("--in-process")
        started = time.monotonic()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = started + 30
        first_at = math.inf
        while time.monotonic() < deadline:
            hit = [t for t, d in received(server) if d == first]
            if hit:
                first_at = hit[0]
                break
            time.sleep(0.002)
        time.sleep(max(0.0, first_at + KILL_AT - time.monotonic()))
        os.kill(proc.pid, signal.SIGKILL)
        killed = time.monotonic()
        proc.wait()
        while time.monotonic() < killed + NEVER:
            stops = [t for t, d in received(server) if d == last_stop and t >= killed]
            if stops:
                return stops[0] - killed, first_at - started
            time.sleep(0.002)
        return math.inf, first_at - started
    finally:
        if relay is not None:
            relay.terminate()
            relay.communicate(timeout=10)
        server.close()


def fmt(values: list[float]) -> str:
    done = [v * 1000 for v in values if math.isfinite(v)]
    never = len(values) - len(done)
    if not done:
        return f"never stopped ({never} of {len(values)})"
    text = (
        f"p50 {percentile(done, 0.5):7.1f}  p99 {percentile(done, 0.99):7.1f}  "
        f"p99.9 {percentile(done, 0.999):7.1f}  max {max(done):7.1f} ms"
    )
    return text + (f"  (never: {never} of {len(values)})" if never else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=10)
    parser.add_argument("--watchdog-ms", type=int, default=500)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        show_file = Path(tmp) / "walk.xshow.json"
        save_schedule(walking_show(), show_file)
        modes = ("in-process", "relay child", "remote relay")
        stops: dict[str, list[float]] = {m: [] for m in modes}
        starts: dict[str, list[float]] = {m: [] for m in modes}
        for _ in range(args.rounds):
            for mode in modes:
                stop, start = one_round(show_file, mode, args.watchdog_ms)
                stops[mode].append(stop)
                starts[mode].append(start)
    print(f"kill -9 of the conductor {KILL_AT:g} s into a walking show, {args.rounds} rounds; "
          f"watchdog {args.watchdog_ms} ms")
    print("time from the kill to the robot's safe stop (last stop frame received):")
    for mode in modes:
        print(f"  {mode:13s} {fmt(stops[mode])}")
    print("time from starting the conductor to the robot's first frame (countdown 0):")
    for mode in modes:
        print(f"  {mode:13s} {fmt(starts[mode])}")


if __name__ == "__main__":
    main()
