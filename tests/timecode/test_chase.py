"""Chasing MTC on an injected clock: lock, follow, jumps and dropouts under both policies.

The positions come from real MTC bytes (quarter frames at 30 fps) through the decoder, with
arrival jitter; the target records what the show was told to do and when."""

from __future__ import annotations

import random
from dataclasses import dataclass, field

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.timecode.chase import Chaser, ChaseSettings
from xgo_show.timecode.mtc import MtcDecoder, quarter_frames

FPS = 30.0
QF = 1 / (4 * FPS)


@dataclass
class Recorded:
    calls: list[tuple[str, float, float | str | None]] = field(default_factory=list)

    def start(self, offset: float, at: float) -> None:
        self.calls.append(("start", at, offset))

    def pause(self, at: float) -> None:
        self.calls.append(("pause", at, None))

    def resume(self, at: float) -> None:
        self.calls.append(("resume", at, None))

    def seek(self, show_time: float, at: float) -> None:
        self.calls.append(("seek", at, show_time))

    def stop(self, reason: str) -> None:
        self.calls.append(("stop", 0.0, reason))

    def kinds(self) -> list[str]:
        return [c[0] for c in self.calls]


class Desk:
    """A DAW sending MTC from timecode ``tc`` at clock time ``now``, bytes through a decoder
    into the chaser, each quarter frame arriving with up to ``jitter`` s of delay."""

    def __init__(self, chaser: Chaser, jitter: float = 0.002, seed: int = 1) -> None:
        self.chaser = chaser
        self.jitter = jitter
        self.rng = random.Random(seed)
        self.decoder = MtcDecoder()

    def play(self, tc: float, now: float, seconds: float) -> float:
        """Send ``seconds`` of timecode from ``tc`` starting at clock time ``now``; returns the
        clock time after the last quarter frame."""
        frames_per_cycle = 2
        cycles = int(seconds * FPS / frames_per_cycle)
        t = now
        for c in range(cycles):
            data = quarter_frames(tc + c * frames_per_cycle / FPS)
            for piece in range(8):
                arrival = t + self.rng.uniform(0, self.jitter)
                for pos in self.decoder.feed(data[2 * piece : 2 * piece + 2]):
                    self.chaser.position(pos.seconds, arrival)
                self.chaser.tick(arrival)
                t += QF
        return t


def _chaser(policy: str = "hold", origin: float = 3600.0) -> tuple[Chaser, Recorded]:
    target = Recorded()
    chaser = Chaser(target, ChaseSettings(policy=policy, origin=origin), duration=300.0,
                    now=lambda: 0.0)  # every test passes its times explicitly
    return chaser, target


def test_locks_in_under_three_frames_and_starts_where_the_timecode_will_be() -> None:
    chaser, target = _chaser()
    Desk(chaser).play(3600.0 + 10.0, now=100.0, seconds=1.0)
    (kind, at, offset), = target.calls
    assert kind == "start"
    # The show time the timecode has at clock time ``at``: 10 s at clock 100 s, real speed.
    assert isinstance(offset, float)
    assert offset == pytest.approx(10.0 + (at - 100.0), abs=0.003)
    (lock,) = chaser.log.lock_times
    assert lock < 3 / FPS  # a cycle of eight pieces + eight quarter frames
    assert all(abs(d) < 0.005 for d in chaser.log.drifts)


def test_a_jump_holds_then_seeks_never_moving_the_robots_in_one_step() -> None:
    chaser, target = _chaser()
    desk = Desk(chaser)
    t = desk.play(3610.0, now=100.0, seconds=1.0)
    t = desk.play(3650.0, now=t, seconds=1.0)  # the DAW jumped 40 s ahead
    assert target.kinds() == ["start", "pause", "seek", "resume"]
    _, pause_at, _ = target.calls[1]
    _, seek_at, show = target.calls[2]
    # MTC tells a jump at the end of the first new cycle of eight quarter frames (2 frames).
    assert 101.0 < pause_at <= 101.0 + 8 * QF
    assert isinstance(show, float) and show == pytest.approx(50.0 + seek_at - 101.0, abs=0.004)
    assert target.calls[3][1] == seek_at


