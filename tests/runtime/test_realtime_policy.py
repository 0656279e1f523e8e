"""The real-time decision and the guard, in-process: the words of every refusal and notice,
where the mode comes from, what a probe that fails says, which thread is raised and lowered,
and which thread the guard lowers (its checks on given CPU times, its thread's life).

The same against real processes without CAP_SYS_NICE and real spinning threads:
test_realtime.py.
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from xgo_show.errors import UsageError
from xgo_show.runtime import realtime
from xgo_show.runtime.realtime import RealtimePolicy

EPERM = "Operation not permitted"


@pytest.fixture(autouse=True)
def _policy_back() -> Iterator[None]:
    saved = realtime.policy()
    yield
    realtime.restore(saved)


@pytest.fixture
def refused(monkeypatch: pytest.MonkeyPatch) -> None:
    """A process that may not use SCHED_FIFO."""

    def refuse(pid: int, policy: int, param: object) -> None:
        raise PermissionError(1, EPERM)

    monkeypatch.setattr(os, "sched_setscheduler", refuse)


def permitted() -> bool:
    return realtime._probe() == ""


needs_fifo = pytest.mark.skipif(not sys.platform.startswith("linux") or not permitted(),
                                reason="SCHED_FIFO is not permitted here")


# ---------------------------------------------------------------------- the policy's words


def test_what_a_policy_says() -> None:
    assert RealtimePolicy("auto", True).summary == "SCHED_FIFO priority 10 for the writer threads"
    assert RealtimePolicy("required", True).notice is None
    assert RealtimePolicy("auto", True).notice is None
    assert RealtimePolicy("off", False).summary == "off (--no-realtime)"
    assert RealtimePolicy("off", False).notice is None
    assert RealtimePolicy("required", False, "why").notice is None  # it refuses instead
    assert RealtimePolicy("auto", False, EPERM).summary == (
        "not permitted (Operation not permitted): normal priority")
    assert RealtimePolicy("auto", False, EPERM).notice == (
        "note: real-time scheduling not permitted (Operation not permitted); the writer "
        "threads run at normal priority, so other load on this machine can delay frames (run "
        "as root, give the interpreter CAP_SYS_NICE, or set RLIMIT_RTPRIO >= 10; "
        "--no-realtime silences this)")
    assert realtime.HELPER_PRIORITY == realtime.PRIORITY - 1 == 9


def test_the_library_default_is_off_until_a_command_decides() -> None:
    assert RealtimePolicy("off", False, "") == realtime._OFF
    realtime.restore(RealtimePolicy("auto", True))
    assert realtime.policy() == RealtimePolicy("auto", True)


# ---------------------------------------------------------------------- where the mode comes from


def test_an_unknown_mode_is_named_with_where_it_came_from(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(UsageError) as info:
        realtime.configure("fast")
    assert str(info.value) == "real-time mode 'fast': use one of auto, required, off"
    monkeypatch.setenv(realtime.ENV, "  Sometimes ")
    with pytest.raises(UsageError) as info:
        realtime.configure(None)
    assert str(info.value) == ("real-time mode 'sometimes' (from XGO_SHOW_REALTIME): use one "
                               "of auto, required, off")
    assert realtime.ENV == "XGO_SHOW_REALTIME"


@pytest.mark.parametrize(("env", "mode"), [
    (None, "auto"), ("", "auto"), ("  ", "auto"), (" OFF ", "off"), ("Auto", "auto"),
    ("required", "required"),
])
def test_the_environment_gives_the_mode_when_no_option_does(
    monkeypatch: pytest.MonkeyPatch, refused: None, env: str | None, mode: str
) -> None:
    if env is None:
        monkeypatch.delenv(realtime.ENV, raising=False)
    else:
        monkeypatch.setenv(realtime.ENV, env)
    if mode == "required":
        with pytest.raises(UsageError, match=r"^--realtime: "):
            realtime.configure(None)
        return
    assert realtime.configure(None).mode == mode
    assert realtime.policy().mode == mode


def test_an_option_wins_over_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(realtime.ENV, "required")
    assert realtime.configure("off") == RealtimePolicy("off", False)
    assert realtime.policy() is realtime._OFF


def test_off_asks_nothing_of_the_system(monkeypatch: pytest.MonkeyPatch) -> None:
    def probe() -> str:
        raise AssertionError("probed")

    monkeypatch.setattr(realtime, "_probe", probe)
    realtime.restore(RealtimePolicy("auto", True))
    assert realtime.configure("off") is realtime._OFF and realtime.policy() is realtime._OFF


# ---------------------------------------------------------------------- a process that may not


def test_not_permitted_auto_runs_at_normal_priority_and_required_refuses(refused: None) -> None:
    decided = realtime.configure("auto")
    assert decided == RealtimePolicy("auto", False, EPERM)
    assert realtime.policy() == decided
    with pytest.raises(UsageError) as info:
        realtime.configure("required")
    assert str(info.value) == (
        "--realtime: SCHED_FIFO is not permitted (Operation not permitted); run as root, give "
        "the interpreter CAP_SYS_NICE, or set RLIMIT_RTPRIO >= 10 (ulimit -r); or leave out "
        "--realtime")
    assert realtime.policy() == decided  # a refusal changes nothing


def test_a_probe_error_without_words_is_its_text(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(pid: int, policy: int, param: object) -> None:
        raise OSError("no words")

    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    assert realtime._probe() == "no words"


@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
def test_a_probe_that_dies_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    def crash(pid: int, policy: int, param: object) -> None:
        raise SystemExit  # ends the probe thread silently, with nothing said

    monkeypatch.setattr(os, "sched_setscheduler", crash)
    assert realtime._probe() == "the probe thread failed"


@pytest.mark.parametrize("missing", ["sched_setscheduler", "SCHED_FIFO"])
def test_a_system_without_fifo_says_which(monkeypatch: pytest.MonkeyPatch, missing: str) -> None:
    monkeypatch.delattr(os, missing)
    assert realtime._probe() == f"not available on {sys.platform}"
    assert realtime.configure("auto") == RealtimePolicy("auto", False,
                                                        f"not available on {sys.platform}")


def test_the_probe_tries_fifo_at_the_writers_priority_on_a_thread_of_its_own(
    monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[tuple[object, ...]] = []

    def record(pid: int, policy: int, param: os.sched_param) -> None:
        seen.append((pid, policy, param.sched_priority, threading.current_thread().name,
                     threading.current_thread() is threading.main_thread()))

    monkeypatch.setattr(os, "sched_setscheduler", record)
    assert realtime._probe() == ""
    assert seen == [(0, os.SCHED_FIFO, 10, "realtime probe", False)]


def test_decide_prints_the_notice_only_when_auto_is_refused(
    refused: None, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(realtime.ENV, raising=False)
    assert realtime.decide(None).mode == "auto"
    err = capsys.readouterr().err
    assert err == RealtimePolicy("auto", False, EPERM).notice + "\n"
    assert realtime.decide("off") is realtime._OFF
    assert realtime.decide("auto", virtual=True) is realtime._OFF  # virtual time: no need
    assert realtime.decide(None, virtual=True) is realtime._OFF
    assert capsys.readouterr().err == ""
    with pytest.raises(UsageError, match=r"^--realtime: SCHED_FIFO is not permitted"):
        realtime.decide("required", virtual=True)  # asked for: still refused


def test_decide_with_virtual_time_keeps_a_granted_required(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(realtime, "_probe", lambda: "")
    assert realtime.decide("required", virtual=True) == RealtimePolicy("required", True, "")
    assert realtime.decide("auto") == RealtimePolicy("auto", True, "")


def test_the_two_options_and_neither() -> None:
    parser = argparse.ArgumentParser()
    realtime.add_realtime_arguments(parser)
    assert parser.parse_args([]).realtime is None
    assert parser.parse_args(["--realtime"]).realtime == "required"
    assert parser.parse_args(["--no-realtime"]).realtime == "off"
    with pytest.raises(SystemExit):
        parser.parse_args(["--realtime", "--no-realtime"])
    helps = {a.option_strings[0]: a.help for a in parser._actions if a.option_strings}
    assert helps["--realtime"] == (
        "require SCHED_FIFO (priority 10) for the threads that send frames: stop with an error "
        "where it is not permitted. Without either option it is used where permitted (root, "
        "CAP_SYS_NICE or RLIMIT_RTPRIO), else a one-line note says so; docs/realtime.md")
    assert helps["--no-realtime"] == "send frames from threads of normal priority (no SCHED_FIFO)"


# ---------------------------------------------------------------------- raising a thread


def test_a_thread_is_raised_only_when_the_policy_grants_it(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[tuple[int, int, int]] = []
    watched: list[int] = []
    monkeypatch.setattr(os, "sched_setscheduler",
                        lambda pid, pol, param: seen.append((pid, pol, param.sched_priority)))
    monkeypatch.setattr(realtime._GUARD, "watch", watched.append)
    realtime.restore(RealtimePolicy("auto", False, EPERM))
    assert realtime.enter_show_thread() is False
    assert realtime.raise_thread(4321) is False
    assert seen == [] and watched == []
    realtime.restore(RealtimePolicy("auto", True))
    me = threading.get_native_id()
    assert realtime.enter_show_thread() is True
    assert realtime.enter_show_thread(realtime.HELPER_PRIORITY) is True
    assert realtime.raise_thread(4321) is True  # a helper (a thread Python did not start)
    assert realtime.raise_thread(4322, 3) is True
    assert seen == [(me, os.SCHED_FIFO, 10), (me, os.SCHED_FIFO, 9), (4321, os.SCHED_FIFO, 9),
                    (4322, os.SCHED_FIFO, 3)]
    assert watched == [me, me, 4321, 4322]


def test_a_refused_raise_is_not_watched(monkeypatch: pytest.MonkeyPatch, refused: None) -> None:
    watched: list[int] = []
    monkeypatch.setattr(realtime._GUARD, "watch", watched.append)
    realtime.restore(RealtimePolicy("auto", True))
    assert realtime.enter_show_thread() is False
    assert realtime.raise_thread(4321) is False
    assert watched == []


def test_leaving_lowers_only_a_thread_that_was_raised(monkeypatch: pytest.MonkeyPatch) -> None:
    lowered: list[int] = []
    monkeypatch.setattr(realtime, "_to_normal", lowered.append)
    guard = realtime._Guard(report=lambda line: None)
    monkeypatch.setattr(realtime, "_GUARD", guard)
    me = threading.get_native_id()
    realtime.leave_show_thread()
    realtime.lower_thread(4321)
    assert lowered == []
    guard._watched.update({me: 0.0, 4321: 0.0, 4322: 0.0})
    realtime.leave_show_thread()
    assert lowered == [me] and set(guard._watched) == {4321, 4322}
    realtime.leave_show_thread()  # once only
    realtime.lower_thread(4321)
    assert lowered == [me, 4321] and set(guard._watched) == {4322}


def named_thread(name: bytes) -> tuple[threading.Thread, threading.Event, list[int]]:
    """A thread whose kernel name is ``name`` (as Zenoh names its own), until the event."""
    import ctypes

    libc = ctypes.CDLL(None)
    ready, done = threading.Event(), threading.Event()
    out: list[int] = []

    def body() -> None:
        libc.prctl(15, ctypes.c_char_p(name), 0, 0, 0)  # PR_SET_NAME
        out.append(threading.get_native_id())
        ready.set()
        done.wait(5.0)

    th = threading.Thread(target=body, daemon=True)
    th.start()
    ready.wait(5.0)
    return th, done, out


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc/self/task")
def test_threads_are_found_by_the_start_of_their_kernel_name(
    monkeypatch: pytest.MonkeyPatch
) -> None:
    # Names no library thread has: the suite's in-process Zenoh sessions leave rx-0, rx-1.
    made = [named_thread(name) for name in (b"qrx-1", b"qrx-0", b"qtx-0")]
    try:
        ids = [out[0] for _, _, out in made]
        assert realtime.threads_named("qrx-") == sorted(ids[:2])
        assert realtime.threads_named("qtx-0") == [ids[2]]
        assert realtime.threads_named("no such thread") == []
        # A thread that ends while the list is read is left out; no /proc: none.
        real = Path.read_text

        def gone(self: Path, *args: object, **kwargs: object) -> str:
            if self.parent.name == str(ids[0]):
                raise FileNotFoundError(str(self))
            return real(self, *args, **kwargs)  # type: ignore[arg-type]

        monkeypatch.setattr(Path, "read_text", gone)
        assert realtime.threads_named("qrx-") == [ids[1]]
        monkeypatch.undo()

        def no_proc(path: str) -> list[str]:
            raise FileNotFoundError(path)

        monkeypatch.setattr(os, "listdir", no_proc)
        assert realtime.threads_named("qrx-") == []
    finally:
        for th, done, _ in made:
            done.set()
            th.join(5.0)


@needs_fifo
def test_to_normal_puts_a_raised_thread_back_and_ignores_one_that_ended() -> None:
    out: list[tuple[int, int]] = []
    ready, done = threading.Event(), threading.Event()

    def body() -> None:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(realtime.PRIORITY))
        ready.set()
        done.wait(5.0)
        out.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))

    th = threading.Thread(target=body)
    th.start()
    ready.wait(5.0)
    assert th.native_id is not None
    realtime._to_normal(th.native_id)
    done.set()
    th.join(5.0)
    assert out == [(os.SCHED_OTHER, 0)]
    realtime._to_normal(th.native_id)  # ended: no error
    realtime._to_normal(2**22 + 1)  # above any thread id (pid_max): no error either


# ---------------------------------------------------------------------- the guard


def test_cpu_time_is_the_threads_own_in_seconds() -> None:
    me = threading.get_native_id()
    before, t0 = realtime._cpu_time(me), time.thread_time()
    end = time.thread_time() + 0.05
    while time.thread_time() < end:
        pass
    used, t1 = realtime._cpu_time(me) - before, time.thread_time() - t0
    assert 0.04 < used < 1.0 and abs(used - t1) < 0.02
    assert realtime._cpu_time(2**22 + 12345) == -1.0  # no such thread


def guard_with(monkeypatch: pytest.MonkeyPatch, times: dict[int, float]) -> realtime._Guard:
    monkeypatch.setattr(realtime, "_cpu_time", lambda native: times[native])
    return realtime._Guard(report=lambda line: None)


def test_the_guard_picks_out_threads_over_their_share_and_forgets_ended_ones(
    monkeypatch: pytest.MonkeyPatch
) -> None:
    share = realtime.GUARD_SHARE * realtime.GUARD_PERIOD  # 0.125 s of CPU a period
    times = {1: 10.0 + share, 2: 10.0 + share + 0.001, 3: -1.0, 4: 10.01, 5: 0.0, 6: 0.5}
    guard = guard_with(monkeypatch, times)
    guard._watched.update({1: 10.0, 2: 10.0, 3: 10.0, 4: 10.0, 5: 0.0, 6: 0.4})
    assert guard._check() == [2]
    # noted for the next check, a thread that has used no CPU yet too
    assert guard._watched == {1: 10.0 + share, 4: 10.01, 5: 0.0, 6: 0.5}
    del guard._watched[5], guard._watched[6]
    times[4] = 10.01 + share + 0.01
    assert guard._check() == [4]
    assert guard._watched == {1: 10.0 + share}


def test_the_guard_lowers_a_spinning_thread_says_so_and_ends_when_none_is_left(
    monkeypatch: pytest.MonkeyPatch
) -> None:
    lowered: list[int] = []
    lines: list[str] = []
    monkeypatch.setattr(realtime, "_to_normal", lowered.append)
    times = {7: 0.0}
    monkeypatch.setattr(realtime, "_cpu_time", lambda native: times[native])
    guard = realtime._Guard(report=lines.append)
    guard.watch(7)
    thread = guard._thread
    assert thread is not None and thread.name == "realtime guard" and thread.daemon
    guard.watch(7)
    assert guard._thread is thread  # one guard thread at a time
    times[7] = 1.0  # a whole CPU for the period
    thread.join(2.0)
    assert not thread.is_alive() and guard._thread is None
    assert lowered == [7] and guard.demoted == 1
    assert lines == ["warning: show thread 7 used over 50% of a CPU for 0.25 s under "
                     "SCHED_FIFO: back to normal priority"]
    guard.watch(7)  # a new raised thread: a new guard
    assert guard._thread is not None and guard._thread is not thread
    guard.forget(7)
    guard._thread.join(2.0)


def test_the_guard_sleeps_a_period_between_checks(monkeypatch: pytest.MonkeyPatch) -> None:
    sleeps: list[float] = []
    guard = realtime._Guard(report=lambda line: None)

    def sleep(seconds: float) -> None:
        sleeps.append(seconds)
        guard._watched.clear()

    monkeypatch.setattr(realtime.time, "sleep", sleep)
    monkeypatch.setattr(os, "sched_setscheduler", lambda *a: None)
    guard._watched[1] = 0.0
    guard._run()
    assert sleeps == [0.25] and guard._thread is None


def test_the_guard_runs_one_above_the_writers(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[tuple[int, int, int]] = []
    monkeypatch.setattr(os, "sched_setscheduler",
                        lambda pid, pol, param: seen.append((pid, pol, param.sched_priority)))
    monkeypatch.setattr(realtime.time, "sleep", lambda s: None)
    guard = realtime._Guard(report=lambda line: None)
    guard._run()  # nothing watched: it ends after one look
    assert seen == [(0, os.SCHED_FIFO, 11)]


def test_a_guard_that_may_not_be_raised_still_guards(
    monkeypatch: pytest.MonkeyPatch, refused: None
) -> None:
    lowered: list[int] = []
    monkeypatch.setattr(realtime, "_to_normal", lowered.append)
    monkeypatch.setattr(realtime.time, "sleep", lambda s: None)
    monkeypatch.setattr(realtime, "_cpu_time", lambda native: 5.0)
    guard = realtime._Guard(report=lambda line: None)
    guard._watched.update({3: 0.0, 4: 0.0})
    guard._run()
    assert lowered == [3, 4] and guard.demoted == 2


def test_the_guard_reports_on_standard_error_by_default(
    capsys: pytest.CaptureFixture[str]
) -> None:
    assert realtime._Guard().report is realtime._say
    realtime._say("a line")
    assert capsys.readouterr().err == "a line\n"

