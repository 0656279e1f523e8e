"""Suite-wide fixtures.

``wait(predicate)`` polls for something another thread or process does (a pty server, a
vendor library that does not wait for its replies). ``relays`` starts ``xgo-show relay``
processes (for the relay, control and behave tests) and ``conductor_session`` connects to them;
tests/loopback.py puts Zenoh on 127.0.0.1 with explicit endpoints.

Every test must clean up the threads it starts (pty servers, reader threads, runtimes): a
non-daemon thread left running keeps the interpreter alive and leaks into later tests, and one
of the runtime's own threads (named ``xgo-show ...``: writers, readers, pty servers, relays),
daemon or not, left running means a runtime was not closed. The check is cheap: one
``threading.enumerate()`` before and after, plus a short grace period only when a new thread
is still alive.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator

import pytest
import zenoh
from hypothesis import settings

from tests.relay.processes import RelayProcess, Relays
from xgo_show.net.session import SessionOptions, open_session

# scripts/mutation.sh runs the tests with --hypothesis-profile=mutation: mutmut's tracing slows
# every call, so a per-example deadline would fail clean code, and derandomized examples make
# every mutant meet the same ones (a kill rate that does not change from run to run).
settings.register_profile("mutation", deadline=None, derandomize=True)

pytest_plugins = ["pytester"]  # lets tests/test_thread_leak_check.py run this check itself

# Commands raise their writer threads to SCHED_FIFO by default where permitted (root here): the
# suite opts out, for itself and every command it starts as a process, because eight suites
# share this machine and the tests check behaviour, not timing. tests/runtime/test_realtime.py
# and the tests that pass --realtime opt back in. XGO_SHOW_REALTIME=auto runs the suite with it.
os.environ.setdefault("XGO_SHOW_REALTIME", "off")

# A child process that hangs is sent SIGABRT (tests/children.py): with this, every child the
# suite starts prints all its threads' stacks then, which says where it hung.
os.environ.setdefault("PYTHONFAULTHANDLER", "1")

# Tests send SIGINT to the commands they start, as Ctrl-C would. A non-interactive shell starts
# a background job (`flock ... &`) with SIGINT ignored, and an ignored SIGINT is inherited by
# every child: Python then never raises KeyboardInterrupt, and `behave`, `run` and the rest
# would never see their Ctrl-C. With a handler here, each child starts with SIGINT's default.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True)
def _realtime_policy_restored() -> Iterator[None]:
    """A test that configured real-time scheduling leaves the process's policy as it was."""
    from xgo_show.runtime import realtime

    before = realtime.policy()
    yield
    if realtime.policy() is not before:
        realtime.restore(before)


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
        pytest.fail(f"test left threads running: {names}", pytrace=False)


def _new_live_threads(before: set[threading.Thread]) -> list[threading.Thread]:
    return [
        t
        for t in threading.enumerate()
        if t not in before and t.is_alive() and (not t.daemon or t.name.startswith("xgo-show"))
    ]


def wait_until(predicate: Callable[[], object], timeout: float = 2.0) -> float:
    """Poll ``predicate`` every 5 ms until it holds; fail after ``timeout`` seconds. Returns
    the monotonic time it was first seen to hold."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("the condition did not hold in time")
        time.sleep(0.005)
    return time.monotonic()


def starved_ms(records: list[dict[str, object]], *, window: float = 0.5) -> float:
    """The worst issue lateness (ms, >= 0) of the scheduled frames in a run log's last
    ``window`` seconds of show: how much the machine was starving the show just before it
    ended. A deadline a test checks on a shared machine (the suite runs beside others at load
    8-16) takes this on top, as a stop or a reaction is delayed as the frames were."""
    frames = [r for r in records if r["kind"] == "frame" and r["send"] == "frame"]
    last = max(float(r["actual"]) for r in frames)  # type: ignore[arg-type]
    return max(0.0, *(1000 * (float(r["actual"]) - float(r["planned"]))  # type: ignore[arg-type]
                      for r in frames if float(r["actual"]) > last - window))  # type: ignore[arg-type]


@pytest.fixture
def wait() -> Callable[[Callable[[], bool]], None]:
    """``wait(predicate, timeout=2.0)``: :func:`wait_until` as a fixture."""
    return wait_until


@pytest.fixture
def relays() -> Iterator[Relays]:
    """Starts ``xgo-show relay`` processes; stops them and their simulators at the end."""
    r = Relays()
    try:
        yield r
    finally:
        r.close()


@pytest.fixture
def conductor_session() -> Iterator[Callable[..., zenoh.Session]]:
    """``open(*relays)``: a Zenoh session connected to those relays (closed at the end)."""
    opened: list[zenoh.Session] = []

    def open_(*targets: RelayProcess) -> zenoh.Session:
        session = open_session(
            SessionOptions(connect=tuple(r.endpoint for r in targets), listen=())
        )
        opened.append(session)
        return session

    yield open_
    for session in opened:
        session.close()
