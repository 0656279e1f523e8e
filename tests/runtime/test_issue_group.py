"""An :class:`IssueGroup` in-process, with no writer threads: which armed frames the first
writer awake issues for the others (due ones, not its own, once), what a peer's write does to
the owner's link (busy for the frame's wire time and gap, from the peer's send), when a peer
leaves the frame to its owner (a request pending, the link busy, the owner writing), and what
taking a frame back tells the owner (not issued, issued at a time, or the peer's error)."""

from __future__ import annotations

import threading

import pytest

from tests.runtime.conftest import make_performer
from xgo_show.errors import TransportError
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import FakeClock, MonotonicClock
from xgo_show.runtime.executor import IssueGroup, PerformerExecutor
from xgo_show.sim import create_robot
from xgo_show.transports.sim import SimTransport

MINI = get_profile("mini")


class Noting(SimTransport):
    """A simulated Mini's link that notes each write (or fails it, when told)."""

    def __init__(self) -> None:
        super().__init__(create_robot("mini"))
        self.written: list[bytes] = []
        self.fail = False
        self.stall: tuple[FakeClock, float] | None = None  # a write that takes this long

    def write(self, data: bytes) -> None:
        if self.fail:
            raise TransportError("port gone")
        self.written.append(data)
        super().write(data)
        if self.stall is not None:
            clock, seconds = self.stall
            clock.advance(seconds)


def _executor(name: str, clock: FakeClock) -> tuple[PerformerExecutor, Noting]:
    link = Noting()
    link.open()
    return PerformerExecutor(make_performer(name), link, clock=clock, profile=MINI,
                             rest_at_end=False), link



def play_together(executors: list[PerformerExecutor], clock: MonotonicClock) -> float:
    """Start every executor at one instant 50 ms from now and wait for all to end: the start."""
    start = clock.now() + 0.05
    for ex in executors:
        ex.start(start)
    assert all(ex.join(10.0) for ex in executors)
    return start

def test_the_first_writer_issues_the_others_due_frames_once_and_never_its_own() -> None:
    clock = FakeClock()
    now = clock.now()
    (a, la), (b, lb), (w, lw) = (_executor(n, clock) for n in ("a", "b", "w"))
    group = IssueGroup()
    ea = group.arm(a, now, b"A")  # due exactly now
    eb = group.arm(b, now + 0.001, b"B")  # not yet
    ew = group.arm(w, now - 1.0, b"W")  # the writer's own
    group.issue_due(w, now)
    assert (la.written, lb.written, lw.written) == ([b"A"], [], [])
    assert ea.claimed and ea.done.is_set() and ea.actual == now
    assert not eb.claimed and not eb.done.is_set() and eb.actual is None
    assert not ew.claimed
    # Issued once: a second writer of the instant leaves it (and b's is due now).
    clock.advance(0.001)
    group.issue_due(w, clock.now())
    assert (la.written, lb.written) == ([b"A"], [b"B"])
    # Taken back: the time the peer issued it; b's later arm is its own again.
    assert group.disarm(a, ea) == now
    assert group.disarm(b, eb) == now + 0.001
    assert group.disarm(w, ew) is None  # never issued: the owner writes it


def test_a_frame_taken_back_is_not_issued_after() -> None:
    clock = FakeClock()
    (a, la), (w, _) = (_executor(n, clock) for n in ("a", "w"))
    group = IssueGroup()
    entry = group.arm(a, clock.now(), b"A")
    assert group.disarm(a, entry) is None
    group.issue_due(w, clock.now() + 1.0)
    assert la.written == [] and not entry.claimed


def test_a_peers_failed_write_is_raised_to_the_owner() -> None:
    clock = FakeClock()
    (a, la), (w, _) = (_executor(n, clock) for n in ("a", "w"))
    group = IssueGroup()
    entry = group.arm(a, clock.now(), b"A")
    la.fail = True
    group.issue_due(w, clock.now())  # the peer goes on: the owner reports it
    assert entry.done.is_set() and entry.actual is None
    with pytest.raises(TransportError, match="port gone"):
        group.disarm(a, entry)


