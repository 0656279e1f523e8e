"""Schedule file encodings compared on the compile_speed show: size, time to write, time to load.

The show of ``compile_speed.py`` (10 performers, 10 minutes, 50 Hz: 325,551 frames) is compiled
once, then written and read back in each encoding:

- ``v1 json``: the version 1 file (one JSON object per frame: hex bytes, label, origin; the
  baseline, written here as xgo-show wrote it; xgo-show still reads it);
- ``columns``: version 2's canonical body (frame columns + bytes), base64 without deflate;
- ``zlib N``: that body deflated at level N, base64 (xgo-show writes level 1).

CPU seconds are the best of ``--repeat`` runs (this machine is shared); "load" is the whole
reader (checks of every field and frame included) up to the Schedule. The last line checks that
``inspect --frames``'s transcript is the same for the compiled schedule and both files. Prints
figures only (no asserts). Usage::

    python benchmarks/schedule_file.py [--minutes 10] [--performers 10] [--rate 50]
"""

from __future__ import annotations

import base64
import json
import os
import sys
import time
import zlib
from collections.abc import Callable

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from compile_speed import build_show, show_arguments

from xgo_show.compiler import artifact, compile_show
from xgo_show.compiler.artifact import schedule_from_bytes, schedule_to_bytes
from xgo_show.compiler.document import schedule_document
from xgo_show.compiler.report import transcript
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, to_us
from xgo_show.diagnostics import Origin


def version1_bytes(schedule: Schedule) -> bytes:
    """The version 1 file: sorted keys, one frame object per line (as xgo-show wrote it)."""

    def dump(value: object) -> str:
        return json.dumps(value, sort_keys=True, ensure_ascii=False, separators=(", ", ": "))

    def frames(p: PerformerSchedule, ref: Callable[[Origin | None], int | None]) -> object:
        return [{"t_us": to_us(f.t), "hex": f.data.hex(), "origin": ref(f.origin),
                 "label": f.label, "duration_us": to_us(f.duration)} for f in p.frames]

    doc = schedule_document(schedule, frames)
    doc["version"] = 1
    parts = []
    for key in sorted(doc):
        if key == "performers":
            rows = []
            for p in doc[key]:
                items = ",\n   ".join(
                    f"{dump(k)}: " + ("[\n    " + ",\n    ".join(dump(f) for f in v) + "\n   ]"
                                      if k == "frames" and v else dump(v))
                    for k, v in sorted(p.items()))
                rows.append(f"  {{\n   {items}\n  }}")
            parts.append(f' "{key}": [\n' + ",\n".join(rows) + "\n ]")
        else:
            parts.append(f" {dump(key)}: {dump(doc[key])}")
    return ("{\n" + ",\n".join(parts) + "\n}\n").encode("utf-8")


def columns_bytes(schedule: Schedule, level: int | None) -> bytes:
    """Version 2's envelope around the canonical body, deflated at ``level`` (None: stored)."""
    body = artifact._canonical(schedule)
    packed = body if level is None else zlib.compress(body, level)
    return json.dumps({"format": artifact.FORMAT, "body": base64.b64encode(packed).decode()}
                      ).encode()


def unpack(data: bytes, level: int | None) -> bytes:
    """The body again: what a reader does before its checks."""
    packed = base64.b64decode(json.loads(data)["body"])
    return packed if level is None else zlib.decompress(packed)


def best_cpu(run: Callable[[], object], repeat: int) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(repeat):
        c0 = time.process_time()
        result = run()
        best = min(best, time.process_time() - c0)
    return best, result


def main() -> None:
    args = show_arguments(__doc__, 10.0)
    repeat = 3
    schedule = compile_show(build_show(args.minutes, args.performers, args.rate))
    wire = sum(p.total_bytes for p in schedule.performers)
    frames = sum(len(p.frames) for p in schedule.performers)
    print(f"schedule: {frames} frames, {wire} bytes on the wire; CPU s, best of {repeat}; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(f"{'encoding':<10} {'bytes':>11} {'x wire':>7} {'write s':>8} {'load s':>7}")
    v1_cpu, v1 = best_cpu(lambda: version1_bytes(schedule), repeat)
    assert isinstance(v1, bytes)
    load_cpu, _ = best_cpu(lambda: schedule_from_bytes(v1), repeat)
    print(f"{'v1 json':<10} {len(v1):>11,} {len(v1) / wire:>7.2f} {v1_cpu:>8.2f} {load_cpu:>7.2f}")
    for name, level in (("columns", None), ("zlib 1", 1), ("zlib 6", 6), ("zlib 9", 9)):
        write_cpu, data = best_cpu(lambda level=level: columns_bytes(schedule, level), repeat)
        assert isinstance(data, bytes)
        decode_cpu, _ = best_cpu(lambda data=data, level=level: unpack(data, level), repeat)
        print(f"{name:<10} {len(data):>11,} {len(data) / wire:>7.2f} {write_cpu:>8.2f} "
              f"{decode_cpu:>7.2f}  (load: unpacking only)")
    write_cpu, v2 = best_cpu(lambda: schedule_to_bytes(schedule), repeat)
    assert isinstance(v2, bytes)
    load_cpu, loaded = best_cpu(lambda: schedule_from_bytes(v2), repeat)
    print(f"{'v2 file':<10} {len(v2):>11,} {len(v2) / wire:>7.2f} {write_cpu:>8.2f} "
          f"{load_cpu:>7.2f}  (what xgo-show writes: zlib 1; load: the whole reader)")
    assert isinstance(loaded, Schedule)
    same = transcript(loaded) == transcript(schedule_from_bytes(v1)) == transcript(schedule)
    print(f"inspect --frames transcript identical for compiled, v1 and v2: {same}")


if __name__ == "__main__":
    main()
