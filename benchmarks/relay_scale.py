"""How many relays one conductor handles: set-up, lead, start skew and cost by relay count.

For each count N (``--counts``, default 1 4 8 16) the benchmark starts N ``xgo-show relay``
processes, each owning one simulated XGO-Mini on a real pseudo-terminal served from this
process (so every receive time is on this machine's monotonic clock), then runs the conductor
``xgo-show dry-run SHOW --map rI=zenoh:hostI ...`` ``--runs`` times each way, from process start
to exit, alternating:

- ``parallel`` (xgo-show now): the relays are opened (hello, clock sync), uploaded to and
  pre-flighted concurrently; pause/resume/seek/start go to every relay at once and the lead
  comes from the round trips the heartbeats measured;
- ``naive`` (xgo-show before): set-up goes relay after relay, and each relay's start is sent
  once the previous relay answered, on a fixed 0.2 s network lead.

Per run it reads the conductor's run log and the simulators: ``setup`` (process start to the
pre-flight table: Zenoh session, hello, clock sync, upload and pre-flight of every relay),
``lead`` (the start time the runner chose, after its start call), ``min margin`` (the
least time any relay had to spare when its start arrived and its robots were armed; a
refused start has none), ``skew`` (spread of the
first frame's arrival across the N simulators), ``wall`` (process start to exit), the
conductor's CPU time and peak memory, and how many runs failed (a relay refused a start that
came too late, or any other error). Prints figures only. Usage::

    python benchmarks/relay_scale.py [--counts 1 4 8 16] [--runs 5]
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import select
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from xgo_show.compiler.artifact import save_schedule
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.profiles import get_profile
from xgo_show.runtime.runlog import read_log
from xgo_show.runtime.stats import percentile
from xgo_show.sim import PtyServer, create_robot
from xgo_show.wire.xgo import write_frame

MODES = ("parallel", "naive")
OLD_NETWORK_LEAD = 0.2  # seconds: the fixed lead before round trips were measured


def walking_show(names: Sequence[str], seconds: float = 1.0) -> Schedule:
    """Every performer walks forward at once, then body_z changes every 50 ms."""
    profile = get_profile("mini")
    vx, body_z = profile.register("vx"), profile.register("body_z")
    wt = profile.write_type
    frames = [ScheduledFrame(0.0, write_frame(vx.address, vx.encode_value(0.1), write_type=wt))]
    frames += [
        ScheduledFrame(i * 0.05, write_frame(body_z.address, bytes((0x60 + i,)), write_type=wt))
        for i in range(1, int(seconds / 0.05))
    ]
    parts = tuple(
        PerformerSchedule(n, "mini", profile.link, tuple(frames), end=seconds) for n in names
    )
    return Schedule("scale", "bench", parts, 20.0)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class Relay:
    """One relay process with one simulated robot (``rI`` on relay ``hostI``)."""

    def __init__(self, i: int, tmp: Path) -> None:
        self.name, self.robot, self.port = f"host{i}", f"r{i}", free_port()
        self.log = tmp / f"{self.name}.jsonl"
        self.server = PtyServer(create_robot("mini")).start()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "xgo_show", "relay", "--name", self.name, "--map",
             f"{self.robot}={self.server.path}", "--listen", f"tcp/127.0.0.1:{self.port}",
             "--no-telemetry", "--log", str(self.log)],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
        )

    def ready(self, timeout: float) -> None:
        assert self.proc.stdout is not None
        if not select.select([self.proc.stdout], [], [], timeout)[0]:
            raise SystemExit(f"relay {self.name} did not start within {timeout:g} s")
        self.proc.stdout.readline()

    def margin(self) -> float:
        """Seconds to spare the relay had when it armed its last start (nan: refused)."""
        armed = [r for r in read_log(self.log) if r.get("event") in ("armed", "upload")]
        last = armed[-1] if armed else {}
        return last["margin_ms"] / 1e3 if last.get("event") == "armed" else math.nan

    def frames(self) -> list[tuple[float, bytes]]:
        with self.server.lock:
            return [(f.t, f.data) for f in self.server.robot.received]

    def close(self) -> None:
        self.proc.terminate()
        self.proc.communicate(timeout=10)
        self.server.close()


def naive_conductor(argv: list[str]) -> int:
    """The conductor as it was: set-up one relay after another; a start waits for each
    relay's answer; a fixed lead."""
    from xgo_show.cli.main import main
    from xgo_show.errors import NetworkError
    from xgo_show.relay import performer as rp
    from xgo_show.runtime import launch

    # The module, not the package's attribute of that name (the preflight function).
    preflight = importlib.import_module("xgo_show.runtime.preflight")

    def one_by_one(fn: Any, items: Any, **_: Any) -> list[Any]:
        return [fn(item) for item in items]

    launch.each = preflight.each = one_by_one  # type: ignore[assignment]

    def once(self: rp.RelayShow, op: str, at: float | None, value: float | None = None,
             **fields: Any) -> None:
        key = (op, at, value)
        with self._lock:
            if key in self._sent or self._lost is not None:
                return
            self._sent.add(key)
        when = None if at is None else self.to_relay(at)
        try:
            if op == "start":
                assert when is not None
                self.client.start(self.sha256, when, value or 0.0)
            else:
                self.client.command(op, at=when, **fields)
        except NetworkError as exc:
            self.fail(f"{op} on relay {self.client.relay}: {exc}")

    rp.RelayShow.once = once  # type: ignore[method-assign]
    rp.RelayShow.lead = lambda self: OLD_NETWORK_LEAD  # type: ignore[method-assign]
    return main(argv)


