"""Beat tracking: from a recording to beat times, bars and a tempo map.

The method (numpy only, no heavy analysis library: a 3-minute song takes about a second):

1. Onset strength: spectral flux of the log-compressed magnitude spectrum, 23 ms windows every
   ``HOP_S`` (5 ms).
2. Local tempo: autocorrelation of the onset strength in 8 s windows every second, weighted by a
   log-normal prior around 120 bpm (against picking half or double the tempo), median-smoothed.
3. Beats: dynamic programming (Ellis 2007) over the onset strength with that time-varying beat
   period, so tempo changes are followed instead of averaged.
4. Each beat is moved onto the attack it belongs to: the millisecond of the steepest rise of the
   signal's energy within ``SNAP_S`` of the tracked beat (the flux frame grid alone is 5 ms).
5. Bars: the beat phase whose attacks are the loudest starts the bars (or the one given).

:func:`tempo_map` turns downbeats into ``tempo:`` entries (one per bar, merged while one tempo
keeps every beat within ``tolerance``), so bar/beat positions in a routine land on the beats of
the recording; the first downbeat is the music's ``offset``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from xgo_show.audio.decode import require

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    Floats = npt.NDArray[np.float64]

__all__ = ["Analysis", "TempoEntry", "analyse", "tempo_map"]

HOP_S = 0.005  # onset-strength frame step (s)
WINDOW_S = 0.023  # analysis window (s)
SNAP_S = 0.030  # how far a tracked beat may move onto an attack (s)
MIN_BPM, MAX_BPM = 40.0, 240.0
CHANGE_S = 2.0  # how near a tempo change the beat tracker lets either tempo hold (s)


@dataclass(frozen=True)
class Analysis:
    """Beat times (s from the start of the file), the index of the first downbeat among them,
    the meter, and the local tempo (bpm) at each beat."""

    beats: tuple[float, ...]
    first_downbeat: int
    beats_per_bar: int
    bpm: tuple[float, ...]

    @property
    def downbeats(self) -> tuple[float, ...]:
        """The beats that start a bar."""
        return self.beats[self.first_downbeat :: self.beats_per_bar]

    @property
    def offset(self) -> float:
        """Seconds into the recording where bar 1 beat 1 falls."""
        return self.beats[self.first_downbeat]


@dataclass(frozen=True)
class TempoEntry:
    """From ``bar`` on (1-based), ``bpm`` beats a minute."""

    bar: int
    bpm: float


def _onset_strength(mono: Floats, rate: int) -> tuple[Floats, int]:
    """Spectral flux every ``hop`` samples; returns (strength, hop)."""
    np = require("numpy")
    hop = max(1, round(HOP_S * rate))
    n_fft = 1 << max(6, round(math.log2(WINDOW_S * rate)))
    padded = np.concatenate([np.zeros(n_fft // 2), mono, np.zeros(n_fft)])
    frames = 1 + (len(padded) - n_fft) // hop
    window = np.hanning(n_fft)
    top = max(2, int(n_fft * 8000 / rate))  # up to 8 kHz
    flux = np.zeros(frames)
    prev = None
    step = 2048
    for first in range(0, frames, step):
        idx = np.arange(first, min(frames, first + step))[:, None] * hop + np.arange(n_fft)
        mag = np.abs(np.fft.rfft(padded[idx] * window, axis=1))[:, :top]
        logmag = np.log1p(100.0 * mag)
        before = np.vstack([logmag[:1] if prev is None else prev, logmag[:-1]])
        flux[first : first + len(logmag)] = np.maximum(logmag - before, 0.0).sum(axis=1)
        prev = logmag[-1:]
    flux -= _moving_mean(flux, int(0.5 / HOP_S))
    flux = np.maximum(flux, 0.0)
    scale = flux.std()
    return (flux / scale if scale > 0 else flux), hop


def _moving_mean(x: Floats, width: int) -> Floats:
    np = require("numpy")
    width = max(1, min(width, len(x)))
    kernel = np.ones(width) / width
    out: Floats = np.convolve(x, kernel, mode="same")
    return out


def _local_periods(strength: Floats, fps: float) -> Floats:
    """The beat period (in frames) at every frame."""
    np = require("numpy")
    lo, hi = int(fps * 60 / MAX_BPM), int(fps * 60 / MIN_BPM) + 1
    win, step = int(8 * fps), int(1 * fps)
    lags = np.arange(lo, hi)
    bpm = 60 * fps / lags
    prior = np.exp(-0.5 * (np.log2(bpm / 120.0) / 1.0) ** 2)
    centres, periods = [], []
    for start in range(0, max(1, len(strength) - win // 2), step):
        seg = strength[start : start + win]
        if len(seg) < hi * 2:
            seg = strength[max(0, len(strength) - win) :]
        seg = seg - seg.mean()
        spectrum = np.fft.rfft(seg, 2 * len(seg))
        ac = np.fft.irfft(np.abs(spectrum) ** 2)[: len(seg)]
        if ac[0] <= 0 or len(ac) <= hi:
            continue
        ac = ac / ac[0]
        # A beat period also shows at twice the lag: count it in (sharper peaks).
        doubled = np.interp(2 * lags, np.arange(len(ac)), ac, right=0.0)
        score = (ac[lags] + 0.5 * doubled) * prior
        best = int(np.argmax(score))
        # Refine to a fraction of a frame with a parabola through the peak.
        period = float(lags[best])
        if 0 < best < len(lags) - 1:
            a, b, c = score[best - 1], score[best], score[best + 1]
            denom = a - 2 * b + c
            if denom < 0:
                period += 0.5 * (a - c) / denom
        centres.append(start + len(seg) / 2)
        periods.append(period)
    if not periods:
        centres, periods = [0.0], [fps * 0.5]
    smooth = [float(np.median(periods[max(0, i - 2) : i + 3])) for i in range(len(periods))]
    out: Floats = np.interp(np.arange(len(strength)), centres, smooth)
    return out


def _track(
    strength: Floats, periods: Floats, fps: float, tightness: float = 100.0
) -> list[int]:
    """Beat frames by dynamic programming: each beat about one local period after the one
    before. Near a tempo change (any period seen within ``CHANGE_S``) every interval between
    the slower and the faster period is free of penalty, so the beats follow the onsets
    through the change instead of the smeared tempo estimate."""
    np = require("numpy")
    n = len(strength)
    reach = max(1, int(CHANGE_S * fps))
    padded = np.concatenate([np.full(reach, periods[0]), periods, np.full(reach, periods[-1])])
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * reach + 1)
    low, high = windows.min(axis=1), windows.max(axis=1)
    score = strength.copy()
    back = np.full(n, -1)
    for t in range(n):
        lo, hi = low[t], high[t]
        first, last = t - int(2 * hi), t - max(1, int(lo / 2))
        if last < 0:
            continue
        taus = np.arange(t - max(0, first), t - last - 1, -1)
        prev = t - taus
        off = np.maximum(np.log(lo / taus), 0.0) + np.maximum(np.log(taus / hi), 0.0)
        gain = score[prev] - tightness * off**2
        best = int(np.argmax(gain))
        if gain[best] > 0:
            score[t] += gain[best]
            back[t] = prev[best]
    # End on the best-scoring strong frame in the last beat period.
    tail = max(0, n - int(periods[-1]) - 1)
    candidates = np.arange(tail, n)
    strong = candidates[strength[candidates] > 0.5 * strength[candidates].max()] if n else []
    end = int(strong[np.argmax(score[strong])]) if len(strong) else int(np.argmax(score))
    beats = [end]
    while back[beats[-1]] >= 0:
        beats.append(int(back[beats[-1]]))
    beats.reverse()
    # Drop weak beats at either end (silence before the music starts or after it ends).
    level = np.median(strength[beats]) if beats else 0.0
    while beats and strength[beats[0]] < 0.3 * level:
        beats.pop(0)
    while beats and strength[beats[-1]] < 0.3 * level:
        beats.pop()
    return beats


def _snap(mono: Floats, rate: int, times: list[float]) -> list[float]:
    """Move each time onto the steepest energy rise within ``SNAP_S`` (1 ms resolution)."""
    np = require("numpy")
    block = max(1, rate // 1000)  # samples a step (about 1 ms)
    step = block / rate
    usable = len(mono) // block * block
    energy = (mono[:usable].reshape(-1, block) ** 2).sum(axis=1)
    past = np.convolve(energy, np.ones(8) / 8, mode="full")[: len(energy)]
    rise = energy - np.concatenate([[0.0], past[:-1]])
    reach = int(SNAP_S / step)
    out = []
    for t in times:
        c = int(t / step)
        lo, hi = max(0, c - reach), min(len(rise), c + reach + 1)
        if hi <= lo:
            out.append(t)
            continue
        window = rise[lo:hi]
        best = int(np.argmax(window))
        out.append((lo + best) * step if window[best] > 0 else t)
    return out


def analyse(
    samples: npt.ArrayLike, rate: int, beats_per_bar: int = 4, first_bar_at: float | None = None
) -> Analysis:
    """Beats, downbeats and local tempo of mono ``samples`` at ``rate`` Hz.

    ``first_bar_at`` (s): the beat nearest to it is bar 1 beat 1; by default the strongest beat
    phase starts the bars. Raises :class:`ValueError` when fewer than two beats are found.
    """
    np = require("numpy")
    mono = np.asarray(samples, dtype=np.float64)
    strength, hop = _onset_strength(mono, rate)
    periods = _local_periods(strength, rate / hop)
    frames = _track(strength, periods, rate / hop)
    if len(frames) < 2:
        raise ValueError("no steady beat found (fewer than two beats)")
    # Frame k's window is centred on sample k*hop (the signal was padded by half a window).
    times = _snap(mono, rate, [k * hop / rate for k in frames])
    times = sorted(set(times))
    # How loud each beat's attack is (the 50 ms after it): the louder phase starts the bars.
    span = int(0.05 * rate)
    strengths = [float(np.sum(mono[int(t * rate) : int(t * rate) + span] ** 2)) for t in times]
    # No attack at either end (the tracker ran on into silence or noise): not a beat.
    floor = 0.1 * float(np.median(strengths))
    while len(times) > 2 and strengths[-1] < floor:
        times, strengths = times[:-1], strengths[:-1]
    while len(times) > 2 and strengths[0] < floor:
        times, strengths = times[1:], strengths[1:]
    if first_bar_at is not None:
        start = int(np.argmin([abs(t - first_bar_at) for t in times]))
    else:
        phases = range(min(beats_per_bar, len(times)))
        phase_power = [float(np.mean(strengths[p::beats_per_bar])) for p in phases]
        start = int(np.argmax(phase_power))
    gaps = np.diff(times)
    bpm = [60.0 / g for g in gaps]
    bpm.append(bpm[-1])
    return Analysis(tuple(times), start, beats_per_bar, tuple(round(b, 3) for b in bpm))


def tempo_map(analysis: Analysis, tolerance: float = 0.003) -> list[TempoEntry]:
    """``tempo:`` entries whose bar/beat grid (bar 1 at ``analysis.offset``) meets every beat
    from the first downbeat to the last full bar within ``tolerance`` seconds where the
    recording allows: one entry per bar, consecutive bars merged while one tempo fits them all.
    """
    per_bar = analysis.beats_per_bar
    beats = analysis.beats[analysis.first_downbeat :]
    bars = (len(beats) - 1) // per_bar
    if bars < 1:
        raise ValueError(f"fewer than one full bar of {per_bar} beats after the first downbeat")
    downs = [beats[i * per_bar] for i in range(bars + 1)]

    def fits(first: int, last: int, origin: float, bpm: float) -> bool:
        beat_s = 60.0 / bpm
        return all(
            abs(origin + i * beat_s - beats[first * per_bar + i]) <= tolerance
            for i in range((last - first + 1) * per_bar + 1)
        )

    def bpm_to(first: int, last: int, origin: float) -> float:
        """The tempo (3 decimals, as written) that brings bar ``last + 1`` onto its downbeat."""
        return round(60.0 * per_bar * (last + 1 - first) / (downs[last + 1] - origin), 3)

    entries: list[TempoEntry] = []
    first = 0
    origin = downs[0]  # where the map puts the current entry's first bar (rounding included)
    while first < bars:
        last = first
        bpm = bpm_to(first, last, origin)
        while last + 1 < bars:
            candidate = bpm_to(first, last + 1, origin)
            if not fits(first, last + 1, origin, candidate):
                break
            last, bpm = last + 1, candidate
        entries.append(TempoEntry(first + 1, bpm))
        origin += (last + 1 - first) * per_bar * 60.0 / bpm
        first = last + 1
    return entries
