"""Audio-to-frame alignment: how close the music's beats sound to the robots' frames.

A click track (120 bpm, first downbeat 0.5 s into the file) plays on miniaudio's null device
(real time, the device's own thread, no sound card) while a simulated XGO-Mini on a real pty gets
a ``set`` on every beat. For each beat: the clock time its click sounds (the player's tap: the
time the device buffer plays its first sample, sample-exact within the buffer) minus the clock
time the beat's frame was written. With the null device the "sounding" time is the player's
own reckoning (callback time + device buffer); an acoustic check needs a sound card and a
microphone.

Side by side with the naive approach: a player that renders each buffer for the moment it is
asked for (no render-ahead for the device buffer), i.e. the same run with the buffer latency
not compensated. Usage::

    python benchmarks/music_alignment.py [--beats 40]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import soundfile as sf

from xgo_show.audio.decode import decode
from xgo_show.audio.player import music_performer
from xgo_show.audio.sink import open_sink
from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.events import EventRecorder, FrameSent
from xgo_show.runtime.launch import Launch
from xgo_show.runtime.stats import error_stats
from xgo_show.sim.bench import SimBench

BPM = 120.0
OFFSET = 0.5


def _click_track(path: Path, beats: int) -> None:
    rate = 48000
    y = np.zeros(int((OFFSET + beats * 60 / BPM + 1) * rate), dtype=np.float32)
    n = np.arange(int(0.02 * rate))
    click = (0.8 * np.sin(2 * np.pi * 1500 * n / rate) * np.exp(-n / (0.004 * rate)))
    for k in range(beats):
        start = round((OFFSET + k * 60 / BPM) * rate)
        y[start : start + len(n)] = click
    sf.write(path, y, rate)


def _routine(path: Path, beats: int) -> None:
    cues = "\n".join(
        f"    - {{set: {{body_z: {90 - 10 * (k % 2)}}}, at: {k * 60 / BPM:.3f}}}"
        for k in range(beats)
    )
    path.write_text(
        "show: alignment\n"
        f"music: {{file: clicks.wav, offset: {OFFSET}}}\n"
        "performers: {rex: {model: mini}}\n"
        f"tracks:\n  rex:\n{cues}\n"
        f"    - {{rest: 0.5, at: {beats * 60 / BPM:.3f}}}\n",
        encoding="utf-8",
    )


def _measure(folder: Path, beats: int, *, compensate: bool) -> list[float]:
    schedule = compile_show(load_show(folder / "show.yaml"))
    sink = open_sink("null")
    if not compensate:
        sink.latency = 0.0  # the naive player: renders each buffer for the moment of the pull
    audio = decode(folder / "clicks.wav", channels=sink.channels, sample_rate=sink.rate)
    blocks: list[tuple[float, np.ndarray]] = []
    build = music_performer(audio.samples, sink, offset=OFFSET, until=schedule.duration,
                            tap=lambda at, b: blocks.append((at, b.copy())))
    with SimBench(schedule, ["rex"]) as sims:
        launch = Launch(schedule, sims.urls, clock=MonotonicClock(), telemetry=False,
                        extra_performers=[build])
        recorder = EventRecorder(launch.events, FrameSent)
        with launch:
            launch.open()
            launch.preflight()
            launch.arm()
            launch.run(handle_signals=False)
    frames = [e.t for e in recorder.sent("rex") if e.kind == "frame"]
    latency = 0.020 if not compensate else 0.0  # what the naive player's sound is late by
    clicks: list[float] = []
    for at, block in blocks:
        for i in np.flatnonzero(np.abs(block[:, 0]) > 0.05):
            t = at + i / sink.rate + latency
            if not clicks or t - clicks[-1] > 0.2:
                clicks.append(t)
    n = min(len(frames), len(clicks), beats)
    return [clicks[k] - frames[k] for k in range(n)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--beats", type=int, default=40)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        _click_track(folder / "clicks.wav", args.beats)
        _routine(folder / "show.yaml", args.beats)
        ours = _measure(folder, args.beats, compensate=True)
        naive = _measure(folder, args.beats, compensate=False)
    print(f"click sounds minus frame written, {len(ours)} beats at {BPM:g} bpm (null device)")
    print(f"  render ahead of the device buffer   {error_stats(ours).format()}")
    print(f"  naive (render at the pull)          {error_stats(naive).format()}")


if __name__ == "__main__":
    main()
