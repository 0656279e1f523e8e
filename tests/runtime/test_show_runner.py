"""The show runner against simulators on real pseudo-terminals, through pyserial."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest

from tests.conftest import starved_ms, wait_until
from xgo_show.profiles import get_profile
from xgo_show.runtime.events import EventRecorder, ProgressTick
from xgo_show.runtime.executor import ExecutorState
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.report import format_report
from xgo_show.runtime.runlog import RunLog
from xgo_show.runtime.safety import UnsafeScheduleError, check_unsafe, rest_frames
from xgo_show.runtime.show_runner import ShowResult, ShowRunner
from xgo_show.wire.xgo import TYPE_READ, write_frame


def make_runner(schedule, transports, *, log: RunLog | None = None, **options) -> ShowRunner:  # type: ignore[no-untyped-def]
    """A runner over the rig's open ports, its events also written to ``log``."""
    runner = local_runner(schedule, transports, **options)
    if log is not None:
        log.attach(runner.events)
    return runner


def settle() -> None:
    """Give the pty servers a moment to take in the last bytes written."""
    time.sleep(0.05)


def show_frames(server, model: str) -> list[bytes]:
    """Frames the simulator received from the schedule: no telemetry reads, no rest frames."""
    rest = {f.data for f in rest_frames(get_profile(model))}
    return [f.data for f in server.robot.received if f.data[3] != TYPE_READ and f.data not in rest]


def run_in_thread(runner: ShowRunner) -> tuple[threading.Thread, list[ShowResult]]:
    out: list[ShowResult] = []
    th = threading.Thread(target=lambda: out.append(runner.run(handle_signals=False)))
    th.start()
    return th, out


def run_until(
    runner: ShowRunner, performer: str, sent: int, then: Callable[[], object]
) -> ShowResult:
    """Run the show in a thread; once ``performer`` has sent ``sent`` frames, call ``then``
    (a stop, a pulled cable, a fall); return the show's result."""
    th, out = run_in_thread(runner)
    wait_until(lambda: runner.performers[performer].progress.sent >= sent, timeout=3.0)
    then()
    th.join(5)
    assert out, "runner did not return"
    return out[0]


def test_multi_performer_schedule_arrives_complete_and_in_order(rig, perf, sched) -> None:
    schedule = sched(
        perf("rex", "mini", count=30, spacing=0.01),
        perf("rita", "rider", count=25, spacing=0.012, first_byte=0x40),
        perf("lola", "lite", count=20, spacing=0.015, start=0.05, register="roll"),
    )
    rig.for_schedule(schedule)
    log = RunLog(None)
    runner = make_runner(schedule, rig.transports, log=log)
    rec = EventRecorder(runner.events)
    result = runner.run(handle_signals=False)
    settle()
    assert result.completed, result.reason
    for p in schedule.performers:
        server = rig.servers[p.name]
        assert show_frames(server, p.model) == [f.data for f in p.frames]
        assert all(f.accepted for f in server.robot.received), p.name
        records = [r for r in rec.sent(p.name) if r.kind == "frame"]
        assert [r.index for r in records] == list(range(len(p.frames)))
    # Telemetry replies were parsed on the same ports.
    assert result.performers["rex"].readings.get("battery") == 100.0
    assert [e["event"] for e in log.events()] == ["start", "end"]
    frames_logged = [r for r in log.records if r["kind"] == "frame" and r["send"] == "frame"]
    assert len(frames_logged) == sum(len(p.frames) for p in schedule.performers)


def _walkers(sched, walking, on_failure: str):
    return sched(
        walking("rex", "mini", seconds=1.5),
        walking("lola", "lite", seconds=1.5),
        walking("rita", "rider", seconds=1.5),
        on_failure=on_failure,
    )