def test_a_peers_write_makes_the_owners_link_busy_from_its_send() -> None:
    clock = FakeClock()
    a, link = _executor("a", clock)
    now = clock.now()
    data = bytes(9)
    assert a._issue_for_peer(data, now) == now
    assert link.written == [data]
    wire = a.schedule.link
    assert a._ready_at == pytest.approx(now + wire.wire_time(9) + wire.gap, abs=1e-12)
    # Busy until then: the next is left to the owner; at that very time it goes.
    assert a._issue_for_peer(b"x", a._ready_at - 1e-6) is None
    assert a._issue_for_peer(b"y", a._ready_at) is not None
    assert link.written == [data, b"y"]


def test_a_peers_write_is_timed_at_its_send_and_books_the_link_until_it_returned() -> None:
    # A write that blocks 4 ms (longer than the frame's wire time): the frame was sent when
    # the write was issued, and the link is busy until the write returned, then the gap.
    clock = FakeClock()
    a, link = _executor("a", clock)
    link.stall = (clock, 0.004)
    now = clock.now()
    assert a._issue_for_peer(bytes(9), now) == now
    wire = a.schedule.link
    assert wire.wire_time(9) < 0.004
    assert a._ready_at == pytest.approx(now + 0.004 + wire.gap, abs=1e-12)


@pytest.mark.parametrize("why", ["wake", "abort", "writing"])
def test_a_peer_leaves_the_frame_to_its_owner(why: str) -> None:
    clock = FakeClock()
    a, link = _executor("a", clock)
    if why == "writing":
        assert a._write_lock.acquire()
        held = threading.Event()

        def attempt() -> None:
            held.set() if a._issue_for_peer(b"A", clock.now()) is None else None

        peer = threading.Thread(target=attempt)
        peer.start()
        peer.join(5.0)  # a peer never waits for the owner's lock
        a._write_lock.release()
        assert not peer.is_alive() and held.is_set()
    else:
        getattr(a._flags, why).set()
        assert a._issue_for_peer(b"A", clock.now()) is None
    assert link.written == []


def test_frames_a_peer_wrote_are_announced_and_counted_by_their_owner() -> None:
    # Two performers on one grid on the real clock: whichever thread wrote a frame, its owner
    # announces it (its data, planned time and schedule frame) and counts it before the next,
    # and the cue it played is the one progress shows. Nothing here depends on timing: which
    # writer issued which frame does (most are issued by a peer: test_executor).
    from xgo_show.runtime.events import FrameSent

    clock = MonotonicClock()
    group = IssueGroup()
    count = 20
    executors, seen = [], []
    for name in ("rex", "ivy"):
        link = Noting()
        link.open()
        ex = PerformerExecutor(make_performer(name, count=count, spacing=0.01), link,
                               clock=clock, profile=MINI, rest_at_end=False, group=group)
        rows: list[tuple[int | None, float | None, bytes, object, int, str]] = []

        def note(e: FrameSent, ex: PerformerExecutor = ex, rows: list = rows) -> None:  # type: ignore[type-arg]
            if e.kind == "frame":
                p = ex.progress
                rows.append((e.index, e.planned, e.data, e.frame, p.sent, p.cue))

        ex.events.subscribe(note, FrameSent)  # type: ignore[arg-type]
        executors.append(ex)
        seen.append(rows)
    start = play_together(executors, clock)
    for ex, rows in zip(executors, seen, strict=True):
        frames = ex.schedule.frames
        assert [r[0] for r in rows] == list(range(count))
        for i, (_, planned, data, frame, sent, cue) in enumerate(rows):
            assert planned == pytest.approx(start + frames[i].t, abs=1e-9)
            assert data == frames[i].data and frame is frames[i]
            # Announced before it counts: the frames before it, and the cue of the last.
            assert sent == i
            assert cue == ("" if i == 0 else frames[i - 1].origin.cue)  # type: ignore[union-attr]


