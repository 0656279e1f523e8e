"""Real-time scheduling of the writer threads: the one decision every command makes, the writer
that raises itself (and nothing else), the wait that never spins, the guard that lowers a
thread that does, and a process that may not have it (a real one, without CAP_SYS_NICE)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from xgo_show.errors import UsageError
from xgo_show.runtime import realtime
from xgo_show.runtime.clock import FakeClock, MonotonicClock
from xgo_show.runtime.events import FrameSent
from xgo_show.runtime.launch import local_runner

ROOT = Path(__file__).resolve().parents[2]


def _permitted() -> bool:
    return realtime._probe() == ""


needs_fifo = pytest.mark.skipif(
    not sys.platform.startswith("linux") or not _permitted(),
    reason="SCHED_FIFO is not permitted here (needs root, CAP_SYS_NICE or RLIMIT_RTPRIO)",
)


@pytest.fixture
def auto() -> Iterator[realtime.RealtimePolicy]:
    yield realtime.configure("auto")
    realtime.configure("off")


def _policy_of_thread() -> int:
    return os.sched_getscheduler(0)


def test_off_and_unknown_modes() -> None:
    assert not realtime.configure("off").granted
    assert realtime.configure("off").summary == "off (--no-realtime)"
    with pytest.raises(UsageError, match=r"'fast'.*auto, required, off"):
        realtime.configure("fast")


def test_the_environment_gives_the_mode_when_no_option_does(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setenv(realtime.ENV, "OFF")
    assert realtime.configure(None).mode == "off"
    monkeypatch.setenv(realtime.ENV, "sometimes")
    with pytest.raises(UsageError, match=f"from {realtime.ENV}"):
        realtime.configure(None)


def _policies(prefix: str) -> set[tuple[int, int]]:
    """(policy, priority) of this process's threads whose names start with ``prefix``."""
    return {(os.sched_getscheduler(th.native_id), os.sched_getparam(th.native_id).sched_priority)
            for th in threading.enumerate()
            if th.name.startswith(prefix) and th.native_id is not None and th.is_alive()}


@needs_fifo
def test_writers_readers_and_the_supervisor_are_raised_for_the_show_only(auto, rig, perf, sched) -> None:  # type: ignore[no-untyped-def]
    assert auto.granted and "SCHED_FIFO priority 10" in auto.summary
    schedule = sched(perf("rex", count=5, spacing=0.01), perf("ivy", count=5, spacing=0.01))
    rig.for_schedule(schedule)
    runner = local_runner(schedule, rig.transports)
    assert runner.performers["rex"].telemetry is not None  # a reader thread runs
    seen: dict[str, object] = {}
    show_thread = threading.get_native_id()

    def look(event: FrameSent) -> None:  # listeners run on the writer that sent the frame
        if event.kind != "frame" or event.index != 2:  # well into the show
            return
        seen[event.performer] = (_policy_of_thread(), os.sched_getparam(0).sched_priority)
        seen["readers"] = _policies("xgo-show reader")
        seen["supervisor"] = (os.sched_getscheduler(show_thread),
                              os.sched_getparam(show_thread).sched_priority)
        seen["other"] = _policies("Thread-") | _policies("ThreadPool")

    runner.events.subscribe(look, FrameSent)  # type: ignore[arg-type]
    assert runner.run(handle_signals=False).completed
    fifo = os.SCHED_FIFO
    assert seen["rex"] == seen["ivy"] == (fifo, realtime.PRIORITY)
    # Python's lock knows no priorities: the other threads that take it during the show sit
    # just below the writers, so no normal thread holds it while a writer waits.
    assert seen["readers"] == {(fifo, realtime.HELPER_PRIORITY)}
    assert seen["supervisor"] == (fifo, realtime.HELPER_PRIORITY)
    assert all(policy == os.SCHED_OTHER for policy, _ in seen["other"])  # type: ignore[attr-defined]
    assert _policy_of_thread() == os.SCHED_OTHER  # after the show, the thread that ran it


@needs_fifo
def test_a_writer_on_virtual_time_is_never_raised(auto, rig, perf, sched) -> None:  # type: ignore[no-untyped-def]
    schedule = sched(perf("rex", count=5, spacing=0.01))
    rig.for_schedule(schedule)
    runner = local_runner(schedule, rig.transports, clock=FakeClock(keep_waits=False))
    seen: list[int] = []
    runner.events.subscribe(lambda e: seen.append(_policy_of_thread()), FrameSent)
    assert runner.run(handle_signals=False).completed
    assert seen and set(seen) == {os.SCHED_OTHER}


@needs_fifo
def test_a_realtime_wait_blocks_instead_of_spinning(auto) -> None:
    # A clock told to spin for longer than each whole wait: outside FIFO every 5 ms wait would be
    # 5 ms of CPU (0.1 s for 20). Under FIFO it must block instead, costing only its wake-ups
    # (1-3 ms for 20, more on a loaded machine), so the line at 25 ms separates the two by a
    # wide margin on either side, whatever else this machine is doing.
    clock = MonotonicClock(spin=0.010)
    out: dict[str, float] = {}

    def body() -> None:
        assert realtime.enter_show_thread()
        try:
            cpu, lates = time.thread_time(), []
            for _ in range(20):
                deadline = clock.now() + 0.005
                assert clock.sleep_until(deadline, threading.Event())
                lates.append(clock.now() - deadline)
            out["cpu"] = time.thread_time() - cpu
            out["late"] = sorted(lates)[10]
            out["early"] = min(lates)
        finally:
            realtime.leave_show_thread()

    th = threading.Thread(target=body)
    th.start()
    th.join(5)
    assert out["early"] >= 0.0  # never before the deadline
    assert out["late"] < 0.001
    assert out["cpu"] < 0.025, out


