"""Suite-wide fixtures.

Every test must clean up the threads it starts (pty servers, reader threads, runtimes): a
non-daemon thread left running keeps the interpreter alive and leaks into later tests. The
check is cheap: one ``threading.enumerate()`` before and after, plus a short grace period only
when a new thread is still alive.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest

pytest_plugins = ["pytester"]  # lets tests/test_thread_leak_check.py run this check itself

# A thread that is shutting down as the test ends gets this long to finish.
_GRACE_S = 1.0


@pytest.fixture(autouse=True)
def _no_leaked_threads() -> Iterator[None]:
    before = set(threading.enumerate())
    yield
    leaked = _new_live_threads(before)
    if not leaked:
        return
    deadline = time.monotonic() + _GRACE_S
    for thread in leaked:
        thread.join(max(0.0, deadline - time.monotonic()))
    leaked = _new_live_threads(before)
    if leaked:
        names = ", ".join(sorted(t.name for t in leaked))
        pytest.fail(f"test left non-daemon threads running: {names}", pytrace=False)


def _new_live_threads(before: set[threading.Thread]) -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t not in before and t.is_alive() and not t.daemon]