def test_port_closed_mid_show_safe_stops_everyone(rig, sched, walking) -> None:
    schedule = _walkers(sched, walking, "halt_all")
    rig.for_schedule(schedule)
    log = RunLog(None)
    runner = make_runner(schedule, rig.transports, log=log)
    result = run_until(runner, "lola", 5, rig.servers["lola"].close)  # the cable is pulled
    settle()
    assert not result.completed
    assert result.reason.startswith("fault on lola")
    assert "lola" in result.faults
    for name in ("rex", "rita"):
        snap = rig.servers[name].snapshot()
        assert snap["raw"]["vx"] == "80", name  # neutral speed
        assert snap["actions"][-1]["id"] == 255, name  # default posture restored
        assert result.stops[name].ok
        assert result.performers[name].state is ExecutorState.STOPPED
        assert len(show_frames(rig.servers[name], snap["model"])) < len(
            schedule.performer(name).frames
        )
    assert not result.stops["lola"].ok  # its port is gone; the report says so
    # The others are stopped within 100 ms of the fault being seen; lola's dead port is given
    # up on after the stop timeout, so the latency covers everyone but must still be bounded.
    assert result.stop_latency is not None and result.stop_latency < runner.stop_timeout * 2 + 0.1
    assert max(result.stops[n].elapsed for n in ("rex", "rita")) < 0.1
    faults = log.events("fault")
    assert faults[0]["performer"] == "lola"
    assert {e["performer"] for e in log.events("safe_stop")} == {"rex", "lola", "rita"}
    assert log.events("end")[0]["completed"] is False


def test_continue_policy_keeps_the_others_running(rig, sched, walking) -> None:
    schedule = _walkers(sched, walking, "continue")
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports)
    result = run_until(runner, "lola", 5, rig.servers["lola"].close)
    settle()
    assert not result.completed
    assert set(result.stops) == {"lola"}
    for name in ("rex", "rita"):
        assert result.performers[name].state is ExecutorState.FINISHED
        server = rig.servers[name]
        assert show_frames(server, server.robot.model) == [
            f.data for f in schedule.performer(name).frames
        ]
        assert server.snapshot()["raw"]["vx"] == "80"  # rested at the normal end


def test_fallen_rider_halts_the_show(rig, sched, walking) -> None:
    schedule = sched(walking("rex", "mini", seconds=2.0), walking("rita", "rider", seconds=2.0))
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports)

    def fall() -> None:
        with rig.servers["rita"].lock:
            rig.servers["rita"].robot.fall()  # type: ignore[attr-defined]

    result = run_until(runner, "rita", 3, fall)
    settle()
    assert "fallen" in result.reason
    assert rig.servers["rex"].snapshot()["raw"]["vx"] == "80"
    assert rig.servers["rex"].snapshot()["actions"][-1]["id"] == 255


def test_low_battery_during_the_show_is_a_fault(rig, sched, walking) -> None:
    schedule = sched(walking("rex", "mini", seconds=2.0))
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports, battery_floor=30)

    def drain() -> None:
        with rig.servers["rex"].lock:
            rig.servers["rex"].robot.set_battery(12)  # type: ignore[attr-defined]

    result = run_until(runner, "rex", 3, drain)
    assert "battery" in result.reason and "below the floor" in result.reason
    assert result.stops["rex"].ok


def _arm_moves(seconds: float = 3.0):  # type: ignore[no-untyped-def]
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.wire.xarm import servo_move

    xarm = get_profile("xarm")
    n = int(seconds / 0.1)
    moves = tuple(
        ScheduledFrame(i * 0.1, servo_move(100, {1: 300 + 10 * i, 2: 700 - 10 * i}))
        for i in range(n)
    )
    return PerformerSchedule("arm", "xarm", xarm.link, moves, end=seconds)


def test_xarm_battery_is_polled_during_the_show(rig, sched) -> None:
    schedule = sched(_arm_moves(1.0))
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports)
    rec = EventRecorder(runner.events)
    result = runner.run(handle_signals=False)
    assert result.completed, result.reason
    reads = [r for r in rec.sent("arm") if r.kind == "read"]
    assert len(reads) >= 3 and all(r.label == "battery_v" for r in reads)
    assert result.performers["arm"].readings["battery_v"] == pytest.approx(7.6, 0.01)
    assert "telemetry: battery 7.60 V" in format_report(result)


