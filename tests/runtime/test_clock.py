"""The real clock's waits and the real-time hand-off, in a SCHED_FIFO thread where permitted."""

from __future__ import annotations

import os
import threading
import time

import pytest

from xgo_show.runtime.clock import HANDOFF, MonotonicClock, hand_off_cpu, is_realtime


def _in_fifo_thread(fn: object) -> dict[str, object]:
    """Run ``fn`` in a new thread switched to SCHED_FIFO priority 1; skip where refused."""
    out: dict[str, object] = {}

    def body() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
        except (AttributeError, OSError) as exc:
            out["refused"] = str(exc)
            return
        out["result"] = fn()  # type: ignore[operator]

    th = threading.Thread(target=body)
    th.start()
    th.join(10)
    if "refused" in out:
        pytest.skip(f"SCHED_FIFO not permitted here: {out['refused']}")
    return out


def test_normal_thread_is_not_realtime_and_does_not_hand_off() -> None:
    assert not is_realtime()
    t0 = time.perf_counter()
    for _ in range(200):
        hand_off_cpu()
    # 200 hand-offs of 50 us would take 10 ms at the very least.
    assert time.perf_counter() - t0 < 200 * HANDOFF


def test_realtime_thread_hands_off_its_cpu_after_a_write() -> None:
    def work() -> tuple[bool, float]:
        t0 = time.perf_counter()
        hand_off_cpu()
        return is_realtime(), time.perf_counter() - t0

    realtime, took = _in_fifo_thread(work)["result"]  # type: ignore[misc]
    assert realtime
    assert took >= HANDOFF


def test_realtime_thread_wakes_on_time_never_early() -> None:
    clock = MonotonicClock()

    def work() -> list[float]:
        errors = []
        for _ in range(20):
            deadline = clock.now() + 0.003
            clock.sleep_until(deadline)
            errors.append(clock.now() - deadline)
        return errors

    errors: list[float] = _in_fifo_thread(work)["result"]  # type: ignore[assignment]
    assert min(errors) >= 0.0
    assert sorted(errors)[len(errors) // 2] < 0.001
