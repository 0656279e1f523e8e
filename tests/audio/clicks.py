"""Generated click tracks with known beat times (the audio tests' ground truth)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import soundfile as sf

RATE = 44100


@dataclass(frozen=True)
class ClickTrack:
    path: Path
    beats: tuple[float, ...]  # every click, pickup included (s)
    downbeat: float  # bar 1 beat 1 (s)


def click_times(
    sections: list[tuple[float, int]], first_downbeat: float, pickup: int = 0
) -> list[float]:
    """Beat times: ``pickup`` beats before ``first_downbeat`` at the first tempo, then each
    (bpm, beats) section in turn."""
    t = first_downbeat - pickup * 60.0 / sections[0][0]
    times = []
    for i in range(pickup):
        times.append(t + i * 60.0 / sections[0][0])
    t = first_downbeat
    for bpm, count in sections:
        for _ in range(count):
            times.append(t)
            t += 60.0 / bpm
    return times


def write_click_track(
    path: Path,
    sections: list[tuple[float, int]],
    first_downbeat: float = 0.5,
    pickup: int = 0,
    beats_per_bar: int = 4,
    noise_db: float = -40.0,
) -> ClickTrack:
    """A mono click track: a 1 kHz click on every beat, louder (2 kHz) on each bar's first,
    over white noise; written with libsndfile in the format the suffix names."""
    times = click_times(sections, first_downbeat, pickup)
    rng = np.random.default_rng(7)
    total = int((times[-1] + 1.0) * RATE)
    signal = rng.normal(0.0, 10 ** (noise_db / 20), total).astype(np.float32)
    n = np.arange(int(0.03 * RATE))
    decay = np.exp(-n / (0.004 * RATE))
    for i, t in enumerate(times):
        down = i >= pickup and (i - pickup) % beats_per_bar == 0
        click = (0.8 if down else 0.4) * np.sin(2 * np.pi * (2000 if down else 1000) * n / RATE)
        start = round(t * RATE)
        signal[start : start + len(n)] += (click * decay).astype(np.float32)
    # libsndfile's Vorbis encoder crashes on one big write: write in blocks.
    with sf.SoundFile(path, "w", RATE, 1) as out:
        for i in range(0, len(signal), 8192):
            out.write(signal[i : i + 8192])
    return ClickTrack(path, tuple(times), first_downbeat)