def test_frames_without_a_cue_play_in_a_group_too() -> None:
    # Frames the compiler files under no cue (origin None), on the real clock: whichever
    # writer issues them, both performers play every frame and finish.
    from dataclasses import replace

    from xgo_show.compiler.schedule import ScheduledFrame
    from xgo_show.compiler.state import frame_labels
    from xgo_show.runtime.executor import ExecutorState

    clock = MonotonicClock()
    group = IssueGroup()
    executors, links = [], []
    for name in ("rex", "ivy"):
        schedule = make_performer(name, count=20, spacing=0.01)
        schedule = replace(schedule, frames=tuple(
            ScheduledFrame(f.t, f.data, None, labels=frame_labels(MINI))
            for f in schedule.frames))
        link = Noting()
        link.open()
        executors.append(PerformerExecutor(schedule, link, clock=clock, profile=MINI,
                                           rest_at_end=False, group=group))
        links.append(link)
    play_together(executors, clock)
    assert [ex.state for ex in executors] == [ExecutorState.FINISHED] * 2
    for ex, link in zip(executors, links, strict=True):
        assert link.written == [f.data for f in ex.schedule.frames]
        assert ex.progress.cue == ""


def test_a_performer_that_ends_first_is_sent_nothing_more_by_its_peer() -> None:
    # rex's 5 frames end long before ivy's 30 (one grid, the real clock): whoever wrote
    # rex's last frame, ivy's later writes never issue it again.
    clock = MonotonicClock()
    group = IssueGroup()
    executors, links = [], []
    for name, count in (("rex", 5), ("ivy", 30)):
        link = Noting()
        link.open()
        executors.append(PerformerExecutor(make_performer(name, count=count, spacing=0.01),
                                           link, clock=clock, profile=MINI, rest_at_end=False,
                                           group=group))
        links.append(link)
    play_together(executors, clock)
    for ex, link in zip(executors, links, strict=True):
        assert link.written == [f.data for f in ex.schedule.frames]


def test_a_writer_on_virtual_time_neither_issues_a_peers_frames_nor_arms_its_own() -> None:
    # Each fake clock jumps on its own: an instant of one is no instant of another, so an
    # executor on a FakeClock plays as if it had no group. Its thread alone runs: nothing
    # depends on timing.
    group = IssueGroup()
    peer, peer_link = _executor("peer", FakeClock())
    entry = group.arm(peer, 0.0, b"P")  # due long ago
    clock = FakeClock()
    link = Noting()
    link.open()
    ex = PerformerExecutor(make_performer("rex", count=3), link, clock=clock, profile=MINI,
                           rest_at_end=False, group=group)
    ex.start(clock.now())
    assert ex.join(10.0)
    assert link.written == [f.data for f in ex.schedule.frames]
    assert peer_link.written == [] and not entry.claimed
    assert group._armed == {peer: entry}


def test_a_writer_that_wrote_its_own_frames_leaves_nothing_armed() -> None:
    # One writer of a group on the real clock writes all its frames itself (no peer runs):
    # each taken back as it is written, so a peer's later write issues none of them again.
    # Deterministic: whenever each frame goes out, the writer writes it.
    clock = MonotonicClock()
    group = IssueGroup()
    link = Noting()
    link.open()
    ex = PerformerExecutor(make_performer("rex", count=5, spacing=0.002), link, clock=clock,
                           profile=MINI, rest_at_end=False, group=group)
    ex.start(clock.now())
    assert ex.join(10.0)
    frames = [f.data for f in ex.schedule.frames]
    assert link.written == frames
    w, _ = _executor("w", FakeClock())
    group.issue_due(w, clock.now() + 60.0)
    assert link.written == frames
