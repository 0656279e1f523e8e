"""``xgo-show compile`` and ``validate`` end to end, as a user runs them, beside the baselines.

The show of ``compile_speed.py`` (10 performers, 10 minutes, 50 Hz) is written as a routine
(YAML), then each command runs in its own process, ``--repeat`` times: CPU seconds (user +
system) and peak resident memory from process start to exit, as ``/usr/bin/time`` reports them
(``os.wait4``'s resource usage of that one child). Beside them, in this process: the compiler
alone on the show built in memory (``compile_show``), and writing the schedule with the version
1 JSON writer (the old ``save``, see ``schedule_file.py``) against the version 2 file.
Targets (issue 12): compile <= 2 s CPU and <= 300 MiB, validate <= 1 s. Prints figures only
(no asserts). Usage::

    python benchmarks/compile_cli.py [--minutes 10] [--performers 10] [--rate 50]
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from compile_speed import build_show, show_arguments, show_yaml
from schedule_file import version1_bytes

from xgo_show.compiler import compile_show
from xgo_show.compiler.artifact import schedule_to_bytes

REPEAT = 3


def run_child(argv: list[str]) -> tuple[float, float]:
    """CPU seconds and peak RSS (MiB) of one process running ``argv`` to its end."""
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited with {proc.returncode}")
    return usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024  # ru_maxrss: KiB on Linux


def in_process(run: Callable[[], object]) -> float:
    c0 = time.process_time()
    run()
    return time.process_time() - c0


def row(name: str, cpus: list[float], rss: list[float] | None, target: str) -> None:
    mem = f"{max(rss):>8.0f}" if rss else f"{'-':>8}"
    print(f"{name:<38} {min(cpus):>6.2f} {statistics.median(cpus):>6.2f} {max(cpus):>6.2f} "
          f"{mem}  {target}")


def main() -> None:
    args = show_arguments(__doc__, 10.0)
    exe = [sys.executable, "-m", "xgo_show"]
    with tempfile.TemporaryDirectory() as tmp:
        routine = Path(tmp) / "compile_speed.yaml"
        routine.write_text(show_yaml(args.minutes, args.performers, args.rate), encoding="utf-8")
        out = Path(tmp) / "compile_speed.xshow.json"
        print(f"routine: {routine.stat().st_size:,} bytes of YAML; {REPEAT} runs each; load "
              f"average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
        print(f"{'':<38} {'CPU s: min':>10} {'p50':>6} {'max':>6} {'peak MiB':>8}")
        children = {
            "python + imports (xgo-show --help)": ([*exe, "--help"], ""),
            "xgo-show validate SHOW.yaml": ([*exe, "validate", "-q", str(routine)],
                                            "target <= 1 s"),
            "xgo-show compile SHOW.yaml -o F": ([*exe, "compile", "-q", str(routine), "-o",
                                                 str(out)], "target <= 2 s, <= 300 MiB"),
        }
        for name, (argv, target) in children.items():
            runs = [run_child(argv) for _ in range(REPEAT)]
            row(name, [c for c, _ in runs], [m for _, m in runs], target)
        print(f"schedule file: {out.stat().st_size:,} bytes")
    show = build_show(args.minutes, args.performers, args.rate)
    schedule = compile_show(show)
    row("baseline: compile_show in memory", [in_process(lambda: compile_show(show))
                                             for _ in range(REPEAT)], None, "")
    row("baseline: version 1 JSON writer", [in_process(lambda: version1_bytes(schedule))
                                            for _ in range(REPEAT)], None, "")
    row("version 2 writer (schedule_to_bytes)", [in_process(lambda: schedule_to_bytes(schedule))
                                                 for _ in range(REPEAT)], None, "")


if __name__ == "__main__":
    main()