@needs_fifo
def test_the_guard_lowers_a_raised_thread_that_spins(auto, capsys) -> None:  # type: ignore[no-untyped-def]
    out: dict[str, object] = {}

    def spinner() -> None:
        assert realtime.enter_show_thread()
        start = time.monotonic()
        # A bug that never blocks: the guard must notice within two of its periods.
        while os.sched_getscheduler(0) == os.SCHED_FIFO and time.monotonic() - start < 2.0:
            pass
        out["lowered_after"] = time.monotonic() - start
        out["policy"] = os.sched_getscheduler(0)
        realtime.leave_show_thread()

    th = threading.Thread(target=spinner)
    th.start()
    th.join(5)
    assert out["policy"] == os.SCHED_OTHER
    assert out["lowered_after"] < 3 * realtime.GUARD_PERIOD  # type: ignore[operator]
    assert "back to normal priority" in capsys.readouterr().err


@needs_fifo
def test_a_thread_that_waits_is_left_alone_by_the_guard(auto) -> None:
    out: list[int] = []

    def writer() -> None:
        realtime.enter_show_thread()
        clock = MonotonicClock()
        t0 = clock.now()
        for i in range(1, 60):  # 0.6 s of 100 Hz waits: more than two guard periods
            clock.sleep_until(t0 + i * 0.01)
        out.append(os.sched_getscheduler(0))
        realtime.leave_show_thread()
        out.append(os.sched_getscheduler(0))

    th = threading.Thread(target=writer)
    th.start()
    th.join(5)
    assert out == [os.SCHED_FIFO, os.SCHED_OTHER]


def _unprivileged(code: str) -> subprocess.CompletedProcess[str]:
    """``code`` in a real process without CAP_SYS_NICE (and RLIMIT_RTPRIO 0)."""
    env = {k: v for k, v in os.environ.items() if k != realtime.ENV}
    cmd = ["setpriv", "--bounding-set", "-sys_nice", "--inh-caps", "-sys_nice",
           "prlimit", "--rtprio=0", sys.executable, "-c", code]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env, timeout=30)


needs_setpriv = pytest.mark.skipif(
    subprocess.run(["sh", "-c", "command -v setpriv && command -v prlimit"],
                   capture_output=True).returncode != 0,
    reason="setpriv and prlimit (util-linux) drop CAP_SYS_NICE for the child",
)


@needs_setpriv
def test_not_permitted_auto_says_so_in_one_line_and_required_refuses() -> None:
    done = _unprivileged(
        "from xgo_show.runtime.realtime import decide\n"
        "p = decide(None)\n"
        "print(p.granted, p.summary)\n"
        "decide('required')\n"
    )
    assert done.stdout.startswith("False not permitted (Operation not permitted)"), done
    note = done.stderr.splitlines()[0]
    assert note.startswith("note: real-time scheduling not permitted (Operation not permitted)")
    assert "--no-realtime silences this" in note
    assert "--realtime: SCHED_FIFO is not permitted" in done.stderr
    assert done.returncode != 0


@needs_setpriv
def test_a_relay_with_realtime_required_stops_before_opening_its_ports() -> None:
    done = _unprivileged(
        "import sys; from xgo_show.cli.main import main\n"
        "sys.exit(main(['relay', '--realtime', '--map', 'rex=sim:mini', '--listen', "
        "'tcp/127.0.0.1:1']))\n"
    )
    assert done.returncode == 2, done
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "--realtime: SCHED_FIFO is not permitted" in lines[0], lines
    assert "Traceback" not in done.stderr


def test_realtime_and_no_realtime_exclude_each_other(capsys) -> None:  # type: ignore[no-untyped-def]
    from xgo_show.cli.main import main

    with pytest.raises(SystemExit):
        main(["dry-run", "x.yaml", "--realtime", "--no-realtime"])
    assert "not allowed with argument" in capsys.readouterr().err


def test_the_relay_child_of_run_gets_the_conductors_mode() -> None:
    from xgo_show.relay.child import RelayChild

    def flags(mode: str | None) -> list[str]:
        cmd = RelayChild({"rex": "/dev/null"}, {"rex": "mini"}, namespace="t", realtime=mode).cmd
        return [c for c in cmd if "realtime" in c]

    assert flags(None) == []  # auto (or XGO_SHOW_REALTIME, which the child inherits)
    assert flags("required") == ["--realtime"]
    assert flags("off") == ["--no-realtime"]


def test_leaving_a_thread_never_raised_does_nothing() -> None:
    realtime.leave_show_thread()
    assert _policy_of_thread() == os.SCHED_OTHER
