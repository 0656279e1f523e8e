"""Clock sync over real Zenoh sessions: a skewed relay clock measured, tracked and followed."""

from __future__ import annotations

import json
import time
from collections.abc import Callable

import pytest
import zenoh

from xgo_show.errors import XgoShowError
from xgo_show.net.offset import Timebase
from xgo_show.net.slew import SlewingClock
from xgo_show.net.testhooks import DelayInjector, SkewedClock
from xgo_show.net.timesync import (
    ClockTracker,
    TimeSyncError,
    TrackerUpdate,
    measure,
    serve_time,
)
from xgo_show.runtime.clock import MonotonicClock

KEY = "xgo-show-test/relay/r1/time"
Pair = tuple[zenoh.Session, zenoh.Session]


def _reachable(session: zenoh.Session, wait: Callable[..., None]) -> None:
    """Wait until the queryable's declaration has reached the other session."""

    def answered() -> bool:
        replies = session.get(KEY, payload=b'{"v":1,"op":"ping","seq":0}', timeout=0.2)
        return any(r.ok is not None for r in replies)

    wait(answered, timeout=5.0)


def _truth(relay_clock: SkewedClock) -> float:
    """The relay clock minus this machine's, now (from one reading: no preemption between)."""
    t = relay_clock.now()
    return t - relay_clock.to_base(t)


def _show_clock_error(show_clock: SlewingClock) -> float:
    """How far the show clock is from this machine's clock: the smallest of a few paired
    readings (a thread preempted between the two readings of a pair only adds to it)."""
    pairs = [(show_clock.now(), time.monotonic()) for _ in range(20)]
    return min((abs(c - m) for c, m in pairs), key=abs)


def test_a_measured_offset_is_within_its_bound(zenoh_pair: Pair, wait: Callable[..., None]) -> None:
    relay, conductor = zenoh_pair
    relay_clock = SkewedClock(MonotonicClock(), offset=12.5, ppm=100.0)
    server = serve_time(relay, KEY, relay_clock)
    try:
        _reachable(conductor, wait)
        est = measure(conductor, KEY, n=25)
    finally:
        server.close()
    assert est.samples == 25
    assert est.consistent
    assert abs(est.offset - _truth(relay_clock)) <= est.bound + 100e-6 * 1.0
    assert est.bound < 0.005  # loopback: a fraction of a millisecond unless the machine is busy


def test_an_injected_one_way_delay_shows_in_the_bound_not_as_a_hidden_error(
    zenoh_pair: Pair, wait: Callable[..., None]
) -> None:
    relay, conductor = zenoh_pair
    relay_clock = SkewedClock(MonotonicClock(), offset=-3.0)
    server = serve_time(relay, KEY, relay_clock, delay=DelayInjector(0.005, 0.002, seed=1))
    try:
        _reachable(conductor, wait)
        est = measure(conductor, KEY, n=15)
    finally:
        server.close()
    error = est.offset - _truth(relay_clock)
    assert abs(error) <= est.bound
    assert est.bound >= 0.0015  # every reply took 3 ms or more: half of it cannot be told apart
    assert error < -0.001  # and the estimate is off that way, as the bound says it may be


def test_the_tracker_keeps_a_drifting_relays_show_clock_on_the_conductors_time(
    zenoh_pair: Pair, wait: Callable[..., None]
) -> None:
    relay, conductor = zenoh_pair
    base = SkewedClock(MonotonicClock(), offset=40.0, ppm=400.0)  # 0.4 ms off per second
    show_clock = SlewingClock(base)
    followed: list[tuple[Timebase, str]] = []

    def take(tb: Timebase, who: str) -> float:
        followed.append((tb, who))
        return show_clock.follow(tb)

    updates: list[TrackerUpdate] = []
    server = serve_time(relay, KEY, base, on_timebase=take)
    tracker = ClockTracker(conductor, KEY, conductor="c-1", interval=0.1, on_update=updates.append)
    try:
        _reachable(conductor, wait)
        first = tracker.start()
        assert _show_clock_error(show_clock) <= first.bound + 0.0005
        wait(lambda: len(updates) >= 12, timeout=10.0)
        error = _show_clock_error(show_clock)
    finally:
        tracker.close()
        server.close()
    assert all(u.pushed for u in updates)
    assert {who for _, who in followed} == {"c-1"}
    assert error < 0.001
    newest = updates[-1].timebase
    assert abs(newest.rate - 400e-6) <= newest.rate_bound + 1e-6


def test_a_refused_timebase_fails_the_start_with_the_relays_reason(
    zenoh_pair: Pair, wait: Callable[..., None]
) -> None:
    relay, conductor = zenoh_pair

    def refuse(tb: Timebase, who: str) -> None:
        raise XgoShowError(f"conductor {who} does not hold this relay")

    server = serve_time(relay, KEY, MonotonicClock(), on_timebase=refuse)
    tracker = ClockTracker(conductor, KEY, conductor="intruder", first=3)
    try:
        _reachable(conductor, wait)
        with pytest.raises(TimeSyncError, match="conductor intruder does not hold this relay"):
            tracker.start()
    finally:
        tracker.close()
        server.close()


@pytest.mark.parametrize(
    ("payload", "message"),
    [
        (b"\xff not json", "not JSON"),
        (b"[1, 2]", "not a JSON object"),
        (b'{"v": 2, "op": "ping"}', "version 2"),
        (b'{"v": 1, "op": "set"}', "op 'set'"),
        (json.dumps({"v": 1, "op": "timebase", "offset": "x"}).encode(), "'offset'"),
        (b"{" + b" " * 2000 + b"}", "at most 1024"),
    ],
)
def test_bad_requests_get_an_error_reply_and_the_server_keeps_serving(
    zenoh_pair: Pair, wait: Callable[..., None], payload: bytes, message: str
) -> None:
    relay, conductor = zenoh_pair
    server = serve_time(relay, KEY, MonotonicClock())
    try:
        _reachable(conductor, wait)
        replies = list(conductor.get(KEY, payload=payload, timeout=1.0))
        assert len(replies) == 1 and replies[0].err is not None
        assert message in replies[0].err.payload.to_bytes().decode()
        assert measure(conductor, KEY, n=2).samples == 2
    finally:
        server.close()


def test_no_server_is_one_clear_error(zenoh_pair: Pair) -> None:
    _, conductor = zenoh_pair
    with pytest.raises(TimeSyncError, match=r"no answer to 2 time-sync pings within 0\.1 s"):
        measure(conductor, KEY, n=2, timeout=0.1)


def test_a_relay_holds_off_before_each_answer_and_the_estimate_leaves_the_wait_out(
    zenoh_pair: Pair, wait: Callable[..., None]
) -> None:
    relay, conductor = zenoh_pair
    relay_clock = SkewedClock(MonotonicClock(), offset=-3.0, ppm=0.0)
    held: list[float] = []

    def hold_off() -> None:  # as a relay's clock does while a writer is due: 50 ms here
        held.append(time.monotonic())
        time.sleep(0.05)

    server = serve_time(relay, KEY, relay_clock, hold_off=hold_off)
    try:
        _reachable(conductor, wait)
        held.clear()
        est = measure(conductor, KEY, n=5)
    finally:
        server.close()
    assert len(held) == 5  # once per answer, between its two stamps:
    assert est.samples == 5 and est.consistent
    assert abs(est.offset - _truth(relay_clock)) <= est.bound
    # not the 25 ms or more that half a held round trip would be (the lowest of 5 loopback
    # round trips stays far under 40 ms even on a loaded machine)
    assert est.bound < 0.02
