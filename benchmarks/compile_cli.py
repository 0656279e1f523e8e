"""``xgo-show compile`` and ``validate`` end to end, as a user runs them, beside the baselines.

The show of ``compile_speed.py`` (10 performers, 10 minutes, 50 Hz) is written as a routine
(YAML), then each command runs in its own process, ``--repeat`` times after one untimed run
(which leaves the ``.pyc`` files an installed copy has): CPU seconds (user + system), wall
seconds and peak resident memory from process start to exit, as ``/usr/bin/time`` reports them
(``os.wait4``'s resource usage of that one child), with the machine's load average.

Beside them, the same commands of an earlier revision of xgo-show (``--before REV``, by default
the one before this session's speed work; its ``xgo_show`` package is extracted with ``git
archive`` and put first on ``PYTHONPATH``), and in this process: the compiler alone on the show
built in memory (``compile_show``), and writing the schedule with the version 1 JSON writer
(the old ``save``, see ``schedule_file.py``) against the version 2 file.
With ``--pairs N``, compile is then timed N more times in pairs, this revision's run and the
earlier one's back to back: this VM's speed drifts by a fifth between hours and by several
per cent within a minute, and a difference within each pair sees less of it than two tables do.
Targets (issue 12): compile <= 2 s CPU and <= 300 MiB, validate <= 1 s. Prints figures only
(no asserts). Usage::

    python benchmarks/compile_cli.py [--minutes 10] [--performers 10] [--rate 50]
                                     [--repeat 3] [--before REV | --before none] [--pairs N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from compile_speed import build_show, show_arguments, show_yaml
from schedule_file import version1_bytes

from xgo_show.compiler import compile_show
from xgo_show.compiler.artifact import schedule_to_bytes

BEFORE = "6e49d04"  # main before session 9 (frame columns from the fast path, change codes)
REPO = Path(__file__).resolve().parent.parent


class Usage(NamedTuple):
    cpu: float  # seconds, user + system
    wall: float  # seconds
    peak: float  # MiB of resident memory at most


def run_child(argv: list[str], env: dict[str, str], cwd: str) -> Usage:
    """CPU and wall seconds and peak RSS of one process running ``argv`` to its end (in
    ``cwd``: ``python -m`` puts it first on the import path)."""
    w0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, env=env, cwd=cwd)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - w0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited with {proc.returncode}")
    # ru_maxrss: KiB on Linux
    return Usage(usage.ru_utime + usage.ru_stime, wall, usage.ru_maxrss / 1024)


def in_process(run: Callable[[], object]) -> float:
    c0 = time.process_time()
    run()
    return time.process_time() - c0


def row(name: str, cpus: list[float], walls: list[float] | None, rss: list[float] | None,
        target: str = "") -> None:
    wall = f"{statistics.median(walls):>7.2f}" if walls else f"{'-':>7}"
    mem = f"{max(rss):>8.0f}" if rss else f"{'-':>8}"
    print(f"{name:<52} {min(cpus):>6.2f} {statistics.median(cpus):>6.2f} {max(cpus):>6.2f} "
          f"{wall} {mem}  {target}")


def extract(rev: str, into: Path) -> Path:
    """``rev``'s xgo_show package under ``into`` (for PYTHONPATH)."""
    into.mkdir()
    archive = into / "src.tar"
    with archive.open("wb") as fh:
        subprocess.run(["git", "-C", str(REPO), "archive", rev, "xgo_show"], stdout=fh,
                       check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(into, filter="data")
    return into


def commands(exe: list[str], routine: Path, out: Path) -> dict[str, tuple[list[str], str]]:
    return {
        "start-up (xgo-show validate --help)": ([*exe, "validate", "--help"], ""),
        "xgo-show validate SHOW.yaml": ([*exe, "validate", "-q", str(routine)],
                                        "target <= 1 s"),
        "xgo-show compile SHOW.yaml -o F": ([*exe, "compile", "-q", str(routine), "-o",
                                             str(out)], "target <= 2 s, <= 300 MiB"),
    }


def paired(argv: list[str], env: dict[str, str], before: dict[str, str], cwd: str,
           pairs: int) -> None:
    """``argv`` run ``pairs`` times in each environment, a pair's two runs back to back (which
    goes first alternates): CPU seconds this one minus before, per pair."""
    diffs: list[float] = []
    loads: list[float] = []
    for i in range(pairs):
        order = [(env, 1.0), (before, -1.0)]
        if i % 2:
            order.reverse()
        diffs.append(sum(sign * run_child(argv, child_env, cwd).cpu for child_env, sign in order))
        loads.append(os.getloadavg()[0])
    print(f"compile, {pairs} pairs, CPU s this minus before: median "
          f"{statistics.median(diffs):+.3f}, mean {statistics.mean(diffs):+.3f}, min "
          f"{min(diffs):+.3f}, max {max(diffs):+.3f}; load average {min(loads):.2f}-"
          f"{max(loads):.2f}")


def main() -> None:
    def more(parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--repeat", type=int, default=3)
        parser.add_argument("--before", default=BEFORE,
                            help="git revision to run beside this one ('none': skip)")
        parser.add_argument("--pairs", type=int, default=0,
                            help="then time compile this many times more in pairs, this "
                            "revision and --before one after the other (each pair in turn "
                            "first): the difference within a pair, when the machine's "
                            "speed drifts between runs")

    args = show_arguments(__doc__, 10.0, more)
    exe = [sys.executable, "-m", "xgo_show"]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    with tempfile.TemporaryDirectory() as tmp:
        routine = Path(tmp) / "compile_speed.yaml"
        routine.write_text(show_yaml(args.minutes, args.performers, args.rate), encoding="utf-8")
        out = Path(tmp) / "compile_speed.xshow.json"
        print(f"routine: {routine.stat().st_size:,} bytes of YAML; {args.repeat} runs each "
              f"after one untimed; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} "
              "CPUs")
        print(f"{'':<52} {'CPU s: min':>10} {'p50':>6} {'max':>6} {'wall p50':>8} "
              f"{'peak MiB':>8}")
        versions = [("", env)]
        if args.before != "none":
            old = extract(args.before, Path(tmp) / "before")
            versions.append((f"  before ({args.before}): ", {**env, "PYTHONPATH": str(old)}))
        for name, (argv, target) in commands(exe, routine, out).items():
            for prefix, child_env in versions:
                run_child(argv, child_env, tmp)  # untimed: writes the .pyc files
                runs = [run_child(argv, child_env, tmp) for _ in range(args.repeat)]
                row(prefix + name, [u.cpu for u in runs], [u.wall for u in runs],
                    [u.peak for u in runs], "" if prefix else target)
        print(f"schedule file: {out.stat().st_size:,} bytes; load average now "
              f"{os.getloadavg()[0]:.2f}")
        if args.pairs > 0 and len(versions) == 2:
            compile_argv = commands(exe, routine, out)["xgo-show compile SHOW.yaml -o F"][0]
            paired(compile_argv, versions[0][1], versions[1][1], tmp, args.pairs)
    show = build_show(args.minutes, args.performers, args.rate)
    schedule = compile_show(show)
    row("baseline: compile_show in memory", [in_process(lambda: compile_show(show))
                                             for _ in range(args.repeat)], None, None)
    row("baseline: version 1 JSON writer", [in_process(lambda: version1_bytes(schedule))
                                            for _ in range(args.repeat)], None, None)
    row("version 2 writer (schedule_to_bytes)", [in_process(lambda: schedule_to_bytes(schedule))
                                                 for _ in range(args.repeat)], None, None)


if __name__ == "__main__":
    main()
