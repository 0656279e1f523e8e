"""The costliest routines the limits allow: ``xgo-show validate`` of each, as a user runs it.

Issue 13 asks that validate of anything end in under 5 s on this machine, under a memory cap.
Each case below builds a routine at (or just past) a documented limit of docs/limits.md, with
the cue kinds that cost validate most: the largest file of dense moves, the full planner at
the sample limit (a link too busy for validate's short cut), long fades at the top control
rate, many performers, repeats expanding to the cue limit with moves that have no duration
(each needs the trajectory planner), aliases expanding to the value limit, a file of errors.
Each runs as its own process (``python -m xgo_show validate FILE``), timed from process start
to exit: CPU seconds (user + system), wall seconds and peak resident memory, printed beside the
limit with the outcome (accepted, or refused with which error) against the documented one.
Run it under ``nice -n 19`` on a shared machine: the CPU figure is the one to read. Usage::

    python benchmarks/validate_worst.py [--case NAME ...] [--list]

tests/choreo/test_validate_worst.py checks that each case is refused or accepted as documented.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from xgo_show.files import MAX_ROUTINE_BYTES

CPU_LIMIT = 5.0  # seconds: issue 13's "validate of anything finishes in under 5 s"
MEMORY_CAP_MIB = 1024  # peak resident memory a validate may take (docs/limits.md)

_MINI_REGS = ("body_x", "body_y", "body_z", "roll", "pitch", "yaw", "leg1_x", "leg1_z",
              "leg2_x", "leg2_z", "leg3_x", "leg3_z")
# Each register's middle and a swing inside its range that its limits cover in 0.25 s.
_SWING = {"body_x": (0, 3), "body_y": (0, 3), "body_z": (95, 3), "roll": (0, 3),
          "pitch": (0, 3), "yaw": (0, 3), "leg1_x": (0, 3), "leg1_z": (95, 3),
          "leg2_x": (0, 3), "leg2_z": (95, 3), "leg3_x": (0, 3), "leg3_z": (95, 3)}


@dataclass(frozen=True)
class Case:
    """One routine to validate and what validate must say of it."""

    name: str
    what: str
    build: Callable[[Path], Path]  # writes the routine (and its parts) into a folder
    refused: str | None  # text the first error must hold; None: accepted (exit 0)


def _header(performers: list[tuple[str, str]], rate: float, extra: str = "") -> str:
    lines = ["show: worst", f"settings: {{control_rate: {rate:g}{extra}}}", "performers:"]
    lines += [f"  {name}: {{model: {model}}}" for name, model in performers]
    lines.append("tracks:")
    return "\n".join(lines) + "\n"


def _move(n: int, regs: tuple[str, ...], t: float, duration: float) -> str:
    sign = 1 if n % 2 else -1
    parts = []
    for i, name in enumerate(regs):
        mid, swing = _SWING[name]
        parts.append(f"{name}: {mid + sign * swing * ((i % 3) + 1) / 3:g}")
    return f"    - {{at: {t:g}, move: {{{', '.join(parts)}}}, duration: {duration:g}}}\n"


def _dense(folder: Path, *, rate: float, regs: tuple[str, ...], duration: float,
           performers: int, size: int, cues: int) -> Path:
    """Back-to-back moves on every performer, as many as ``size`` bytes and ``cues`` allow."""
    names = [(f"p{i}", "mini") for i in range(performers)]
    head = _header(names, rate)
    per = [f"  p{i}:\n" for i in range(performers)]
    budget = size - len(head) - sum(len(p) for p in per)
    lines: list[list[str]] = [[] for _ in range(performers)]
    used, n = 0, 0
    while n < cues:
        i = n % performers
        line = _move(n, regs, duration * len(lines[i]), duration)
        if used + len(line) > budget:
            break
        lines[i].append(line)
        used += len(line)
        n += 1
    path = folder / "routine.yaml"
    path.write_text(head + "".join(p + "".join(ls) for p, ls in zip(per, lines, strict=True)))
    return path


def dense_max(folder: Path) -> Path:
    """The largest file of moves: 8 registers a move, 10 Minis, 50 Hz, within the size limit."""
    return _dense(folder, rate=50, regs=_MINI_REGS[:8], duration=0.5, performers=10,
                  size=MAX_ROUTINE_BYTES, cues=20_000)


def dense_full_planner(folder: Path) -> Path:
    """As many samples as allowed where validate's short cut cannot prove the link fits
    (12 registers at 200 Hz): the whole show is sampled, merged and paced."""
    return _dense(folder, rate=200, regs=_MINI_REGS, duration=0.5, performers=10,
                  size=MAX_ROUTINE_BYTES, cues=4_800)


def fades_1000hz(folder: Path) -> Path:
    """Long LED fades on 64 Riders at 1000 Hz, four LEDs at once, up to the sample limit."""
    names = [(f"r{i}", "rider") for i in range(64)]
    text = _header(names, 1000)
    fades = 0
    for i in range(64):
        text += f"  r{i}:\n"
        for k in range(2):  # 64 Riders x 2 cues x 4 LEDs x 766 samples each: 392,192
            colour = "[255, 0, 255]" if k % 2 else "[0, 255, 0]"
            leds = ", ".join(f"led{j}: {colour}" for j in range(1, 5))
            text += f"    - {{at: {k * 60}, led: {{{leds}}}, fade: 60}}\n"
            fades += 4
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


def moves_1000hz(folder: Path) -> Path:
    """64 Minis moving four registers at 1000 Hz, 490,000 samples: the full planner."""
    names = [(f"p{i}", "mini") for i in range(64)]
    text = _header(names, 1000)
    for i in range(64):
        text += f"  p{i}:\n" + "".join(
            _move(k, _MINI_REGS[2:6], k * 1.9, 1.9) for k in range(4))
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


def untimed_repeats(folder: Path) -> Path:
    """Repeats that expand to the cue limit: moves without a duration (each one's shortest
    time is planned) on 8 performers."""
    names = [(f"p{i}", "mini") for i in range(8)]
    text = _header(names, 25)
    for i in range(8):
        text += (f"  p{i}:\n    - repeat: 49\n      cues:\n        - repeat: 25\n"
                 "          cues:\n            - {move: {body_z: 110, pitch: 10}}\n"
                 "            - {move: {body_z: 80, pitch: -10}}\n")
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


def repeat_past_cues(folder: Path) -> Path:
    """Nested repeats of zero-length rests, one cue past the limit."""
    text = _header([("p0", "mini")], 50) + (
        "  p0:\n    - repeat: 10000\n      cues:\n        - repeat: 10000\n          cues:\n"
        "            - {rest: 0}\n")
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


def aliases_1m(folder: Path) -> Path:
    """YAML aliases that expand to just under the 1,000,000-value limit, as an unknown field."""
    inner = "[" + ", ".join(["1"] * 999) + "]"
    text = _header([("p0", "mini")], 50)
    text += f"  p0:\n    - {{move: {{body_z: 100}}, duration: 1}}\nx-anchor: &a {inner}\n"
    text += "x-bomb: [" + ", ".join(["*a"] * 990) + "]\n"
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


def aliases_past(folder: Path) -> Path:
    """The same, past the limit: refused before anything is built."""
    inner = "[" + ", ".join(["1"] * 999) + "]"
    text = _header([("p0", "mini")], 50)
    text += f"  p0:\n    - {{move: {{body_z: 100}}, duration: 1}}\nx-anchor: &a {inner}\n"
    text += "x-bomb: [" + ", ".join(["*a"] * 1010) + "]\n"
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


def errors_max(folder: Path) -> Path:
    """A file of the largest size of cues naming registers that do not exist (each a
    did-you-mean search)."""
    head = _header([(f"p{i}", "mini") for i in range(10)], 50)
    lines, size, n = [head], len(head), 0
    for i in range(10):
        lines.append(f"  p{i}:\n")
    per = (MAX_ROUTINE_BYTES - size - 100) // 10
    out = [head]
    for i in range(10):
        out.append(f"  p{i}:\n")
        used = 0
        while True:
            line = (f"    - {{at: {n % 3000}, move: {{bodyz{n}: 1, rol{n}: 2, pich{n}: 3}}, "
                    "duration: 1}\n")
            if used + len(line) > per:
                break
            out.append(line)
            used += len(line)
            n += 1
    path = folder / "routine.yaml"
    path.write_text("".join(out))
    return path


def _parts(folder: Path, count: int, size: int) -> Path:
    """A routine of 8 Minis, each including parts of dense moves (``count`` of ``size``)."""
    for k in range(count):
        lines, used, n = [], 0, 0
        while True:
            line = _move(n, _MINI_REGS[:8], 0.5 * n, 0.5)[2:]  # a part's cues start at "- "
            if used + len(line) > size:
                break
            lines.append(line)
            used += len(line)
            n += 1
        (folder / f"part{k}.yaml").write_text("".join(lines))
    text = _header([(f"p{i}", "mini") for i in range(count)], 50)
    for k in range(count):
        text += f"  p{k}:\n    - {{include: part{k}.yaml}}\n"
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


def parts_max(folder: Path) -> Path:
    """A routine including 8 parts of dense moves, all together just within the size limit."""
    return _parts(folder, 8, (MAX_ROUTINE_BYTES - 2000) // 8)


def parts_past(folder: Path) -> Path:
    """The same with larger parts: the routine and its parts pass the size limit together."""
    return _parts(folder, 8, MAX_ROUTINE_BYTES // 6)


def path_points(folder: Path) -> Path:
    """Multi-point paths (each point a move of its own) up to the cue limit."""
    points = ", ".join(str(90 + 10 * (k % 3)) for k in range(1000))
    text = _header([(f"p{i}", "mini") for i in range(12)], 50)
    for i in range(12):
        text += f"  p{i}:\n    - {{move: {{body_z: [{points}]}}, duration: 800}}\n"
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


def over_size(folder: Path) -> Path:
    """One byte past the file size limit."""
    path = _dense(folder, rate=50, regs=_MINI_REGS[:8], duration=0.5, performers=10,
                  size=MAX_ROUTINE_BYTES, cues=20_000)
    text = path.read_text()
    path.write_text(text + "#" * (MAX_ROUTINE_BYTES + 1 - len(text.encode())))
    return path


def over_samples(folder: Path) -> Path:
    """One move past the sample limit (500,000 at 1000 Hz: 500 s of motion and a bit)."""
    text = _header([("p0", "mini")], 1000) + "  p0:\n"
    text += "".join(_move(k, ("body_z",), k * 100.0, 100.0) for k in range(6))
    path = folder / "routine.yaml"
    path.write_text(text)
    return path


CASES: tuple[Case, ...] = (
    Case("dense_max", "1 MiB of 8-register moves, 10 Minis, 50 Hz", dense_max, None),
    Case("parts_max", "8 included parts of moves, 1 MiB with the routine", parts_max, None),
    Case("dense_full_planner", "12-register moves at 200 Hz, 480,000 samples",
         dense_full_planner, None),
    Case("fades_1000hz", "minute-long fades of 4 LEDs on 64 Riders at 1000 Hz", fades_1000hz,
         "the link does not fit"),
    Case("moves_1000hz", "64 Minis moving at 1000 Hz, 490,000 samples", moves_1000hz, None),
    Case("untimed_repeats", "repeats to 19,600 moves without durations", untimed_repeats,
         None),
    Case("aliases_1m", "aliases expanding to 990,000 values", aliases_1m, "unknown field"),
    Case("errors_max", "1 MiB of cues with unknown registers", errors_max, "no register"),
    Case("path_points", "paths of 1000 points on 12 Minis (12,000 moves)", path_points, None),
    Case("repeat_past_cues", "nested repeats of rests past 20,000 cues", repeat_past_cues,
         "more than 20,000 cues"),
    Case("aliases_past", "aliases expanding past 1,000,000 values", aliases_past,
         "expand to more than"),
    Case("over_size", "one byte past 1 MiB", over_size, "the limit is 1,048,576"),
    Case("parts_past", "8 parts passing 1 MiB with the routine", parts_past,
         "pass 1,048,576 bytes together"),
    Case("over_samples", "one move past 500,000 samples", over_samples,
         "more than 500,000 trajectory"),
)


@dataclass
class Outcome:
    code: int
    first_error: str
    cpu: float
    wall: float
    peak_mib: float


def run_case(case: Case, folder: Path) -> Outcome:
    """Build ``case`` in ``folder`` and validate it in a process of its own: its CPU and
    memory from getrusage(RUSAGE_CHILDREN)."""
    import resource

    path = case.build(folder)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "xgo_show", "validate", "-q", str(path)],
                          capture_output=True, text=True, check=False)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    first = next((ln for ln in proc.stdout.splitlines() if ": error: " in ln), "")
    # ru_maxrss of the children is the largest of any child so far: each case runs in a
    # fresh process of this script (see main) so that it is this case's.
    return Outcome(proc.returncode, first, cpu, wall, after.ru_maxrss / 1024)


def verdict(case: Case, outcome: Outcome) -> str:
    """"as documented" when validate accepted or refused ``case`` as the docs say."""
    if case.refused is None:
        ok = outcome.code == 0
    else:
        ok = outcome.code == 1 and case.refused in outcome.first_error
    return "as documented" if ok else "NOT AS DOCUMENTED"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", action="append", help="run only this case (repeatable)")
    parser.add_argument("--list", action="store_true", help="list the cases")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # internal: measure one case
    args = parser.parse_args(argv)
    by_name = {c.name: c for c in CASES}
    if args.list:
        for c in CASES:
            print(f"{c.name:20} {c.what}")
        return 0
    if args.one:
        with tempfile.TemporaryDirectory() as tmp:
            o = run_case(by_name[args.one], Path(tmp))
        print(f"{o.code}\t{o.cpu:.3f}\t{o.wall:.3f}\t{o.peak_mib:.1f}\t{o.first_error}")
        return 0
    names = args.case or [c.name for c in CASES]
    print(f"load average {os.getloadavg()[0]:.1f} (2 CPUs); limits: {CPU_LIMIT:g} s of CPU, "
          f"{MEMORY_CAP_MIB} MiB peak")
    print(f"{'case':20} {'CPU s':>6} {'wall s':>7} {'peak MiB':>9}  {'CPU<5s':6} "
          f"{'mem<cap':7}  outcome")
    worst = 0.0
    failed = False
    for name in names:
        case = by_name[name]
        line = subprocess.run([sys.executable, __file__, "--one", name], capture_output=True,
                              text=True, check=True).stdout.rstrip("\n")
        code, cpu, wall, peak, first = line.split("\t", 4)
        o = Outcome(int(code), first, float(cpu), float(wall), float(peak))
        said = "accepted" if o.code == 0 else f"refused: {o.first_error.split(': error: ')[-1]}"
        v = verdict(case, o)
        cpu_ok = o.cpu < CPU_LIMIT
        mem_ok = o.peak_mib < MEMORY_CAP_MIB
        failed = failed or not (cpu_ok and mem_ok) or v != "as documented"
        worst = max(worst, o.cpu)
        print(f"{name:20} {o.cpu:6.2f} {o.wall:7.2f} {o.peak_mib:9.0f}  "
              f"{'yes' if cpu_ok else 'NO':6} {'yes' if mem_ok else 'NO':7}  "
              f"{v}, {said[:90]}")
    print(f"slowest: {worst:.2f} s of CPU (limit {CPU_LIMIT:g} s)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