def test_xarm_low_voltage_during_the_show_halts_everyone(rig, sched, walking) -> None:
    schedule = sched(walking("rex", "mini", seconds=3.0), _arm_moves(3.0))
    rig.add("rex", "mini")
    # 7.0 V draining 1 V a second: below the 20% floor (6.48 V) after about half a second.
    rig.add("arm", "xarm", battery_mv=7000, drain_mv_per_minute=60_000)
    runner = make_runner(schedule, rig.transports, battery_floor=20)
    th, out = run_in_thread(runner)
    th.join(10)
    result = out[0]
    settle()
    assert not result.completed
    assert result.reason.startswith("fault on arm: battery ")
    assert "V is below the floor of 6.48 V" in result.reason
    assert result.stops["arm"].ok and result.stops["arm"].frames == ("GroupStop",)
    assert result.stops["rex"].ok
    assert rig.servers["rex"].snapshot()["raw"]["vx"] == "80"
    assert rig.servers["rex"].snapshot()["actions"][-1]["id"] == 255
    assert len(rig.servers["arm"].snapshot()["stops"]) == 1
    assert result.performers["arm"].state is ExecutorState.FAILED
    # Stopped well before the end of the 3 s show.
    assert result.performers["arm"].progress.show_time < 2.0


def test_report_names_each_rest_once_after_a_pause(rig, sched, walking) -> None:
    schedule = sched(walking("rex", "mini", seconds=1.0))
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports, telemetry=False)
    th, out = run_in_thread(runner)
    wait_until(lambda: runner.performers["rex"].progress.sent >= 3, timeout=3.0)
    runner.pause()
    wait_until(lambda: runner.performers["rex"].state is ExecutorState.PAUSED, timeout=3.0)
    runner.resume()
    th.join(10)
    result = out[0]
    assert result.completed, result.reason
    labels = [f.label for f in rest_frames(get_profile("mini"))]
    end = next(line for line in format_report(result).splitlines() if "end:" in line)
    assert end == "  end: show over; rested twice: " + ", ".join(labels)


def test_an_exception_in_the_coordinating_thread_safe_stops_everyone(
    rig, sched, walking, tmp_path
) -> None:
    from xgo_show.runtime.runlog import read_log

    schedule = sched(
        walking("rex", "mini", seconds=3.0), walking("rita", "rider", seconds=3.0), _arm_moves(3.0)
    )
    rig.for_schedule(schedule)
    calls = []

    def progress(event) -> None:  # type: ignore[no-untyped-def]
        calls.append(event)
        if len(calls) == 3:  # the show is well under way: Ctrl-C with no signal handlers
            raise KeyboardInterrupt

    path = tmp_path / "run.jsonl"
    with RunLog(str(path)) as log:
        runner = make_runner(schedule, rig.transports, log=log, progress_hz=20)
        runner.events.subscribe(progress, ProgressTick)
        with pytest.raises(KeyboardInterrupt):
            runner.run(handle_signals=False)
    settle()
    result = runner.result
    assert result is not None and not result.completed
    assert result.reason == "exception: KeyboardInterrupt()"
    assert set(result.stops) == {"rex", "rita", "arm"} and all(
        s.ok for s in result.stops.values()
    )
    # Every robot stopped within 100 ms, plus the starvation the show's own frames saw just
    # before (the suite runs beside other work: a starved stop thread is late as they were).
    records = read_log(path)
    starved = starved_ms(records)
    assert result.stop_latency is not None, result
    assert result.stop_latency < 0.1 + starved / 1000, (result.stop_latency, starved)
    for name in ("rex", "rita"):
        snap = rig.servers[name].snapshot()
        assert snap["raw"]["vx"] == "80" and snap["actions"][-1]["id"] == 255
    assert len(rig.servers["arm"].snapshot()["stops"]) == 1
    events = [r for r in records if r["kind"] == "event"]
    stops = [e for e in events if e["event"] == "safe_stop"]
    assert {e["performer"] for e in stops} == {"rex", "rita", "arm"}
    assert all(e["reason"] == result.reason and e["ok"] for e in stops)
    error = next(e for e in events if e["event"] == "exception")
    assert error["type"] == "KeyboardInterrupt"
    end = events[-1]
    assert end["event"] == "end" and end["reason"] == result.reason and not end["completed"]
    assert set(end["states"].values()) == {"stopped"}


