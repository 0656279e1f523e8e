"""Run ``xgo-show`` with one thing of a relay process changed, for measuring (test-only).

``benchmarks/delivery_trace.py`` starts its relays through this script to take a relayed
robot's extra cost apart one thing at a time, in the same run as the relays as shipped::

    python benchmarks/relay_variants.py [--threads FILE] [--variant NAME] [--handoff-us N] \\
        -- relay --name r0 --map robot0=/dev/pts/5 ...

``--threads FILE`` appends ``NATIVE_ID NAME`` for the main thread and for every Python thread
the process starts (a relay's Python threads all have the process's name in /proc, Zenoh's have
their own: ``rx-0``, ``tx-0``...), so a scheduler trace can say which thread ran.
``--variant`` (see :data:`VARIANTS`) changes one thing before the command runs; ``base`` changes
nothing. Nothing here is used by ``xgo-show`` itself.
"""

from __future__ import annotations

import argparse
import sys
import threading
from collections.abc import Callable
from typing import Any


def name_threads(path: str) -> None:
    """Append each Python thread's native id and name to ``path`` as it starts (the main
    thread's now): once per thread, nothing while it runs."""

    def note(name: str) -> None:
        with open(path, "a", encoding="utf-8") as out:
            out.write(f"{threading.get_native_id()} {name.replace(' ', '_')}\n")

    note("MainThread")
    inner: Any = threading.Thread._bootstrap_inner  # type: ignore[attr-defined]

    def bootstrap(self: threading.Thread) -> None:
        note(self.name)
        inner(self)

    threading.Thread._bootstrap_inner = bootstrap  # type: ignore[attr-defined]


def read_threads(path: str) -> dict[int, str]:
    """What :func:`name_threads` wrote: native id -> name (the latest name of a reused id)."""
    out: dict[int, str] = {}
    try:
        with open(path, encoding="utf-8") as f:
            for line in f:
                tid, _, name = line.strip().partition(" ")
                if tid.isdigit():
                    out[int(tid)] = name
    except OSError:
        pass
    return out


def _no_bookkeeping() -> None:
    """The relay's run log and event collector get nothing: no bookkeeping thread, no queueing
    and no kernel timer armed after each write (the conductor's heartbeats still get the
    show's state, which is all delivery_trace asks)."""
    from xgo_show.relay import server

    class Nothing:
        def __init__(self, *args: object, **kwargs: object) -> None:
            pass

        def flush(self, timeout: float = 2.0) -> bool:
            return True

        def close(self) -> None:
            pass

    server.__dict__["DeferredListeners"] = Nothing


def _plain_clock() -> None:
    """The executors read this machine's monotonic clock itself, not a slewing clock over it
    (the conductor is on this machine: its timebase is this clock, give or take its bound)."""
    from xgo_show.relay import server
    from xgo_show.runtime.clock import MonotonicClock

    class Plain(MonotonicClock):
        def __init__(self, base: object, **kwargs: object) -> None:
            super().__init__()
            self.timebase = None

        def follow(self, timebase: object) -> float:
            return 0.0

        def reset(self) -> None:
            pass

        def error(self) -> float:
            return 0.0

    server.__dict__["SlewingClock"] = Plain


def _no_tracer() -> None:
    """No test tracer (``XGO_SHOW_TEST_TRACE``): the writes' times come from the kernel's
    trace instead."""
    from xgo_show.relay import server

    class Off:
        def __init__(self, *args: object, **kwargs: object) -> None:
            pass

        def close(self) -> None:
            pass

    server.__dict__["StartTracer"] = Off


#: name -> what it changes in the relay process before ``xgo-show`` runs
VARIANTS: dict[str, Callable[[], None]] = {
    "base": lambda: None,
    "no-bookkeeping": _no_bookkeeping,
    "plain-clock": _plain_clock,
    "no-tracer": _no_tracer,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", metavar="FILE")
    parser.add_argument("--variant", choices=sorted(VARIANTS), default="base")
    parser.add_argument("--handoff-us", type=float, default=0.0)
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    if args.threads:
        name_threads(args.threads)
    if args.handoff_us:
        from xgo_show.runtime import clock

        clock.HANDOFF = args.handoff_us * 1e-6
    VARIANTS[args.variant]()
    from xgo_show.cli.main import program

    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    sys.argv = ["xgo-show", *command]
    program()


if __name__ == "__main__":
    main()
