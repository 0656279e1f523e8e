"""One call per item on a bounded pool of threads, every call waited for.

The launch opens, checks and closes its endpoints (relay hosts, local ports) this way: each
one mostly waits (a network round trip, a robot's answer), so set-up takes about as long as the
slowest endpoint instead of the sum of them all.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, wait
from typing import TypeVar

__all__ = ["MAX_WORKERS", "each"]

#: Threads at most per call of :func:`each` (the calls mostly wait; more only adds threads).
MAX_WORKERS = 16

_T = TypeVar("_T")
_R = TypeVar("_R")


def each(
    fn: Callable[[_T], _R],
    items: Sequence[_T],
    *,
    undo: Callable[[_R], object] | None = None,
    limit: int = MAX_WORKERS,
    name: str = "xgo-show fan-out",
) -> list[_R]:
    """``fn(item)`` for every item, at most ``limit`` at a time; the results in ``items``' order.

    Every call runs to its end even when another raises; then the first exception in
    ``items``' order is raised, after ``undo(result)`` for every call that did succeed (so
    nothing one call opened is left open because another failed). On an interrupt (Ctrl-C)
    the calls not yet begun are dropped and the running ones waited for and undone before it
    propagates. A single item runs in the caller's thread.
    """
    if len(items) <= 1:
        return [fn(item) for item in items]
    pool = ThreadPoolExecutor(max_workers=max(1, min(limit, len(items))), thread_name_prefix=name)
    futures = [pool.submit(fn, item) for item in items]
    try:
        wait(futures)
        errors = [f.exception() for f in futures]
        first = next((e for e in errors if e is not None), None)
        if first is None:
            return [f.result() for f in futures]
        raise first
    except BaseException:
        pool.shutdown(wait=True, cancel_futures=True)
        if undo is not None:
            for f in futures:
                if not f.cancelled() and f.exception() is None:
                    undo(f.result())
        raise
    finally:
        pool.shutdown(wait=True)