def test_a_broken_listener_never_stops_the_show(rig, sched, perf) -> None:
    schedule = sched(perf("rex", "mini", count=20, spacing=0.01))
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports, progress_hz=50)

    def broken(event) -> None:  # type: ignore[no-untyped-def]
        raise RuntimeError("display broke")

    runner.events.subscribe(broken)
    result = runner.run(handle_signals=False)
    assert result.completed, result.reason
    assert result.stats["rex"].frames == 20
    # Every event reached it and failed there, counted, without touching the robots.
    assert runner.events.listener_errors >= 20
    assert isinstance(runner.events.last_listener_error, RuntimeError)


def test_stop_from_another_thread_is_a_safe_stop(rig, sched, walking) -> None:
    schedule = sched(walking("rex", "mini", seconds=2.0))
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports)
    result = run_until(runner, "rex", 3, lambda: runner.stop("operator"))
    settle()
    assert result.reason == "operator"
    assert result.stops["rex"].ok and result.stops["rex"].elapsed < 0.1
    assert rig.servers["rex"].snapshot()["raw"]["vx"] == "80"


def test_unsafe_register_is_refused_before_anything_moves(rig, perf, sched) -> None:
    profile = get_profile("mini")
    good = perf("rex", "mini", count=3)
    bad_frame = write_frame(profile.register("servo_zero").address, b"\x01")
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame

    bad = PerformerSchedule(
        "rex", "mini", good.link, (*good.frames, ScheduledFrame(0.5, bad_frame)), end=1.0
    )
    schedule = sched(bad)
    rig.for_schedule(schedule)
    with pytest.raises(UnsafeScheduleError, match="servo_zero"):
        make_runner(schedule, rig.transports)
    settle()
    assert rig.servers["rex"].robot.received == []
    found = check_unsafe(schedule, {"rex": profile}, allow_unsafe=True)
    assert len(found) == 1 and "servo_zero" in found[0]


def test_unsafe_xarm_commands_are_refused_before_anything_moves(rig, sched) -> None:
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.profiles.xarm import UNSAFE_COMMANDS
    from xgo_show.wire.xarm import group_erase, servo_move, servo_off, servo_offset_write

    xarm = get_profile("xarm")
    frames = (
        ScheduledFrame(0.0, servo_move(200, {1: 300})),
        ScheduledFrame(0.2, servo_offset_write(3, -20)),
        ScheduledFrame(0.4, group_erase(255)),
        ScheduledFrame(0.6, servo_off([2, 3])),
        ScheduledFrame(0.8, b"\x55\x55\x09\x01\x02\x03\x04\x05\x06\x07\x08"),
    )
    schedule = sched(PerformerSchedule("arm", "xarm", xarm.link, frames, end=1.0))
    rig.for_schedule(schedule)
    with pytest.raises(UnsafeScheduleError, match="ServoOffsetWrite") as err:
        make_runner(schedule, rig.transports)
    assert "arm frame 1 at 0.200s" in str(err.value) and "--allow-unsafe" in str(err.value)
    settle()
    assert rig.servers["arm"].robot.received == []
    found = check_unsafe(schedule, {"arm": xarm}, allow_unsafe=True)
    assert len(found) == 4
    assert "ServoOffsetWrite (24" in found[0] and "GroupErase (8" in found[1]
    assert "ServoOff (20" in found[2] and "unknown packet" in found[3]
    assert {8, 20, 24} <= set(UNSAFE_COMMANDS)
    # The show's own commands are safe.
    assert check_unsafe(sched(PerformerSchedule("arm", "xarm", xarm.link, frames[:1], 1.0)),
                        {"arm": xarm}) == []