def test_a_jump_under_the_stop_policy_stops() -> None:
    chaser, target = _chaser("stop")
    desk = Desk(chaser)
    t = desk.play(3610.0, now=100.0, seconds=1.0)
    desk.play(3650.0, now=t, seconds=1.0)
    assert target.kinds() == ["start", "stop"]
    assert "timecode jump of +39.0" in str(target.calls[1][2])
    assert chaser.state == "stopped"


@pytest.mark.parametrize("policy", ["hold", "stop"])
def test_a_dropout_holds_or_stops(policy: str) -> None:
    chaser, target = _chaser(policy)
    desk = Desk(chaser)
    t = desk.play(3610.0, now=100.0, seconds=1.0)
    chaser.tick(t + 0.1)
    assert target.kinds() == ["start"]  # 0.1 s of silence is no dropout
    chaser.tick(t + 0.25)
    if policy == "stop":
        assert target.kinds() == ["start", "stop"] and "no timecode for" in str(target.calls[1][2])
        return
    assert target.kinds() == ["start", "pause"]
    desk.play(3611.0, now=t + 2.0, seconds=0.5)  # the DAW plays on from where it stopped
    assert target.kinds() == ["start", "pause", "seek", "resume"]
    assert target.calls[2][2] == pytest.approx(11.0 + target.calls[2][1] - (t + 2.0), abs=0.003)


def test_timecode_before_the_show_starts_it_at_zero_on_time() -> None:
    chaser, target = _chaser()
    Desk(chaser).play(3600.0 - 2.0, now=50.0, seconds=0.5)  # pre-roll: 2 s before show start
    ((kind, at, offset),) = target.calls
    assert kind == "start" and offset == 0.0 and at == pytest.approx(52.0, abs=0.003)


@settings(max_examples=60, deadline=None)
@given(
    start=st.floats(0, 200),
    jitter=st.floats(0, 0.006),
    seed=st.integers(0, 1000),
    jumps=st.lists(st.floats(-60, 60).filter(lambda j: abs(j) > 0.2), max_size=3),
)
def test_under_any_jitter_and_jumps_the_show_is_told_a_sane_story(
    start: float, jitter: float, seed: int, jumps: list[float]
) -> None:
    chaser, target = _chaser()
    desk = Desk(chaser, jitter, seed)
    tc, t = 3600.0 + round(start * FPS) / FPS, 1000.0  # a desk sends whole frames
    segments = [(t, tc)]
    t = desk.play(tc, now=t, seconds=0.5)
    for jump in jumps:
        tc = max(3600.0, tc + 0.5 + round(jump * FPS) / FPS)
        segments.append((t, tc))
        t = desk.play(tc, now=t, seconds=0.5)
    kinds = target.kinds()
    assert kinds[0] == "start" and kinds.count("start") == 1
    # Every change of place is a pause first, then a seek and a resume at the same time; a
    # jump past the show's end leaves the show held at its last pause.
    rest = kinds[1:]
    whole = len(rest) // 3
    assert rest == ["pause", "seek", "resume"] * whole + ["pause"] * (len(rest) - 3 * whole)
    assert len(rest) - 3 * whole <= 1
    for i in range(1, 1 + 3 * whole, 3):
        assert target.calls[i + 1][1] == target.calls[i + 2][1] >= target.calls[i][1]
    # Wherever the show went, it went where the timecode was then (within the jitter).
    lead = chaser.settings.lead
    for kind, at, show in target.calls:
        if kind in ("start", "seek"):
            seg_t, seg_tc = max(s for s in segments if s[0] <= at - lead)
            assert isinstance(show, float)
            assert show == pytest.approx(seg_tc - 3600.0 + at - seg_t, abs=jitter + 0.002)
