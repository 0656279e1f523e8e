"""How fast and how closely the MTC chase locks: lock time from the first byte, and the error of
the show time it starts at, over many simulated locks (real MTC bytes through the decoder,
arrival jitter, the DAW starting at a random point of the quarter-frame cycle).

Side by side with the naive approach: start on the first whole timecode received (one
position, no lock window), which is quicker but carries that one byte's jitter and says
nothing about whether the timecode runs at real speed. Usage::

    python benchmarks/chase_lock.py [--runs 2000] [--jitter-ms 2] [--fps 30]
"""

from __future__ import annotations

import argparse
import random

from xgo_show.runtime.stats import error_stats
from xgo_show.timecode.chase import Chaser, ChaseSettings
from xgo_show.timecode.mtc import RATES, MtcDecoder, quarter_frames


class _Start:
    def __init__(self) -> None:
        self.started: tuple[float, float] | None = None

    def start(self, offset: float, at: float) -> None:
        self.started = (offset, at)

    def pause(self, at: float) -> None: ...

    def resume(self, at: float) -> None: ...

    def seek(self, show_time: float, at: float) -> None: ...

    def stop(self, reason: str) -> None: ...


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=2000)
    parser.add_argument("--jitter-ms", type=float, default=2.0)
    parser.add_argument("--fps", type=int, choices=(24, 25, 30), default=30)
    args = parser.parse_args()
    rate_code = {24: 0, 25: 1, 30: 3}[args.fps]
    fps = RATES[rate_code]
    qf = 1 / (4 * fps)
    rng = random.Random(7)
    lock_times, errors, naive_times, naive_errors = [], [], [], []
    for _ in range(args.runs):
        target = _Start()
        chaser = Chaser(target, ChaseSettings(origin=0.0), duration=1e9, now=lambda: 0.0)
        decoder = MtcDecoder()
        tc0 = rng.randrange(10, 100_000) / fps  # a whole frame
        skip = rng.randrange(8)  # the first bytes heard are mid-cycle
        t0 = 1000.0
        first_byte: float | None = None
        naive: tuple[float, float] | None = None
        for cycle in range(8):
            data = quarter_frames(tc0 + 2 * cycle / fps, rate_code)
            for piece in range(8):
                if cycle == 0 and piece < skip:
                    continue
                sent = t0 + (cycle * 8 + piece) * qf
                arrived = sent + rng.uniform(0, args.jitter_ms / 1000)
                first_byte = arrived if first_byte is None else first_byte
                for pos in decoder.feed(data[2 * piece : 2 * piece + 2]):
                    if naive is None:  # taken as the timecode at its arrival
                        naive = (arrived, pos.seconds - (tc0 + arrived - t0))
                    chaser.position(pos.seconds, arrived)
            if target.started is not None:
                break
        assert target.started is not None and naive is not None and first_byte is not None
        offset, at = target.started
        true_show = tc0 + (at - t0)  # the timecode at clock time ``at``
        lock_times.append(at - chaser.settings.lead - first_byte)
        errors.append(abs(offset - true_show))
        naive_times.append(naive[0] - first_byte)
        naive_errors.append(abs(naive[1]))
    print(f"MTC chase at {args.fps} fps, {args.runs} locks, arrival jitter 0-{args.jitter_ms:g} ms")
    print("lock time from the first byte (the show starts 0.1 s lead later):")
    print(f"  chase (8 positions)     {error_stats(lock_times).format()}")
    print(f"  naive (first position)  {error_stats(naive_times).format()}")
    print("error of the start position (show time the robots start at vs the timecode then):")
    print(f"  chase (mean of window)  {error_stats(errors).format()}")
    print(f"  naive (one position)    {error_stats(naive_errors).format()}")
    print(f"resolution: one quarter frame = {qf * 1000:.2f} ms")


if __name__ == "__main__":
    main()