def one_run(relays: list[Relay], show: Schedule, show_file: Path, log: Path,
            mode: str) -> dict[str, float]:
    cmd = [sys.executable, "-m", "xgo_show"] if mode == "parallel" else \
        [sys.executable, __file__, "--naive-conductor"]
    cmd += ["dry-run", str(show_file), "--no-telemetry", "--log", str(log)]
    for r in relays:
        cmd += ["--map", f"{r.robot}=zenoh:{r.name}", "--connect", f"tcp/127.0.0.1:{r.port}"]
    before = [len(r.frames()) for r in relays]
    started = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    ended = time.monotonic()
    proc.returncode = os.waitstatus_to_exitcode(status)
    out: dict[str, float] = {
        "wall": ended - started,
        "cpu": usage.ru_utime + usage.ru_stime,
        "rss_mib": usage.ru_maxrss / 1024,
        "failed": float(proc.returncode != 0),
    }
    records = read_log(log) if log.exists() else []
    log.unlink(missing_ok=True)
    pre = next((r for r in records if r.get("event") == "preflight"), None)
    begun = next((r for r in records if r.get("event") == "start"), None)
    out["setup"] = pre["mono"] - started if pre else math.nan
    out["lead"] = begun["start_at"] - begun["mono"] if begun else math.nan
    first = show.performers[0].frames[0].data
    firsts = [next((t for t, d in r.frames()[n:] if d == first), math.nan)
              for r, n in zip(relays, before, strict=True)]
    out["skew"] = max(firsts) - min(firsts) if not proc.returncode else math.nan
    margins = [r.margin() for r in relays]
    out["margin"] = math.nan if any(math.isnan(m) for m in margins) else min(margins)
    if proc.returncode:
        print(f"    {mode} run failed: {err.strip().splitlines()[-1] if err.strip() else '?'}",
              flush=True)
    return out


def fmt(values: list[float], unit: float = 1e3, suffix: str = "ms") -> str:
    done = [v * unit for v in values if math.isfinite(v)]
    if not done:
        return "-"
    return (f"p50 {percentile(done, 0.5):7.1f}  p99 {percentile(done, 0.99):7.1f}  "
            f"p99.9 {percentile(done, 0.999):7.1f}  max {max(done):7.1f} {suffix}")


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--naive-conductor":
        sys.exit(naive_conductor(sys.argv[2:]))
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--counts", type=int, nargs="+", default=[1, 4, 8, 16])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for count in args.counts:
            relays = [Relay(i, Path(tmp)) for i in range(count)]
            try:
                for r in relays:
                    r.ready(20.0 * max(1, count // 2))
                show = walking_show([r.robot for r in relays])
                show_file = Path(tmp) / "scale.xshow.json"
                save_schedule(show, show_file)
                got: dict[str, list[dict[str, float]]] = {m: [] for m in MODES}
                for _ in range(args.runs):
                    for mode in MODES:
                        got[mode].append(one_run(relays, show, show_file, Path(tmp) / "log",
                                                 mode))
            finally:
                for r in relays:
                    r.close()
            print(f"{count} relay(s), one simulated Mini each, {args.runs} runs per way "
                  f"(load average {os.getloadavg()[0]:.2f}):")
            for mode in MODES:
                runs = got[mode]
                failed = sum(int(r["failed"]) for r in runs)
                print(f"  {mode:8s} failed {failed} of {len(runs)}")
                for key, label in (("setup", "setup"), ("lead", "lead"),
                                   ("margin", "min margin"), ("skew", "start skew"),
                                   ("wall", "wall")):
                    print(f"    {label:10s} {fmt([r[key] for r in runs])}")
                print(f"    {'cpu':10s} {fmt([r['cpu'] for r in runs])}")
                print(f"    {'peak rss':10s} {fmt([r['rss_mib'] for r in runs], 1, 'MiB')}")
            print(flush=True)


if __name__ == "__main__":
    main()
