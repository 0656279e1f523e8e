"""``xgo-show relay --realtime``: the writer threads run under SCHED_FIFO, Zenoh's do not (a
real-time Zenoh thread answering heartbeats would compete with the writers at their own
priority). Read from the relay process's threads in /proc, before and during a show."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import pytest

from tests.relay.conftest import claim


def fifo_threads(pid: int) -> int:
    """How many of ``pid``'s threads run under SCHED_FIFO or SCHED_RR."""
    count = 0
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            policy = os.sched_getscheduler(int(task.name))
        except (ProcessLookupError, PermissionError):
            continue  # the thread ended meanwhile
        count += policy in (os.SCHED_FIFO, os.SCHED_RR)
    return count


def test_only_the_show_threads_are_real_time(
    relays, conductor_session, walk, as_upload, until
) -> None:  # type: ignore[no-untyped-def]
    if not sys.platform.startswith("linux"):
        pytest.skip("thread scheduling policies are read from Linux's /proc")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except PermissionError:
        pytest.skip("SCHED_FIFO is not permitted here (needs root or CAP_SYS_NICE)")
    relay = relays.start("rt", {"rex": "mini"}, "--realtime")
    client = claim(conductor_session(relay), relay)
    assert fifo_threads(relay.proc.pid) == 0  # Zenoh's threads, the main thread: normal
    show = walk(1.0, rex="mini")
    text, sha = as_upload(show)
    client.upload(text, sha)
    client.start(sha, time.monotonic() + 0.3)
    # the writer thread (and the guard that watches it); not the show thread, not Zenoh's
    assert until(lambda: fifo_threads(relay.proc.pid) >= 1, 2.0)
    until(lambda: client.command("heartbeat")["show"]["state"] == "ended", 5.0)
    assert until(lambda: fifo_threads(relay.proc.pid) == 0, 1.0)  # the guard ends with them
    client.stop_heartbeat()
