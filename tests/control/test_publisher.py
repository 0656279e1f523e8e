"""The event publisher's bounds: noisy events over the rate are counted and summed up in one
warning when their window ends; a full queue drops its oldest event, counted."""

from __future__ import annotations

import threading
import time
from typing import Any

from xgo_show.control.publisher import EventPublisher
from xgo_show.runtime.clock import MonotonicClock


class Sink:
    """Collects what the publisher puts; ``gate`` holds the publisher thread while cleared."""

    def __init__(self) -> None:
        self.sent: list[tuple[str, dict[str, Any]]] = []
        self.gate = threading.Event()
        self.gate.set()

    def put(self, key: str, payload: dict[str, Any]) -> None:
        self.gate.wait(5.0)
        self.sent.append((key, payload))


def _until(predicate: Any, timeout: float = 2.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline
        time.sleep(0.005)


def test_noisy_events_over_the_rate_are_counted_then_summed_up() -> None:
    sink = Sink()
    pub = EventPublisher("ns", sink.put, clock=MonotonicClock(), noisy_per_second=10,
                         window=0.2)  # two noisy events per 0.2 s window
    try:
        published = [pub.publish_noisy("trigger", trigger="x", accepted=False, reason="no")
                     for _ in range(50)]
        assert published == [True, True] + [False] * 48
        assert pub.suppressed == 48
        # No further event needed: the publisher says it when the window ends.
        _until(lambda: any(p["event"] == "warning" for _, p in sink.sent))
        warnings = [p for k, p in sink.sent if k == "ns/event/warning"]
        assert [w["suppressed"] for w in warnings] == [48]
        assert [p["event"] for _, p in sink.sent].count("trigger") == 2
        time.sleep(0.25)  # a new window: two more go out
        assert pub.publish_noisy("trigger", trigger="x", accepted=False, reason="no")
    finally:
        pub.close()


def test_a_full_queue_drops_its_oldest_events_and_counts_them() -> None:
    sink = Sink()
    sink.gate.clear()  # a subscriber so slow the publisher thread cannot send
    pub = EventPublisher("ns", sink.put, clock=MonotonicClock(), maxlen=5)
    try:
        pub.publish("state", n=0)
        _until(lambda: not pub._queue)  # the thread holds event 0, blocked in put
        for n in range(1, 21):
            pub.publish("state", n=n)
        assert pub.dropped == 15
        sink.gate.set()
        _until(lambda: len(sink.sent) == 6)
        assert [p["n"] for _, p in sink.sent] == [0, 16, 17, 18, 19, 20]
    finally:
        pub.close()