def test_xarm_gets_group_stop_when_the_show_is_stopped(rig, sched, walking) -> None:
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.wire.xarm import servo_move

    xarm = get_profile("xarm")
    moves = tuple(
        ScheduledFrame(i * 0.2, servo_move(200, {1: 300 + 50 * i, 2: 700 - 50 * i}))
        for i in range(10)
    )
    schedule = sched(
        walking("rex", "mini", seconds=2.0),
        PerformerSchedule("arm", "xarm", xarm.link, moves, end=2.0),
    )
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports)
    result = run_until(runner, "arm", 2, lambda: runner.stop("operator"))
    settle()
    assert result.stops["arm"].ok and result.stops["arm"].frames == ("GroupStop",)
    snap = rig.servers["arm"].snapshot()
    assert len(snap["stops"]) == 1
    assert 2 <= len(snap["moves"]) < 10
    assert rig.servers["rex"].snapshot()["raw"]["vx"] == "80"


def test_a_blocked_port_delays_no_one_else_and_ends_in_a_halt(rig, sched, walking) -> None:
    import os
    import tty

    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.profiles.model import Link
    from xgo_show.transports import open_transport

    # A robot whose UART stopped reading: a pty nobody drains, on a fast link so that the
    # terminal's buffer fills within a few tens of milliseconds and writes then block.
    master, slave = os.openpty()
    tty.setraw(slave)
    try:
        fast = Link(baud=10_000_000, gap=0.0001)
        junk = tuple(ScheduledFrame(i * 0.0003, b"\x00" * 255) for i in range(5000))
        stuck = PerformerSchedule("lola", "mini", fast, junk, end=2.0)
        schedule = sched(walking("rex", "mini", seconds=2.0), stuck)
        rig.add("rex", "mini")
        blocked = open_transport(os.ttyname(slave), baudrate=115200, write_timeout=0.5)
        blocked.open()
        rig.transports["lola"] = blocked
        runner = make_runner(schedule, rig.transports, telemetry=False)
        result = runner.run(handle_signals=False)
        settle()
    finally:
        os.close(master)
        os.close(slave)
    assert result.reason.startswith("fault on lola")
    assert "blocked" in result.faults["lola"]
    # rex kept its timeline while lola's port was stuck, then was stopped with everyone.
    assert result.stats["rex"].frames >= 8
    assert result.stops["rex"].ok
    assert rig.servers["rex"].snapshot()["raw"]["vx"] == "80"
    assert not result.stops["lola"].ok
    assert "safe stop" in format_report(result).split("lola (mini)")[1]


def test_seek_moves_every_performer_to_the_same_show_time(rig, perf, sched) -> None:
    from xgo_show.errors import XgoShowError
    from xgo_show.runtime.events import ShowSought
    from xgo_show.runtime.performer import Performer

    schedule = sched(
        perf("rex", "mini", count=40, spacing=0.05), perf("lola", "lite", count=40, spacing=0.05)
    )
    rig.for_schedule(schedule)
    runner = make_runner(schedule, rig.transports, telemetry=False)
    assert all(isinstance(p, Performer) for p in runner.performers.values())
    with pytest.raises(XgoShowError, match="outside the show"):
        runner.seek(99.0)
    rec = EventRecorder(runner.events)
    result = run_until(runner, "rex", 4, lambda: runner.seek(1.5))
    assert result.completed, result.reason
    sought = [e for e in rec.events if isinstance(e, ShowSought)]
    assert len(sought) == 1 and sought[0].show_time == 1.5
    for name in ("rex", "lola"):
        indexes = [r.index for r in rec.sent(name) if r.kind == "frame"]
        jump = next(i for i in range(1, len(indexes)) if indexes[i] != indexes[i - 1] + 1)
        assert indexes[jump] == 30  # t = 1.5 s, on both robots
        assert indexes[jump:] == list(range(30, 40))
        assert any(r.kind == "reach" for r in rec.sent(name))
