"""The bounded fan-out the launch opens, checks and closes its endpoints with."""

from __future__ import annotations

import threading
import time

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


def test_a_single_item_runs_in_the_callers_thread() -> None:
    where: list[tuple[int, str]] = []

    def call(i: int) -> int:
        where.append((i, threading.current_thread().name))
        return i * 10

    assert each(call, [4]) == [40]
    assert where == [(4, threading.current_thread().name)]
    assert each(call, []) == []


def test_two_items_already_run_at_once_on_named_threads() -> None:
    together = threading.Barrier(2, timeout=5)
    names: list[str] = []

    def call(i: int) -> int:
        together.wait()
        names.append(threading.current_thread().name)
        return i

    assert each(call, [1, 2]) == [1, 2]
    # Named, so that a thread dump shows what a stuck thread was doing.
    assert len(names) == 2 and all(n.startswith("xgo-show fan-out") for n in names)
    assert each(call, [1, 2], name="open ports") == [1, 2]
    assert all(n.startswith("open ports") for n in names[2:])


@pytest.mark.parametrize("limit", [1, 2])
def test_never_one_more_than_the_limit_at_once(limit: int) -> None:
    # limit + 1 parties never meet: every call finds the barrier broken (the first after its
    # timeout, the others at once).
    crowd = threading.Barrier(limit + 1, timeout=0.5)

    def call(i: int) -> bool:
        try:
            crowd.wait()
        except threading.BrokenBarrierError:
            return False
        return True

    assert each(call, list(range(limit + 3)), limit=limit) == [False] * (limit + 3)


def test_no_thread_is_left_running_after_it_returns_or_raises() -> None:
    def call(i: int) -> int:
        if i == 2:
            raise ValueError("no")
        return i

    def ours() -> list[threading.Thread]:
        return [t for t in threading.enumerate() if t.name.startswith("left behind")]

    assert each(call, [0, 1], name="left behind") == [0, 1]
    assert ours() == []
    with pytest.raises(ValueError):
        each(call, [0, 1, 2, 3], name="left behind")
    assert ours() == []


def test_an_interrupt_drops_the_calls_not_begun_and_undoes_the_running_one() -> None:
    import signal

    main = threading.main_thread().ident
    assert main == threading.get_ident()  # the interrupt goes to this (the main) thread
    begun: list[int] = []
    undone: list[int] = []

    def call(i: int) -> int:
        begun.append(i)
        if i == 0:
            time.sleep(0.1)  # the caller is waiting by now
            signal.pthread_kill(main, signal.SIGINT)  # Ctrl-C
            time.sleep(0.2)  # still running when the interrupt arrives
        return i

    with pytest.raises(KeyboardInterrupt):
        each(call, [0, 1, 2, 3, 4], undo=undone.append, limit=1)
    assert begun == [0] and undone == [0]
