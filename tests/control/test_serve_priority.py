"""Zenoh's receiving threads, which run serve's trigger handlers, at real-time priority while a
show plays and only then (a real serve process, its threads read from /proc), and the realtime
hook that raises a thread Python did not start, under the same guard as the writers."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import zenoh

from tests.children import exited
from tests.control.conftest import control_session
from tests.loopback import free_port
from xgo_show.control.client import ControlClient
from xgo_show.runtime import realtime

NS = "priority-test"

needs_fifo = pytest.mark.skipif(
    not sys.platform.startswith("linux") or realtime._probe() != "",
    reason="SCHED_FIFO is not permitted here (needs root, CAP_SYS_NICE or RLIMIT_RTPRIO)",
)


def _until(check: Callable[[], bool], timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def _threads(pid: int, prefix: str) -> dict[int, tuple[int, int]]:
    """Process ``pid``'s threads named ``prefix``...: kernel id -> (policy, priority)."""
    out = {}
    for task in os.listdir(f"/proc/{pid}/task"):
        tid = int(task)
        try:
            name = Path(f"/proc/{pid}/task/{task}/comm").read_text()
            if name.startswith(prefix):
                out[tid] = (os.sched_getscheduler(tid), os.sched_getparam(tid).sched_priority)
        except (OSError, ProcessLookupError):
            continue  # ended meanwhile
    return out


@pytest.fixture
def auto() -> Iterator[realtime.RealtimePolicy]:
    yield realtime.configure("auto")
    realtime.configure("off")


@needs_fifo
def test_serves_receiving_threads_are_raised_while_a_show_plays(triggered_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "serve", "--sim", "--load", str(triggered_path),
         "--listen", endpoint, "--namespace", NS, "--no-telemetry"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, realtime.ENV: "auto"},
    )
    try:
        with control_session(proc, endpoint, NS) as session:
            client = ControlClient(session, NS, timeout=5.0)
            before = _threads(proc.pid, "rx-")
            assert before and all(p == os.SCHED_OTHER for p, _ in before.values())
            client.command("start")
            _until(lambda: client.status()["state"] == "waiting")
            during = _threads(proc.pid, "rx-")
            assert during and all(v == (os.SCHED_FIFO, realtime.HELPER_PRIORITY)
                                  for v in during.values()), during
            # ... the threads of its session's other runtimes stay as they were
            assert all(p == os.SCHED_OTHER for p, _ in _threads(proc.pid, "tx-").values())
            client.trigger("go")
            _until(lambda: client.status()["state"] == "waiting")
            client.trigger("encore")
            _until(lambda: client.status()["state"] in ("loaded", "idle"))
            after = _threads(proc.pid, "rx-")
            assert after and all(p == os.SCHED_OTHER for p, _ in after.values()), after
    finally:
        proc.terminate()
        out = exited(proc, 10)
    assert proc.returncode == 0, out


def _connected_pair() -> tuple[zenoh.Session, zenoh.Session]:
    def config(listen: list[str], connect: list[str]) -> zenoh.Config:
        c = zenoh.Config()
        c.insert_json5("scouting/multicast/enabled", "false")
        c.insert_json5("listen/endpoints", json.dumps(listen))
        c.insert_json5("connect/endpoints", json.dumps(connect))
        return c

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    a = zenoh.open(config([endpoint], []))
    b = zenoh.open(config([], [endpoint]))
    return a, b


@needs_fifo
def test_zenoh_threads_are_found_by_name_raised_and_lowered(auto) -> None:  # type: ignore[no-untyped-def]
    a, b = _connected_pair()
    try:
        got: list[int] = []
        sub = a.declare_subscriber("prio/x", zenoh.handlers.Callback(
            lambda s: got.append(threading.get_native_id()), indirect=False))
        time.sleep(0.3)  # the link is up
        rx = realtime.threads_named("rx-")
        assert rx and realtime.threads_named("no such thread-") == []
        for tid in rx:
            assert realtime.raise_thread(tid)
            assert os.sched_getscheduler(tid) == os.SCHED_FIFO
            assert os.sched_getparam(tid).sched_priority == realtime.HELPER_PRIORITY
        b.put("prio/x", b"1")
        _until(lambda: bool(got))
        assert got[0] in rx  # a direct handler runs on one of them
        for tid in rx:
            realtime.lower_thread(tid)
            assert os.sched_getscheduler(tid) == os.SCHED_OTHER
        realtime.lower_thread(rx[0])  # twice: nothing to do
        sub.undeclare()
    finally:
        b.close()  # type: ignore[no-untyped-call]
        a.close()  # type: ignore[no-untyped-call]


def test_nothing_is_raised_when_realtime_is_off() -> None:
    realtime.configure("off")
    assert realtime.raise_thread(threading.get_native_id()) is False
    assert os.sched_getscheduler(0) == os.SCHED_OTHER


@needs_fifo
def test_the_guard_lowers_a_thread_raised_from_outside_that_spins(auto, capsys) -> None:  # type: ignore[no-untyped-def]
    ready, stop = threading.Event(), threading.Event()
    native: list[int] = []

    def spinner() -> None:
        native.append(threading.get_native_id())
        ready.set()
        while not stop.is_set():  # a flood's handler that never rests
            pass

    th = threading.Thread(target=spinner)
    th.start()
    try:
        ready.wait(5)
        assert realtime.raise_thread(native[0])
        start = time.monotonic()
        _until(lambda: os.sched_getscheduler(native[0]) == os.SCHED_OTHER, timeout=3.0)
        assert time.monotonic() - start < 3 * realtime.GUARD_PERIOD
    finally:
        stop.set()
        th.join(5)
    assert "back to normal priority" in capsys.readouterr().err
