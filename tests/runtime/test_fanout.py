"""The bounded fan-out the launch opens, checks and closes its endpoints with."""

from __future__ import annotations

import threading

import pytest

from xgo_show.runtime.fanout import each


def test_the_calls_overlap_and_the_results_keep_the_items_order() -> None:
    together = threading.Barrier(4, timeout=5)  # broken unless all four wait at once

    def call(i: int) -> int:
        together.wait()
        return i * 10

    assert each(call, [3, 1, 2, 0]) == [30, 10, 20, 0]


def test_no_more_than_the_limit_run_at_once() -> None:
    running, most, lock = 0, 0, threading.Lock()
    gate = threading.Barrier(2, timeout=5)

    def call(i: int) -> int:
        nonlocal running, most
        with lock:
            running += 1
            most = max(most, running)
        gate.wait()  # two at a time reach this together, and only two
        with lock:
            running -= 1
        return i

    assert each(call, list(range(6)), limit=2) == list(range(6))
    assert most == 2


def test_a_failure_waits_for_the_others_and_undoes_every_success() -> None:
    finished: list[int] = []
    undone: list[int] = []
    slow = threading.Event()

    def call(i: int) -> int:
        if i == 1:
            raise LookupError("one failed")
        if i == 3:
            slow.wait(0.2)  # still running when the failure is known
        finished.append(i)
        return i

    with pytest.raises(LookupError, match="one failed"):
        each(call, [0, 1, 2, 3], undo=undone.append)
    assert sorted(finished) == [0, 2, 3] and sorted(undone) == [0, 2, 3]


def test_the_first_failure_in_the_items_order_is_raised() -> None:
    def call(i: int) -> int:
        raise ValueError(f"item {i}")

    with pytest.raises(ValueError, match="item 0"):
        each(call, [0, 1, 2])
