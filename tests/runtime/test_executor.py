"""Executor timing logic on a fake clock, against an in-process simulator stamped by that clock."""

from __future__ import annotations

import itertools
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import replace

import pytest

from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.errors import TransportError, XgoShowError
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import (
    EventRecorder,
    FaultRaised,
    SafeStopped,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState, PerformerExecutor, Progress, SafeStopResult
from xgo_show.runtime.safety import rest_frames, stop_frames
from xgo_show.runtime.telemetry import TelemetryPoller
from xgo_show.sim import create_robot
from xgo_show.transports.sim import SimTransport
from xgo_show.wire.xgo import TYPE_READ, TYPE_WRITE_RIDER, XgoDecoder, reply_frame, write_frame

MINI = get_profile("mini")
# 9-byte frame: 0.78 ms on the wire at 115200 baud, then 1 ms of silence.
MIN_SPACING = MINI.link.wire_time(9) + MINI.link.gap


class HookClock(FakeClock):
    """A fake clock that runs ``hook(deadline)`` on each wait (to oversleep, pause, …), and
    ``before(deadline)`` as each wait begins (a request arriving while the writer waits)."""

    def __init__(self) -> None:
        super().__init__()
        self.hook: Callable[[float], None] | None = None
        self.before: Callable[[float], None] | None = None

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        if self.before is not None:
            self.before(deadline)
        ok = super().sleep_until(deadline, interrupt)
        if ok and self.hook is not None:
            self.hook(deadline)
        return ok


def sim_link(clock: FakeClock, model: str = "mini") -> SimTransport:
    link = SimTransport(create_robot(model), clock=clock.now, sleep=clock.advance)
    link.open()
    return link


class PollingSim(SimTransport):
    """A sim link for a reader thread on a fake clock: reads never wait on fake time (which
    only the writer moves); an empty read sleeps 1 ms of real time instead."""

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        data = super().read(size, 0.0)
        if not data:
            time.sleep(0.001)
        return data


def schedule_frames(link: SimTransport) -> list[bytes]:
    """What the robot received, without the stop/rest frames after the show."""
    rest = {f.data for f in rest_frames(MINI)}
    return [f.data for f in link.robot.received if f.data not in rest]


def test_frames_go_out_at_start_plus_offset(perf) -> None:
    clock = FakeClock()
    link = sim_link(clock)
    schedule = perf("rex", count=8, spacing=0.1)
    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.5
    ex.run(start)
    received = link.robot.received[: len(schedule.frames)]
    assert [f.data for f in received] == [f.data for f in schedule.frames]
    assert [f.t for f in received] == pytest.approx([start + f.t for f in schedule.frames])
    # Every deadline asked for is start + offset (no accumulated intervals).
    for frame in schedule.frames:
        assert any(abs(w - (start + frame.t)) < 1e-12 for w in clock.waits)
    assert ex.state is ExecutorState.FINISHED
    assert all(r.error == pytest.approx(0.0) for r in rec.sent() if r.kind == "frame")
    # The normal end rests the robot (speeds to neutral), after the last frame.
    assert [r.kind for r in rec.sent()[len(schedule.frames) :]] == ["rest"] * len(rest_frames(MINI))


def test_late_frame_shifts_the_next_ones_without_bunching(perf) -> None:
    clock = HookClock()
    link = sim_link(clock)
    # Frames 2.5 ms apart: only 0.5 ms more than the link needs between two 9-byte frames.
    schedule = perf("rex", count=40, spacing=0.0025)
    start = clock.now() + 0.1
    late_deadline = start + schedule.frames[3].t

    def oversleep(deadline: float) -> None:
        if abs(deadline - late_deadline) < 1e-12:
            clock.advance(0.010)  # the OS woke us 10 ms late for frame 3

    clock.hook = oversleep
    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    ex.run(start)
    sent = [r.actual for r in rec.sent() if r.kind == "frame"]
    assert sent[3] == pytest.approx(late_deadline + 0.010)
    # The frames behind it follow at the link's minimum spacing (not all at once) …
    assert sent[4] - sent[3] == pytest.approx(MIN_SPACING)
    assert all(b - a >= MIN_SPACING - 1e-9 for a, b in itertools.pairwise(sent))
    # … and catch up with the plan as soon as it allows: the last frames are on time again.
    assert sent[-1] == pytest.approx(start + schedule.frames[-1].t)
    assert [f.t for f in link.robot.received[:40]] == pytest.approx(sent)


def test_a_frames_label_is_made_when_read_never_on_the_writers_time(perf) -> None:
    """Making a label costs microseconds: it must not sit between the wake and the write."""
    clock = FakeClock()
    made: list[bytes] = []
    lazy = perf("rex", count=6, spacing=0.1)
    frames = tuple(
        ScheduledFrame(f.t, f.data, f.origin, labels=lambda data: made.append(data) or data.hex())
        for f in lazy.frames
    )
    schedule = replace(lazy, frames=frames)
    unmade_at_write: list[bool] = []

    class Watching(SimTransport):
        def write(self, data: bytes) -> None:
            unmade_at_write.append(data not in made)
            super().write(data)

    link = Watching(create_robot("mini"), clock=clock.now, sleep=clock.advance)
    link.open()
    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI, rest_at_end=False)
    rec = EventRecorder(ex.events)
    assert ex.progress.label == ""
    ex.run(clock.now() + 0.1)
    assert unmade_at_write == [True] * len(frames)
    # No label is made on the writer's time: only when a listener reads one.
    assert made == []
    assert [r.label for r in rec.sent()] == [f.data.hex() for f in frames]
    assert made == [f.data for f in frames]
    assert ex.progress.label == frames[-1].data.hex()


def test_pause_holds_the_robot_and_resume_reaches_back_then_shifts(perf) -> None:
    clock = HookClock()
    link = sim_link(clock)
    schedule = perf("rex", count=10, spacing=0.1)
    start = clock.now() + 0.1
    reach_frame = write_frame(MINI.register("roll").address, b"\x90")
    reached_at: list[float] = []

    def reach(t: float) -> list[tuple[bytes, str]]:
        reached_at.append(t)
        return [(reach_frame, "roll back")]

    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI, reach=reach)
    rec = EventRecorder(ex.events)
    pause_at = start + schedule.frames[4].t

    def pause_hook(deadline: float) -> None:
        if abs(deadline - pause_at) < 1e-12:
            ex.pause()

    clock.hook = pause_hook
    ex.start(start)
    deadline = time.monotonic() + 5
    while ex.state is not ExecutorState.PAUSED and time.monotonic() < deadline:
        time.sleep(0.001)
    assert ex.state is ExecutorState.PAUSED
    assert ex.progress.sent == 5
    clock.advance(5.0)  # five seconds of pause
    ex.resume()
    assert ex.join(5)
    kinds = [r.kind for r in rec.sent()]
    n_rest = len(rest_frames(MINI))
    # Five frames, then the hold (rest frames), then the reach frame, then the rest of the show.
    assert kinds[:5] == ["frame"] * 5
    assert kinds[5 : 5 + n_rest] == ["rest"] * n_rest
    assert kinds[5 + n_rest] == "reach"
    assert kinds[6 + n_rest : 11 + n_rest] == ["frame"] * 5
    assert reached_at == [pytest.approx(schedule.frames[4].t)]
    frames = [r for r in rec.sent() if r.kind == "frame"]
    # After the pause every frame is planned and sent 5 s (plus the hold's few ms) later.
    shift = frames[5].actual - (start + schedule.frames[5].t)
    assert 5.0 <= shift < 5.02
    assert all(
        r.actual - (start + schedule.frames[r.index].t) == pytest.approx(shift)
        for r in frames[5:]
        if r.index is not None
    )
    ex.close()


def test_start_mid_show_sends_state_reaching_frames_first(perf) -> None:
    clock = FakeClock()
    link = sim_link(clock)
    schedule = perf("rex", count=10, spacing=0.1)
    pose = write_frame(MINI.register("body_z").address, b"\x64")
    ex = PerformerExecutor(
        schedule, link, clock=clock, profile=MINI, reach=lambda t: [(pose, f"state at {t}")]
    )
    start = clock.now() + 0.2
    ex.run(start, offset=0.5)
    got = schedule_frames(link)
    assert got[0] == pose
    assert got[1:] == [f.data for f in schedule.frames[5:]]
    # Show time 0.5 happens at ``start``.
    assert link.robot.received[1].t == pytest.approx(start)
    assert link.robot.received[0].t < start


def test_safe_stop_drops_pending_frames_and_stops_the_robot(perf, walking) -> None:
    clock = HookClock()
    link = sim_link(clock)
    schedule = walking("rex", seconds=1.0)
    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    stopped: list[object] = []

    def stop_hook(deadline: float) -> None:
        if not stopped and deadline >= start + 0.5:
            stopped.append(deadline)
            ex.safe_stop("test")

    clock.hook = stop_hook
    ex.run(start)
    result = ex.stop_result
    assert result is not None and result.ok
    assert ex.state is ExecutorState.STOPPED
    sent_frames = [r for r in rec.sent() if r.kind == "frame"]
    assert len(sent_frames) < len(schedule.frames)
    # Nothing from the schedule after the stop frames.
    kinds = [r.kind for r in rec.sent()]
    assert kinds[kinds.index("stop") :] == ["stop"] * len(stop_frames(MINI))
    snap = link.robot.snapshot()
    assert snap["registers"]["vx"] == 0.0
    assert snap["raw"]["vx"] == "80"
    assert snap["actions"][-1]["id"] == 255


def test_stop_frames_decode_to_neutral_speeds_and_posture_reset() -> None:
    for model in ("mini", "lite", "rider"):
        profile = get_profile(model)
        frames = [f for sf in stop_frames(profile) for f in XgoDecoder().feed(sf.data)]
        written: dict[str, bytes] = {}
        for frame in frames:
            assert frame.type == profile.write_type
            pos = 0
            for reg in profile.walk(frame.address, len(frame.data)):
                written[reg.name] = frame.data[pos : pos + reg.size]
                pos += reg.size
        for name, value in profile.safe_stop:
            assert written[name] == profile.register(name).encode_value(value)
        assert written["vx"] == b"\x80"
        assert written["action"] == b"\xff"
        assert list(written)[-1] == "action"  # posture reset after the speeds are neutral


def test_telemetry_reads_fit_between_frames_without_delaying_any(perf) -> None:
    clock = FakeClock()
    link = PollingSim(create_robot("rider"), clock=clock.now)
    link.open()
    rider = get_profile("rider")
    # Frames 3 ms apart (room for a read only where the spacing allows), then a 1 s tail.
    schedule = perf("rita", "rider", count=200, spacing=0.003, end=1.6)
    poller = TelemetryPoller(rider, interval=0.01)
    ex = PerformerExecutor(schedule, link, clock=clock, profile=rider, telemetry=poller)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.run(start)
    frames = [r for r in rec.sent() if r.kind == "frame"]
    reads = [r for r in rec.sent() if r.kind == "read"]
    assert len(frames) == len(schedule.frames)
    assert all(r.error == pytest.approx(0.0) for r in frames)  # no frame delayed by a read
    assert len(reads) > 20
    # Every write, read or not, keeps the link's wire time + gap after the previous one.
    by_time = [r for r in rec.sent() if r.kind in ("frame", "read")]
    for a, b in itertools.pairwise(by_time):
        assert b.actual - a.actual >= rider.link.wire_time(a.nbytes) + rider.link.gap - 1e-9
    got = link.robot.received
    assert sum(1 for f in got if f.data[3] == TYPE_READ) == len(reads)
    writes = [f.data for f in got if f.data[3] == TYPE_WRITE_RIDER]
    assert writes[: len(schedule.frames)] == [f.data for f in schedule.frames]


def test_telemetry_poller_parses_replies_and_ignores_unsolicited_frames() -> None:
    rider = get_profile("rider")
    poller = TelemetryPoller(rider, battery_floor=30)
    names = [item.name for item in poller.items]
    assert names == ["battery", "status", "attitude"]
    noise = b"\x01\x02" + reply_frame(0x65, bytes(24))  # junk, then a block nobody asked for
    samples = poller.feed(noise + reply_frame(rider.register("battery").address, b"\x50"), 1.0)
    assert [(s.name, s.value) for s in samples] == [("battery", 80.0)]
    assert poller.unsolicited == 1
    assert poller.fault is None
    attitude = struct.pack("<ff", 3.5, -2.0)
    samples = poller.feed(reply_frame(rider.register("imu_roll").address, attitude), 2.0)
    assert {s.name: s.value for s in samples} == {"imu_roll": 3.5, "imu_pitch": -2.0}
    # One low battery reading is not yet a fault; two in a row are.
    poller.feed(reply_frame(rider.register("battery").address, b"\x14"), 3.0)
    assert poller.fault is None
    poller.feed(reply_frame(rider.register("battery").address, b"\x14"), 4.0)
    assert poller.fault is not None and "below the floor" in poller.fault
    fallen = TelemetryPoller(rider)
    fallen.feed(reply_frame(rider.register("status").address, b"\x00"), 1.0)
    assert fallen.fault is not None and "fallen" in fallen.fault
    # A Mini's status 0 is not a fall (only the Rider documents that meaning).
    mini = TelemetryPoller(MINI)
    mini.feed(reply_frame(MINI.register("status").address, b"\x00"), 1.0)
    assert mini.fault is None


def test_xarm_battery_reads_fit_between_frames_with_room_for_the_reply() -> None:
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.wire.xarm import get_battery_voltage, servo_move

    clock = FakeClock()
    link = PollingSim(create_robot("xarm"), clock=clock.now)
    link.open()
    xarm = get_profile("xarm")
    # A 2-servo ServoMove is 13 bytes: 13.5 ms on the wire at 9600 baud, then 1 ms of silence.
    # 25 ms apart leaves 10.5 ms: enough for the 4-byte request (4.2 ms + gap + margin) but not
    # for its 6-byte reply as well, so no read may go there; 45 ms apart leaves room for both.
    times = [i * 0.025 for i in range(20)] + [0.5 + i * 0.045 for i in range(20)]
    frames = tuple(
        ScheduledFrame(t, servo_move(20, {1: 300 + i, 2: 600 - i})) for i, t in enumerate(times)
    )
    schedule = PerformerSchedule("arm", "xarm", xarm.link, frames, end=1.5)
    poller = TelemetryPoller(xarm, interval=0.01, battery_floor=20)
    ex = PerformerExecutor(schedule, link, clock=clock, profile=xarm, telemetry=poller)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.run(start)
    sent = [r for r in rec.sent() if r.kind == "frame"]
    reads = [r for r in rec.sent() if r.kind == "read"]
    assert len(sent) == len(frames)
    assert all(r.error == pytest.approx(0.0) for r in sent)  # no frame delayed by a read
    tight = [r for r in reads if sent[0].actual < r.actual < sent[19].actual]
    roomy = [r for r in reads if sent[20].actual < r.actual < sent[-1].actual]
    assert tight == []  # no read in a 25 ms gap
    assert len(roomy) >= 15  # one in (nearly) every 45 ms gap
    room = xarm.link.wire_time(4 + 6) + xarm.link.gap
    by_time = [r for r in rec.sent() if r.kind in ("frame", "read")]
    for a, b in itertools.pairwise(by_time):
        need = room if a.kind == "read" else xarm.link.wire_time(a.nbytes) + xarm.link.gap
        assert b.actual - a.actual >= need - 1e-9
    assert sum(1 for f in link.robot.received if f.data == get_battery_voltage()) == len(reads)
    assert ex.fault is None


def test_xarm_poller_reads_volts_and_faults_below_the_mapped_floor() -> None:
    from xgo_show.wire.xarm import battery_reply, positions_reply

    xarm = get_profile("xarm")
    poller = TelemetryPoller(xarm, battery_floor=20)  # 20% of 6.0..8.4 V = 6.48 V
    assert [(i.name, i.request.hex(), i.reply_bytes) for i in poller.items] == [
        ("battery_v", "5555020f", 6)
    ]
    noise = b"\x01\x55\x02" + positions_reply({1: 500})  # junk, then a reply nobody asked for
    samples = poller.feed(noise + battery_reply(7600), 1.0)
    assert [(s.name, s.value) for s in samples] == [("battery_v", pytest.approx(7.6))]
    assert poller.unsolicited == 1 and poller.fault is None
    poller.feed(battery_reply(6500), 2.0)  # just above the floor
    poller.feed(battery_reply(6470), 3.0)  # one low reading is not yet a fault
    assert poller.fault is None
    poller.feed(battery_reply(6460), 4.0)
    assert poller.fault == "battery 6.46 V is below the floor of 6.48 V (20% of the xArm's range)"


def _reaching(schedule_t: list[float]) -> Callable[[float], list[tuple[bytes, str]]]:
    pose = write_frame(MINI.register("roll").address, b"\x90")

    def reach(t: float) -> list[tuple[bytes, str]]:
        schedule_t.append(t)
        return [(pose, f"state at {t:g}")]

    return reach


def _wait_state(ex: PerformerExecutor, state: ExecutorState) -> None:
    deadline = time.monotonic() + 5
    while ex.state is not state and time.monotonic() < deadline:
        time.sleep(0.001)
    assert ex.state is state


def _wait_until(done: Callable[[], bool]) -> None:
    """Wait (5 s at most) for what the writer's thread does after a state it published: a
    hold says PAUSED first, then rests the robot and makes its catch-up."""
    deadline = time.monotonic() + 5
    while not done() and time.monotonic() < deadline:
        time.sleep(0.001)
    assert done()


def test_pause_at_a_time_holds_there_and_resume_at_a_time_goes_on_exactly_then(perf) -> None:
    """What a relay needs: every host given the same times acts on the same frame."""
    clock = FakeClock()
    link = sim_link(clock)
    schedule = perf("rex", count=10, spacing=0.1)
    reached: list[float] = []
    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI, reach=_reaching(reached))
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.pause(at=start + 0.35)  # asked ahead: frames 0-3 go, frame 4 (t=0.4) does not
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    assert ex.progress.sent == 4
    assert ex.progress.show_time == pytest.approx(0.35)
    go = clock.now() + 2.0
    ex.resume(at=go)
    assert ex.join(5)
    assert reached == [pytest.approx(0.35)]
    frames = [r for r in rec.sent() if r.kind == "frame"]
    assert [r.index for r in frames] == list(range(10))
    # Show time 0.35 happens at ``go``: frame 4 (t=0.4) 50 ms later, and so on.
    assert frames[4].actual == pytest.approx(go + 0.05)
    assert frames[9].actual == pytest.approx(go + 0.55)
    kinds = [r.kind for r in rec.sent()]
    assert kinds.index("reach") < kinds.index("frame", 5)
    states = [e.state for e in rec.events if isinstance(e, StateChanged)]
    assert states == [
        ExecutorState.RUNNING,
        ExecutorState.PAUSED,
        ExecutorState.REACHING,
        ExecutorState.RUNNING,
        ExecutorState.FINISHED,
    ]


def test_seek_while_playing_jumps_with_catch_up_frames(perf) -> None:
    clock = HookClock()
    link = sim_link(clock)
    schedule = perf("rex", count=10, spacing=0.1)
    reached: list[float] = []
    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI, reach=_reaching(reached))
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1

    def seek_hook(deadline: float) -> None:
        if abs(deadline - (start + 0.2)) < 1e-12:
            ex.seek(0.7)

    clock.hook = seek_hook
    ex.run(start)
    assert reached == [pytest.approx(0.7)]
    sent = rec.sent()
    assert [r.index for r in sent if r.kind == "frame"] == [0, 1, 2, 7, 8, 9]
    jump = next(i for i, r in enumerate(sent) if r.kind == "reach")
    after = [r for r in sent[jump:] if r.kind == "frame"]
    # Show time 0.7 happens right after the catch-up frame; then 100 ms apart as planned.
    assert after[0].actual_show == pytest.approx(0.7)
    assert after[1].actual - after[0].actual == pytest.approx(0.1)
    assert ex.state is ExecutorState.FINISHED


def test_seek_while_paused_takes_effect_on_resume(perf) -> None:
    clock = FakeClock()
    link = sim_link(clock)
    schedule = perf("rex", count=10, spacing=0.1)
    reached: list[float] = []
    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI, reach=_reaching(reached))
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.pause(at=start + 0.65)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    ex.seek(0.2)
    time.sleep(0.05)
    assert ex.state is ExecutorState.PAUSED  # a seek alone does not resume
    ex.resume()
    assert ex.join(5)
    assert reached == [pytest.approx(0.2)]
    assert [r.index for r in rec.sent() if r.kind == "frame"] == [*range(7), *range(2, 10)]


class FailingSim(SimTransport):
    """A sim link whose port dies after ``good`` writes (an unplugged adapter)."""

    def __init__(self, clock: FakeClock, good: int) -> None:
        super().__init__(create_robot("mini"), clock=clock.now, sleep=clock.advance)
        self.good = good
        self.open()

    def write(self, data: bytes) -> None:
        if self.good <= 0:
            raise OSError("port gone")
        self.good -= 1
        super().write(data)


class StuckSim(SimTransport):
    """A sim link whose writes block until ``release`` is set (a wedged USB adapter)."""

    def __init__(self, clock: FakeClock) -> None:
        super().__init__(create_robot("mini"), clock=clock.now, sleep=clock.advance)
        self.writing = threading.Event()
        self.release = threading.Event()
        self.open()

    def write(self, data: bytes) -> None:
        self.writing.set()
        self.release.wait(5)
        super().write(data)


def test_a_safe_stop_sends_the_stop_frames_and_says_what_it_sent_and_when(perf) -> None:
    clock = FakeClock()
    link = sim_link(clock)
    ex = PerformerExecutor(perf("rex", count=3), link, clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    requested = clock.now()
    result = ex.safe_stop("operator")
    labels = tuple(f.label for f in stop_frames(MINI))
    sent = rec.sent()
    assert [(r.kind, r.note, r.data) for r in sent] == [
        ("stop", f.label, f.data) for f in stop_frames(MINI)]
    assert [f.data for f in link.robot.received] == [f.data for f in stop_frames(MINI)]
    # Elapsed: from the request to the last stop frame's send (the link's spacing between).
    assert len(labels) > 1 and sent[-1].t > requested
    assert result == SafeStopResult("rex", "operator", True, labels, "",
                                    pytest.approx(sent[-1].t - requested))
    assert ex.stop_result is result and ex.state is ExecutorState.STOPPED and ex.done
    stopped = [e for e in rec.events if isinstance(e, SafeStopped)]
    assert stopped == [SafeStopped(clock.now(), "rex", result)]
    # A second stop (a fault right after the operator's) sends nothing and says the same.
    assert ex.safe_stop("fault") is result
    assert len(rec.sent()) == len(sent) and len(link.robot.received) == len(labels)
    assert len([e for e in rec.events if isinstance(e, SafeStopped)]) == 1


def test_a_port_that_dies_during_the_stop_is_reported_never_raised(perf) -> None:
    clock = FakeClock()
    ex = PerformerExecutor(perf("rex", count=3), FailingSim(clock, good=1), clock=clock,
                           profile=MINI)
    requested = clock.now()
    result = ex.safe_stop("fault")
    first = stop_frames(MINI)[0].label
    assert result == SafeStopResult("rex", "fault", False, (first,), "port gone",
                                    pytest.approx(clock.now() - requested))
    assert ex.state is ExecutorState.STOPPED


def test_a_stuck_write_makes_the_stop_give_up_in_its_timeout_and_say_so(perf) -> None:
    clock = FakeClock()
    link = StuckSim(clock)
    ex = PerformerExecutor(perf("rex", count=3), link, clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    first = threading.Thread(target=ex.safe_stop, args=("operator",), daemon=True)
    first.start()  # holds the port: its first stop frame never returns
    assert link.writing.wait(5)
    began = time.monotonic()
    result = ex.safe_stop("fault")  # the default timeout: 0.1 s
    assert time.monotonic() - began < 0.6
    blocked = SafeStopResult("rex", "fault", False, error="port blocked: write stuck")
    assert result == blocked and ex.stop_result == blocked
    assert [e for e in rec.events if isinstance(e, SafeStopped)] == [
        SafeStopped(clock.now(), "rex", blocked)]
    link.release.set()
    first.join(5)
    assert ex.stop_result == blocked  # the first answer stands


def test_a_failed_port_is_a_fault_once_and_the_stop_after_it_leaves_it_failed(perf) -> None:
    clock = FakeClock()
    ex = PerformerExecutor(perf("rex", count=3), sim_link(clock), clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    clock.advance(1.5)
    ex.port_failed("read error")
    ex.port_failed("another")
    assert ex.fault == "read error" and ex.state is ExecutorState.FAILED
    assert [e for e in rec.events if isinstance(e, FaultRaised)] == [
        FaultRaised(clock.now(), "rex", "read error")]
    assert ex.safe_stop("fault").ok and ex.state is ExecutorState.FAILED


def test_a_port_failing_after_the_part_is_over_is_no_fault(perf) -> None:
    clock = FakeClock()
    ex = PerformerExecutor(perf("rex", count=3), sim_link(clock), clock=clock, profile=MINI)
    ex.safe_stop("operator")
    rec = EventRecorder(ex.events)
    ex.port_failed("closed by its owner")
    assert ex.fault is None and ex.state is ExecutorState.STOPPED and rec.events == []


def test_the_lead_time_is_the_catch_up_frames_wire_time_plus_50_ms(perf) -> None:
    clock = FakeClock()
    asked: list[float] = []

    def reach(t: float) -> list[tuple[bytes, str]]:
        asked.append(t)
        return [(b"\x00" * 9, "a"), (b"\x00" * 12, "b")]

    schedule = perf("rex", count=3)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI, reach=reach)
    link = schedule.link
    want = link.wire_time(9) + link.wire_time(12) + 2 * link.gap + 0.05
    assert ex.lead_time(2.0) == pytest.approx(want) and asked == [2.0]
    assert ex.lead_time(0.0) == 0.05 and ex.lead_time(-1.0) == 0.05 and asked == [2.0]
    plain = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI)
    assert plain.lead_time(2.0) == 0.05


def test_frames_sent_before_the_start_go_before_the_first_frame(perf) -> None:
    clock = FakeClock()
    link = sim_link(clock)
    schedule = perf("rex", count=3, spacing=0.1)
    ex = PerformerExecutor(schedule, link, clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    led = write_frame(MINI.register("vx").address, b"\x80")
    ex.send([(led, "led blue"), (led, "led red")])
    ex.run(clock.now() + 0.5)
    sent = rec.sent()
    assert [(r.kind, r.note) for r in sent[:3]] == [("set", "led blue"), ("set", "led red"),
                                                    ("frame", "")]
    assert [f.data for f in link.robot.received[:3]] == [led, led, schedule.frames[0].data]


class UnpluggedSim(PollingSim):
    """A sim link whose reads fail: the adapter was pulled out mid-show."""

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        raise OSError("unplugged")


def test_a_port_that_cannot_be_read_is_a_fault_that_ends_the_part(perf) -> None:
    clock = HookClock()
    rider = get_profile("rider")
    link = UnpluggedSim(create_robot("rider"), clock=clock.now)
    link.open()
    ex = PerformerExecutor(perf("rita", "rider", count=20, spacing=0.1), link, clock=clock,
                           profile=rider, telemetry=TelemetryPoller(rider))
    rec = EventRecorder(ex.events)
    faulted = threading.Event()
    readers: list[str] = []  # the thread that found the fault

    def found(event: object) -> None:
        readers.append(threading.current_thread().name)
        faulted.set()

    ex.events.subscribe(found, FaultRaised)

    def hold(deadline: float) -> None:  # the writer waits for the reader's verdict
        faulted.wait(5)

    clock.hook = hold
    ex.run(clock.now() + 0.5)
    assert readers == ["xgo-show reader rita"]
    assert ex.fault == f"port {link.url}: unplugged" and ex.state is ExecutorState.FAILED
    assert [e.reason for e in rec.events if isinstance(e, FaultRaised)] == [ex.fault]
    assert len([r for r in rec.sent() if r.kind == "frame"]) <= 1  # the part ended there
    assert not any(t.name == "xgo-show reader rita" for t in threading.enumerate())


def test_no_reader_without_telemetry_or_when_the_port_is_read_by_its_owner(perf) -> None:
    clock = FakeClock()
    rider = get_profile("rider")
    for telemetry, read_port in ((None, True), (TelemetryPoller(rider), False)):
        ex = PerformerExecutor(perf("rita", "rider", count=2), sim_link(clock, "rider"),
                               clock=clock, profile=rider, telemetry=telemetry,
                               read_port=read_port)
        seen: list[str] = []
        ex.events.subscribe(lambda e, seen=seen: seen.extend(
            t.name for t in threading.enumerate() if "reader" in t.name))
        ex.run(clock.now() + 0.1)
        assert seen == [] and ex.state is ExecutorState.FINISHED


def test_a_new_executor_is_idle_at_show_time_zero_with_its_models_profile(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", "lite", count=3)
    ex = PerformerExecutor(schedule, sim_link(clock, "lite"), clock=clock)
    assert ex.profile is get_profile("lite") and ex.read_port is True
    assert ex.state is ExecutorState.IDLE and not ex.done and ex.fault is None
    clock.advance(5.0)
    assert ex.progress == Progress("rex", ExecutorState.IDLE, 0.0, 0, 3, "", "")
    assert ex.join() is True  # never started: nothing to wait for
    other = PerformerExecutor(schedule, sim_link(clock, "lite"), clock=clock)
    assert other.events is not ex.events  # each its own bus unless given one


def test_state_changes_say_when_and_at_which_show_time(perf) -> None:
    clock = FakeClock()
    now = clock.now()
    schedule = perf("rex", count=4, spacing=0.1)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI)
    rec = EventRecorder(ex.events, StateChanged)
    start = clock.now() + 0.5
    ex.run(start, offset=2.0)  # show time 2.0 at ``start``: past every frame (0.0 to 0.3)
    changes = [(e.performer, e.state, e.show_time) for e in rec.events]
    assert [c[:2] for c in changes] == [("rex", ExecutorState.RUNNING),
                                        ("rex", ExecutorState.FINISHED)]
    assert changes[0][2] == pytest.approx(2.0 - 0.5)  # running from now, before the start
    assert rec.events[0].t == pytest.approx(now)
    assert [f.data for f in link_frames(ex)] == []  # nothing was left to send
    ex.port_failed("late")  # after the end: no fault, no change
    assert ex.state is ExecutorState.FINISHED and len(rec.events) == 2


def link_frames(ex: PerformerExecutor) -> list[object]:
    """The scheduled frames the robot received (none of the rest frames after the show)."""
    return [f for f in ex.transport.robot.received  # type: ignore[attr-defined]
            if f.data not in {r.data for r in rest_frames(ex.profile)}]


def test_a_start_at_a_frames_time_sends_that_frame(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=4, spacing=0.1)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI)
    ex.run(clock.now() + 0.5, offset=schedule.frames[2].t)
    assert [f.data for f in link_frames(ex)] == [f.data for f in schedule.frames[2:]]


def test_the_writer_runs_on_a_named_daemon_thread_and_join_waits_for_it(perf) -> None:
    clock = HookClock()
    gate = threading.Event()
    clock.hook = lambda deadline: gate.wait(5)
    ex = PerformerExecutor(perf("rex", count=3), sim_link(clock), clock=clock, profile=MINI)
    ex.start(clock.now() + 0.5)
    writers = [t for t in threading.enumerate() if t.name == "xgo-show writer rex"]
    assert len(writers) == 1 and writers[0].daemon  # never keeps the process alive
    assert ex.join(0.05) is False  # held at its first deadline
    gate.set()
    assert ex.join(5) is True and ex.state is ExecutorState.FINISHED


# ---------------------------------------------------------------- pause, hold, resume, seek


ROLL_BACK = write_frame(MINI.register("roll").address, b"\x90")
UNDO_REST = write_frame(MINI.register("vx").address, b"\xa0")


class RestAwareReach:
    """A reach that knows what the rest frames change, as the compiler's does: ``at_rest``
    says whether the show has the robot at rest at a show time, ``after_rest`` gives only the
    frames that undo the rest frames there. Every call is kept, with the executor's state."""

    def __init__(self, rested: bool) -> None:
        self.rested = rested
        self.calls: list[tuple[str, float]] = []

    def __call__(self, t: float) -> list[tuple[bytes, str]]:
        self.calls.append(("reach", t))
        return [(ROLL_BACK, f"state at {t:g}")]

    def at_rest(self, t: float) -> bool:
        self.calls.append(("at_rest", t))
        return self.rested

    def after_rest(self, t: float) -> list[tuple[bytes, str]]:
        self.calls.append(("after_rest", t))
        return [(UNDO_REST, f"undo rest at {t:g}")]


def _states(rec: EventRecorder) -> list[ExecutorState]:
    return [e.state for e in rec.events if isinstance(e, StateChanged)]


def test_a_pause_not_at_rest_rests_and_makes_the_catch_up_while_holding(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=10, spacing=0.1)
    reach = RestAwareReach(rested=False)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI, reach=reach)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.pause(at=start + 0.35)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    _wait_until(lambda: len(reach.calls) >= 2)  # after PAUSED: missed now and then under load
    # Made at the pause, while the robot holds: a resume then writes at once.
    assert reach.calls == [("at_rest", pytest.approx(0.35)), ("after_rest", pytest.approx(0.35))]
    n_rest = len(rest_frames(MINI))
    assert [r.kind for r in rec.sent()] == ["frame"] * 4 + ["rest"] * n_rest
    ex.resume()
    assert ex.join(5)
    sent = rec.sent()[4 + n_rest:]
    # Only what the rest frames changed goes back; the reach is never asked for the whole state.
    assert [(r.kind, r.note) for r in sent[:2]] == [("reach", "undo rest at 0.35"), ("frame", "")]
    assert [r.data for r in sent if r.kind == "reach"] == [UNDO_REST]
    assert [r.index for r in sent if r.kind == "frame"] == list(range(4, 10))
    assert len(reach.calls) == 2
    assert _states(rec) == [ExecutorState.RUNNING, ExecutorState.PAUSED, ExecutorState.REACHING,
                            ExecutorState.RUNNING, ExecutorState.FINISHED]


def test_a_pause_where_the_show_is_at_rest_sends_nothing_and_goes_on_at_once(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=10, spacing=0.1)
    reach = RestAwareReach(rested=True)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI, reach=reach)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.pause(at=start + 0.35)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    assert [r.kind for r in rec.sent()] == ["frame"] * 4  # the link stays free
    ex.resume()
    assert ex.join(5)
    assert reach.calls == [("at_rest", pytest.approx(0.35))]
    kinds = [r.kind for r in rec.sent()]
    assert kinds == ["frame"] * 10 + ["rest"] * len(rest_frames(MINI))  # rest only at the end
    assert _states(rec) == [ExecutorState.RUNNING, ExecutorState.PAUSED, ExecutorState.RUNNING,
                            ExecutorState.FINISHED]


def test_a_seek_while_paused_catches_up_with_the_whole_state_there(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=10, spacing=0.1)
    reach = RestAwareReach(rested=False)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI, reach=reach)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.pause(at=start + 0.35)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    ex.seek(0.7)
    ex.resume()
    assert ex.join(5)
    assert reach.calls[2:] == [("reach", pytest.approx(0.7))]
    assert [r.note for r in rec.sent() if r.kind == "reach"] == ["state at 0.7"]
    assert [r.index for r in rec.sent() if r.kind == "frame"] == [0, 1, 2, 3, 7, 8, 9]


@pytest.mark.parametrize("back_to", [0.0, 0.2])
def test_a_seek_back_while_paused_plays_again_from_there(perf, back_to: float) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=10, spacing=0.1)
    reached: list[float] = []
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI,
                           reach=_reaching(reached))
    rec = EventRecorder(ex.events)
    sent_when: list[tuple[ExecutorState, int]] = []
    ex.events.subscribe(lambda e: sent_when.append((e.state, ex.progress.sent)), StateChanged)
    start = clock.now() + 0.1
    ex.pause(at=start + 0.65)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    ex.seek(back_to)
    ex.resume()
    assert ex.join(5)
    first = round(back_to / 0.1)
    assert [r.index for r in rec.sent() if r.kind == "frame"] == [*range(7), *range(first, 10)]
    # Progress counts the frames before the new place while catching up and going on.
    assert sent_when[2:4] == [(ExecutorState.REACHING, first), (ExecutorState.RUNNING, first)]
    assert ex.progress.sent == 10


def test_a_pause_woken_late_still_holds_at_the_show_time_asked(perf) -> None:
    """Every host given the same pause time holds at the same show time, even one whose wait
    for it ended late; no frame planned at that time or after goes out."""
    clock = HookClock()
    schedule = perf("rex", count=10, spacing=0.1)
    reached: list[float] = []
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI,
                           reach=_reaching(reached))
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    pause_at = start + schedule.frames[4].t  # exactly frame 4's time

    def oversleep(deadline: float) -> None:
        if deadline == pause_at:
            clock.advance(0.010)

    clock.hook = oversleep
    ex.pause(at=pause_at)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    assert ex.progress.sent == 4 and ex.progress.cue == "cue0"
    assert ex.progress.show_time == pytest.approx(0.4, abs=1e-9)
    clock.advance(3.0)  # a long hold: show time stands still, through the catch-up too
    ex.resume(at=clock.now() + 1.0)
    assert ex.join(5)
    assert reached == [pytest.approx(0.4, abs=1e-9)]
    changes = [(e.state, e.show_time) for e in rec.events if isinstance(e, StateChanged)]
    assert [s for s, _ in changes] == [ExecutorState.RUNNING, ExecutorState.PAUSED,
                                       ExecutorState.REACHING, ExecutorState.RUNNING,
                                       ExecutorState.FINISHED]
    assert [t for _, t in changes[1:4]] == pytest.approx([0.4] * 3, abs=1e-9)
    assert [r.index for r in rec.sent() if r.kind == "frame"] == list(range(10))
    assert ex.progress.cue == "cue2"


def test_a_show_can_be_paused_and_resumed_twice(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=10, spacing=0.1)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    ex.events.subscribe(lambda e: e.index in (2, 5) and e.kind == "frame" and ex.pause())

    def held_after(sent: int) -> None:
        deadline = time.monotonic() + 5
        while not (ex.state is ExecutorState.PAUSED and ex.progress.sent == sent):
            assert time.monotonic() < deadline, (ex.state, ex.progress.sent)
            time.sleep(0.001)
        time.sleep(0.05)
        assert ex.state is ExecutorState.PAUSED and ex.progress.sent == sent  # it holds

    ex.start(clock.now() + 0.1)
    held_after(3)
    ex.resume()
    held_after(6)
    ex.resume()
    assert ex.join(5)
    assert [r.index for r in rec.sent() if r.kind == "frame"] == list(range(10))
    assert _states(rec) == [ExecutorState.RUNNING, ExecutorState.PAUSED, ExecutorState.RUNNING,
                            ExecutorState.PAUSED, ExecutorState.RUNNING, ExecutorState.FINISHED]


def test_a_pause_after_the_last_frame_holds_until_resumed_then_lingers_on(perf) -> None:
    clock = HookClock()
    schedule = perf("rex", count=3, spacing=0.1)  # ends at show time 0.3
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI,
                           linger_until=1.0)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    # The pause arrives while the executor waits for the end of the lingering.
    clock.before = lambda deadline: deadline == start + 1.0 and ex.pause(at=start + 0.6)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    assert ex.progress.show_time == pytest.approx(0.6)
    n_rest = len(rest_frames(MINI))
    _wait_until(lambda: [r.kind for r in rec.sent()].count("rest") >= n_rest)
    assert [r.kind for r in rec.sent()] == ["frame"] * 3 + ["rest"] * n_rest
    clock.advance(2.0)
    ex.resume()
    assert ex.join(5) and ex.state is ExecutorState.FINISHED
    last = rec.sent()[3 + n_rest:]
    # The part ends (its rest frames) when the lingering is over: show time 1.0.
    assert [r.kind for r in last] == ["rest"] * n_rest
    assert last[0].actual_show == pytest.approx(1.0)


def test_a_part_without_lingering_ends_at_its_schedules_end(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=3, spacing=0.1)  # ends at show time 0.3
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    ex.run(clock.now() + 0.1)
    rests = [r for r in rec.sent() if r.kind == "rest"]
    assert rests[0].actual_show == pytest.approx(schedule.end)
    assert ex.linger_until == schedule.end


def test_a_mid_show_start_says_it_is_reaching_then_running(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=10, spacing=0.1)
    asked: list[float] = []
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI,
                           reach=_reaching(asked))
    rec = EventRecorder(ex.events)
    ex.run(clock.now() + 0.2, offset=0.45)
    assert asked == [0.45]
    sent = rec.sent()
    assert [(r.kind, r.note) for r in sent[:2]] == [("reach", "state at 0.45"), ("frame", "")]
    assert [r.index for r in sent if r.kind == "frame"] == list(range(5, 10))
    assert _states(rec) == [ExecutorState.REACHING, ExecutorState.RUNNING,
                            ExecutorState.FINISHED]
    assert ex.progress.cue == "cue2" and ex.progress.sent == 10


# ---------------------------------------------------------------- aborts


def _abort_scenario(clock: HookClock, perf) -> tuple[PerformerExecutor, EventRecorder]:
    """A show that waits in every way the writer can: a catch-up for a mid-show start, frames
    given beside the schedule, telemetry-free waits for frames, a pause at a time with its rest
    frames, a resume at a time with its catch-up, and the rest frames at the end."""
    schedule = perf("rex", count=8, spacing=0.1)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI,
                           reach=_reaching([]))
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.send([(UNDO_REST, "led")])
    ex.pause(at=start + 0.25)
    ex.resume(at=start + 1.0)
    return ex, rec


def test_an_abort_during_any_wait_ends_the_part_there_and_sends_nothing_more(perf) -> None:
    clock = HookClock()
    ex, rec = _abort_scenario(clock, perf)
    ex.run(clock.now() + 0.1, offset=0.05)
    assert ex.state is ExecutorState.FINISHED
    waits = len(clock.waits)
    kinds = {r.kind for r in rec.sent()}
    assert {"reach", "set", "frame", "rest"} <= kinds and waits > 10
    for k in range(waits):
        clock = HookClock()
        ex, rec = _abort_scenario(clock, perf)
        at_abort: list[tuple[float, int, int]] = []

        def abort_kth(deadline: float, k: int = k, ex: PerformerExecutor = ex,
                      rec: EventRecorder = rec, clock: HookClock = clock,
                      at_abort: list[tuple[float, int, int]] = at_abort) -> None:
            if len(clock.waits) == k and not at_abort:
                at_abort.append((clock.now(), len(rec.sent()), len(rec.events)))
                ex.abort()

        clock.before = abort_kth
        ex.run(clock.now() + 0.1, offset=0.05)
        assert at_abort, k
        now, sent, events = at_abort[0]
        # No time passes after the abort, no byte goes out, the state does not change.
        assert (clock.now(), len(rec.sent()), len(rec.events)) == (now, sent, events), k


def test_a_frame_the_abort_refused_is_not_counted_as_sent(perf) -> None:
    clock = HookClock()
    schedule = perf("rex", count=10, spacing=0.1)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    # The abort arrives after frame 3's wait, as its write begins.
    clock.hook = lambda deadline: deadline == start + schedule.frames[3].t and ex.abort()
    ex.run(start)
    assert [r.index for r in rec.sent()] == [0, 1, 2]
    assert ex.progress.sent == 3 and ex.progress.label == schedule.frames[2].label


# ---------------------------------------------------------------- telemetry and the reader


class Unreadable(TelemetryPoller):
    """A poller with nothing to read (telemetry off for this performer)."""

    @property
    def enabled(self) -> bool:
        return False


def test_a_poller_with_nothing_to_read_is_no_telemetry(perf) -> None:
    clock = FakeClock()
    rider = get_profile("rider")
    link = PollingSim(create_robot("rider"), clock=clock.now)
    link.open()
    ex = PerformerExecutor(perf("rita", "rider", count=3), link, clock=clock, profile=rider,
                           telemetry=Unreadable(rider))
    assert ex.telemetry is None and ex.readings == {}
    ex.run(clock.now() + 0.1)
    assert [f for f in link.robot.received if f.data[3] == TYPE_READ] == []


def test_the_executor_publishes_on_the_bus_it_is_given(perf) -> None:
    from xgo_show.runtime.events import EventBus

    clock = FakeClock()
    bus = EventBus()
    rec = EventRecorder(bus, StateChanged)
    ex = PerformerExecutor(perf("rex", count=2), sim_link(clock), clock=clock, profile=MINI,
                           events=bus)
    assert ex.events is bus
    ex.run(clock.now() + 0.1)
    assert [e.state for e in rec.events] == [ExecutorState.RUNNING, ExecutorState.FINISHED]


def test_sent_frames_name_their_performer_and_their_planned_show_time(perf) -> None:
    clock = FakeClock()
    rider = get_profile("rider")
    link = PollingSim(create_robot("rider"), clock=clock.now)
    link.open()
    schedule = perf("rita", "rider", count=5, spacing=0.1, end=1.0)
    poller = TelemetryPoller(rider, interval=0.05)
    ex = PerformerExecutor(schedule, link, clock=clock, profile=rider, telemetry=poller)
    rec = EventRecorder(ex.events)
    ex.run(clock.now() + 0.1, offset=0.1)
    sent = rec.sent()
    assert {r.performer for r in sent} == {"rita"}
    frames = [r for r in sent if r.kind == "frame"]
    assert [r.planned_show for r in frames] == pytest.approx([f.t for f in schedule.frames[1:]])
    reads = [r for r in sent if r.kind == "read"]
    names = {i.name: i.request for i in poller.items}
    assert reads and all(r.planned_show is None and r.data == names[r.note] for r in reads)


def test_the_hold_keeps_polling_telemetry_while_the_robot_is_paused(perf) -> None:
    clock = FakeClock()
    rider = get_profile("rider")
    link = PollingSim(create_robot("rider"), clock=clock.now)
    link.open()
    poller = TelemetryPoller(rider, interval=0.05)
    ex = PerformerExecutor(perf("rita", "rider", count=10, spacing=0.1), link, clock=clock,
                           profile=rider, telemetry=poller)
    rec = EventRecorder(ex.events)
    readings = EventRecorder(ex.events, TelemetryRead)
    start = clock.now() + 0.1
    ex.pause(at=start + 0.35)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    n_rest = len(rest_frames(rider))
    deadline = time.monotonic() + 5
    while len([r for r in rec.sent() if r.kind == "rest"]) < n_rest:  # the hold has begun
        assert time.monotonic() < deadline
        time.sleep(0.001)
    clock.advance(0.01)  # past the rest frames' wire time: a reading due at the pause goes
    time.sleep(0.1)
    reads = len([r for r in rec.sent() if r.kind == "read"])
    clock.advance(0.01)  # the link is free again, but no reading is due yet: nothing to send
    time.sleep(0.1)
    assert ex.state is ExecutorState.PAUSED and ex.fault is None
    assert len([r for r in rec.sent() if r.kind == "read"]) == reads
    # The hold looks for a due reading every 20 ms: five in a row take well under 3 s.
    began = time.monotonic()
    for _ in range(5):
        clock.advance(0.05)
        while len([r for r in rec.sent() if r.kind == "read"]) == reads:
            assert time.monotonic() - began < 3.0
            time.sleep(0.001)
        reads += 1
    assert ex.state is ExecutorState.PAUSED
    ex.resume()
    assert ex.join(5)
    while not any(e.t > start + 0.35 for e in readings.events):
        assert time.monotonic() - began < 5.0
        time.sleep(0.001)
    assert ex.fault is None
    ex.close()


def test_the_reader_turns_each_chunk_into_readings_at_the_time_it_came(perf) -> None:
    clock = HookClock()
    rider = get_profile("rider")
    battery = rider.register("battery").address

    chunks = [reply_frame(battery, b"\x50"), reply_frame(battery, b"\x4b")]

    class Replies(PollingSim):
        """Two battery replies, a chunk each, then nothing."""

        def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
            if chunks:
                return chunks.pop(0)
            time.sleep(0.001)
            return b""

    link = Replies(create_robot("rider"), clock=clock.now)
    link.open()
    ex = PerformerExecutor(perf("rita", "rider", count=3), link, clock=clock, profile=rider,
                           telemetry=TelemetryPoller(rider, interval=10.0))
    readings = EventRecorder(ex.events, TelemetryRead)
    gate = threading.Event()
    clock.hook = lambda deadline: gate.wait(5)  # the writer waits until both are read
    ex.start(clock.now() + 0.5)
    deadline = time.monotonic() + 5
    while len(readings.events) < 2 and time.monotonic() < deadline:
        time.sleep(0.001)
    readers = [t for t in threading.enumerate() if t.name == "xgo-show reader rita"]
    assert len(readers) == 1 and readers[0].daemon
    gate.set()
    assert ex.join(5)
    now = clock.now()
    assert readings.events == [TelemetryRead(pytest.approx(now, abs=1.0), "rita", "battery", 80.0),
                               TelemetryRead(pytest.approx(now, abs=1.0), "rita", "battery", 75.0)]
    assert ex.readings == {"battery": 75.0}
    ex.close()
    assert not readers[0].is_alive()


def test_a_fault_the_reader_finds_ends_its_reading(perf) -> None:
    clock = FakeClock()
    rider = get_profile("rider")
    status = rider.register("status").address
    reads: list[int] = []

    class Fallen(PollingSim):
        def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
            reads.append(size)
            return reply_frame(status, b"\x00")  # fallen, again and again

    link = Fallen(create_robot("rider"), clock=clock.now)
    link.open()
    ex = PerformerExecutor(perf("rita", "rider", count=3), link, clock=clock, profile=rider,
                           telemetry=TelemetryPoller(rider))
    ex.start(clock.now() + 100.0)  # far off: the reader finds the fault first
    assert ex.join(5)
    assert ex.state is ExecutorState.FAILED and ex.fault is not None and "fallen" in ex.fault
    seen = len(reads)
    time.sleep(0.05)
    assert len(reads) == seen == 1  # no read after the fault
    ex.close()


def test_without_telemetry_bytes_handed_over_are_no_verdict(perf) -> None:
    """A behaviour that reads the port hands every chunk over and stops reading on False."""
    clock = FakeClock()
    ex = PerformerExecutor(perf("rex", count=2), sim_link(clock), clock=clock, profile=MINI,
                           read_port=False)
    assert ex.received(b"\x55\x00", clock.now()) is True
    assert ex.fault is None


def test_a_port_unreadable_after_the_part_is_over_is_no_fault(perf) -> None:
    clock = FakeClock()
    rider = get_profile("rider")
    unplugged = threading.Event()

    class Late(PollingSim):
        def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
            if unplugged.is_set():
                raise OSError("unplugged")
            return super().read(size, timeout)

    link = Late(create_robot("rider"), clock=clock.now)
    link.open()
    ex = PerformerExecutor(perf("rita", "rider", count=3), link, clock=clock, profile=rider,
                           telemetry=TelemetryPoller(rider))
    ex.start(clock.now() + 0.1)
    assert ex.join(5) and ex.state is ExecutorState.FINISHED
    reader = next(t for t in threading.enumerate() if t.name == "xgo-show reader rita")
    unplugged.set()  # the owner closed the port after the part, before closing the executor
    reader.join(5)
    assert not reader.is_alive()
    assert ex.fault is None and ex.state is ExecutorState.FINISHED
    ex.close()


def test_closing_ends_a_reader_stuck_in_a_read_within_a_bound(perf) -> None:
    clock = FakeClock()
    rider = get_profile("rider")
    release = threading.Event()
    timeouts: list[float | None] = []
    sizes: list[object] = []

    class Stuck(PollingSim):
        def read(self, size: int = 4096, timeout: float | None = 0.0) -> bytes:
            timeouts.append(timeout)
            sizes.append(size)
            release.wait(10)  # a wedged adapter
            return b""

    link = Stuck(create_robot("rider"), clock=clock.now)
    link.open()
    ex = PerformerExecutor(perf("rita", "rider", count=3), link, clock=clock, profile=rider,
                           telemetry=TelemetryPoller(rider))
    ex.start(clock.now() + 0.1)
    assert ex.join(5)
    began = time.monotonic()
    ex.close()  # never waits for ever on the reader
    assert time.monotonic() - began < 5.0
    release.set()
    # Each read gives up after a short timeout, so a closed executor's reader ends soon.
    assert timeouts and all(t is not None and 0 < t <= 0.1 for t in timeouts)
    assert all(isinstance(n, int) and n > 0 for n in sizes)  # a bounded chunk, never "all"


# ---------------------------------------------------------------- faults and threads


@pytest.mark.parametrize(
    ("error", "fault"),
    [
        (OSError("port gone"), "port sim:mini: port gone"),
        (TransportError("sim:mini is not open"), "port sim:mini: sim:mini is not open"),
        (XgoShowError("the schedule is broken"), "the schedule is broken"),
        (ValueError("boom"), "internal error in the executor: ValueError('boom')"),
    ],
)
def test_a_writer_that_fails_says_why_and_stops(perf, error: Exception, fault: str) -> None:
    clock = FakeClock()

    class Breaks(SimTransport):
        def write(self, data: bytes) -> None:
            if len(self.robot.received) == 2:
                raise error
            super().write(data)

    link = Breaks(create_robot("mini"), clock=clock.now, sleep=clock.advance)
    link.open()
    ex = PerformerExecutor(perf("rex", count=5), link, clock=clock, profile=MINI)
    rec = EventRecorder(ex.events, FaultRaised)
    ex.run(clock.now() + 0.1)
    assert ex.fault == fault and ex.state is ExecutorState.FAILED
    assert [e.reason for e in rec.events] == [fault]


def test_threads_are_raised_for_the_show_on_a_real_clock_only(perf, monkeypatch) -> None:
    from xgo_show.runtime import executor as executor_module
    from xgo_show.runtime.clock import MonotonicClock
    from xgo_show.runtime.realtime import HELPER_PRIORITY, PRIORITY

    calls: list[tuple[str, str, int | None]] = []

    def enter(priority: int = PRIORITY) -> bool:
        calls.append(("enter", threading.current_thread().name, priority))
        return True

    def leave() -> None:
        calls.append(("leave", threading.current_thread().name, None))

    monkeypatch.setattr(executor_module, "enter_show_thread", enter)
    monkeypatch.setattr(executor_module, "leave_show_thread", leave)
    rider = get_profile("rider")
    for clock in (FakeClock(), MonotonicClock()):
        calls.clear()
        link = PollingSim(create_robot("rider"), clock=clock.now)
        link.open()
        ex = PerformerExecutor(perf("rita", "rider", count=3, spacing=0.01), link, clock=clock,
                               profile=rider, telemetry=TelemetryPoller(rider))
        ex.start(clock.now() + 0.05)
        assert ex.join(10)
        ex.close()
        if isinstance(clock, FakeClock):
            assert calls == []  # a writer that never waits must never be raised
        else:
            writer, reader = "xgo-show writer rita", "xgo-show reader rita"
            assert sorted(calls, key=str) == sorted(
                [("enter", writer, PRIORITY), ("leave", writer, None),
                 ("enter", reader, HELPER_PRIORITY), ("leave", reader, None)], key=str)


def test_the_lead_time_counts_any_start_after_the_beginning(perf) -> None:
    clock = FakeClock()
    schedule = perf("rex", count=3)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI,
                           reach=lambda t: [(b"\x00" * 9, "a")])
    link = schedule.link
    assert ex.lead_time(0.5) == pytest.approx(link.wire_time(9) + link.gap + 0.05)


def test_telemetry_reads_go_only_where_they_leave_the_margin_before_the_next_frame() -> None:
    """A read request goes out only when it, its reply and the link's gap end at least 2 ms
    (the margin for the OS write and scheduling noise) before the next frame is due, and every
    slot with that much room gets one."""
    from xgo_show.compiler.schedule import PerformerSchedule

    clock = FakeClock()
    rider = get_profile("rider")
    link = PollingSim(create_robot("rider"), clock=clock.now)
    link.open()
    poller = TelemetryPoller(rider, interval=0.001)
    reply = {i.name: i.reply_bytes for i in poller.items}
    margin = 0.002
    room = max(rider.link.wire_time(len(i.request) + i.reply_bytes) + rider.link.gap + margin
               for i in poller.items)
    body_z = rider.register("body_z")
    busy = rider.link.wire_time(9) + rider.link.gap
    times = [0.0]
    for step in range(40):  # the room after each frame grows by 0.25 ms, from none to 10 ms
        times.append(times[-1] + busy + step * 0.00025)
    frames = tuple(ScheduledFrame(t, write_frame(body_z.address, bytes((i % 256,)),
                                                 write_type=rider.write_type))
                   for i, t in enumerate(times))
    schedule = PerformerSchedule("rita", "rider", rider.link, frames, end=times[-1])
    ex = PerformerExecutor(schedule, link, clock=clock, profile=rider, telemetry=poller)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    ex.run(start)
    sent = [r for r in rec.sent() if r.kind in ("frame", "read")]
    frames_sent = [r for r in sent if r.kind == "frame"]
    assert len(frames_sent) == len(frames)
    assert all(r.error == pytest.approx(0.0, abs=1e-9) for r in frames_sent)
    for r, after in itertools.pairwise(sent):
        if r.kind == "read" and after.kind == "frame":
            end = r.actual + rider.link.wire_time(r.nbytes + reply[r.note]) + rider.link.gap
            assert end + margin <= after.planned + 1e-9
    # Every slot with room for the largest read (and a little more) gets one.
    for a, b in itertools.pairwise(frames_sent):
        if b.planned - (a.planned + busy) >= room + 0.0003:
            assert any(a.actual < r.actual < b.actual for r in sent if r.kind == "read")


def test_an_executor_without_telemetry_starts_no_reader(perf, monkeypatch) -> None:
    crashed: list[str] = []
    monkeypatch.setattr(threading, "excepthook", lambda args: crashed.append(str(args.thread)))
    clock = FakeClock()
    ex = PerformerExecutor(perf("rexa", count=2), sim_link(clock), clock=clock, profile=MINI)
    ex.start(clock.now() + 0.1)
    assert ex.join(5) and ex.state is ExecutorState.FINISHED
    for thread in threading.enumerate():
        if thread.name == "xgo-show reader rexa":
            thread.join(5)
    assert crashed == []
    ex.close()


def test_a_request_while_a_late_frame_waits_for_the_link_is_acted_on_before_it(perf) -> None:
    clock = HookClock()
    # Frames 0.5 ms apart: each waits for the link (1.78 ms a frame) after the one before.
    schedule = perf("rex", count=6, spacing=0.0005)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    late = start + schedule.frames[1].t

    asked: list[float] = []

    def pause_while_waiting(deadline: float) -> None:
        if deadline > late and not asked:  # frame 1's wait for the link
            asked.append(deadline)
            ex.pause()

    clock.before = pause_while_waiting
    # Frame 0 goes out 1 ms late: frame 1 is due by then, and waits only for the link.
    clock.hook = lambda deadline: deadline == start and clock.advance(0.001)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    assert [r.index for r in rec.sent() if r.kind == "frame"] == [0]  # held before frame 1
    ex.resume()
    assert ex.join(5) and ex.state is ExecutorState.FINISHED
    assert [r.index for r in rec.sent() if r.kind == "frame"] == list(range(6))


def test_a_frame_planned_before_a_pause_goes_out_even_when_the_link_makes_it_late_past_it(
        perf) -> None:
    # Frame 0 goes out 1 ms late, so frame 1 (planned 0.5 ms in) waits for the link, which is
    # busy until after the pause time (0.7 ms in): its wait is cut to the pause time, and the
    # frame, planned before it, still goes out when the link is free (a frame's deadline is
    # never before its planned time, so waking at it is waking for the frame); frame 2, planned
    # after the pause time, is held.
    clock = HookClock()
    schedule = perf("rex", count=4, spacing=0.0005)
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI)
    rec = EventRecorder(ex.events)
    start = clock.now() + 0.1
    waits: list[float] = []
    clock.before = waits.append
    clock.hook = lambda deadline: deadline == start and clock.advance(0.001)
    ex.pause(at=start + 0.0007)
    ex.start(start)
    _wait_state(ex, ExecutorState.PAUSED)
    frames = [r for r in rec.sent() if r.kind == "frame"]
    assert [r.index for r in frames] == [0, 1]
    assert frames[0].actual == pytest.approx(start + 0.001)
    assert frames[1].actual == pytest.approx(start + 0.001 + MIN_SPACING)
    assert start + 0.0007 in waits  # frame 1's wait ended at the pause time
    ex.resume()
    assert ex.join(5) and ex.state is ExecutorState.FINISHED
    assert [r.index for r in rec.sent() if r.kind == "frame"] == [0, 1, 2, 3]


def test_a_seek_while_playing_at_a_time_goes_on_exactly_then(perf) -> None:
    clock = HookClock()
    schedule = perf("rex", count=10, spacing=0.1)
    reached: list[float] = []
    ex = PerformerExecutor(schedule, sim_link(clock), clock=clock, profile=MINI,
                           reach=_reaching(reached))
    rec = EventRecorder(ex.events)
    sent_when: list[tuple[ExecutorState, int]] = []
    ex.events.subscribe(lambda e: sent_when.append((e.state, ex.progress.sent)), StateChanged)
    start = clock.now() + 0.1
    go = start + 5.0

    def seek_hook(deadline: float) -> None:
        if abs(deadline - (start + 0.2)) < 1e-12:
            ex.seek(0.65, at=go)

    clock.hook = seek_hook
    ex.run(start)
    assert reached == [pytest.approx(0.65)]
    frames = [r for r in rec.sent() if r.kind == "frame"]
    assert [r.index for r in frames] == [0, 1, 2, 7, 8, 9]
    # Show time 0.65 happens at ``go``: frame 7 (t=0.7) 50 ms later.
    assert frames[3].actual == pytest.approx(go + 0.05)
    assert sent_when[1:3] == [(ExecutorState.REACHING, 7), (ExecutorState.RUNNING, 7)]


def test_an_abort_right_after_any_wait_ends_the_part_with_telemetry_too(perf) -> None:
    """Aborts that land between a wait and the write it was for: a telemetry read the abort
    refuses must end the wait too, never be tried again and again."""
    rider = get_profile("rider")

    def scenario() -> tuple[HookClock, PerformerExecutor, EventRecorder]:
        clock = HookClock()
        link = PollingSim(create_robot("rider"), clock=clock.now)
        link.open()
        ex = PerformerExecutor(perf("rita", "rider", count=6, spacing=0.02, end=0.2), link,
                               clock=clock, profile=rider,
                               telemetry=TelemetryPoller(rider, interval=0.005))
        return clock, ex, EventRecorder(ex.events)

    clock, ex, rec = scenario()
    ex.run(clock.now() + 0.05)
    waits = len(clock.waits)
    assert {"frame", "read"} <= {r.kind for r in rec.sent()} and waits > 10
    for k in range(1, waits + 1):
        clock, ex, rec = scenario()
        sent: list[int] = []

        def abort_after(deadline: float, k: int = k, ex: PerformerExecutor = ex,
                        rec: EventRecorder = rec, clock: HookClock = clock,
                        sent: list[int] = sent) -> None:
            if len(clock.waits) == k and not sent:
                sent.append(len(rec.sent()))
                ex.abort()

        clock.hook = abort_after
        ex.start(clock.now() + 0.05)
        ended = ex.join(5)
        ex.close()
        assert ended, k
        assert sent and len(rec.sent()) == sent[0], k


class _WatchingClock(FakeClock):
    """A fake clock that, on every read from the writer thread, checks what a reader of the
    executor's progress would see: a state whose StateChanged is not published yet is a miss
    (a relay's heartbeat answer would then say "finished" without the row that says so)."""

    def __init__(self) -> None:
        super().__init__()
        self.executor: PerformerExecutor | None = None
        self.published: set[ExecutorState] = {ExecutorState.IDLE}
        self.misses: list[ExecutorState] = []
        self._inside = threading.local()

    def now(self) -> float:
        ex = self.executor
        if ex is not None and not getattr(self._inside, "busy", False):
            self._inside.busy = True  # progress reads the clock too
            try:
                shown = ex.progress.state
                if shown not in self.published:
                    self.misses.append(shown)
            finally:
                self._inside.busy = False
        return super().now()


def test_progress_never_shows_a_state_before_its_state_changed_is_published(perf) -> None:
    clock = _WatchingClock()
    link = sim_link(clock)
    ex = PerformerExecutor(perf("rex", count=4, spacing=0.05), link, clock=clock, profile=MINI)
    ex.events.subscribe(lambda ev: clock.published.add(ev.state), StateChanged)
    clock.executor = ex
    ex.run(clock.now() + 0.1)
    assert ex.progress.state is ExecutorState.FINISHED
    assert clock.misses == []


class _CountingClock(FakeClock):
    def __init__(self) -> None:
        super().__init__()
        self.reads = 0

    def now(self) -> float:
        self.reads += 1
        return super().now()


def test_a_scheduled_frame_costs_the_writer_three_clock_reads(perf) -> None:
    # The wait's check, the send time, and after the write (a write that blocked): each read
    # of a relay's slewed clock costs its writer microseconds per frame (issue 9).
    clock = _CountingClock()
    # The simulated robot stamps what it receives on the same time, uncounted.
    link = SimTransport(create_robot("mini"), clock=lambda: FakeClock.now(clock),
                        sleep=clock.advance)
    link.open()
    count = 50
    ex = PerformerExecutor(
        perf("rex", count=count, spacing=0.05), link, clock=clock, profile=MINI, rest_at_end=False
    )
    ex.run(clock.now() + 0.1)
    assert ex.state is ExecutorState.FINISHED
    assert clock.reads <= 3 * count + 12  # + the start, the end and the state changes


class _ThreadNoting(SimTransport):
    """A simulated robot's link that notes which thread issued each write."""

    def __init__(self) -> None:
        super().__init__(create_robot("mini"))
        self.writers: list[int] = []

    def write(self, data: bytes) -> None:
        self.writers.append(threading.get_ident())
        super().write(data)


def test_frames_due_together_in_a_group_go_out_from_the_first_writer_awake(perf) -> None:
    # Two performers on one grid, on the real clock: the writer that wakes first writes the
    # other's frame too, instead of handing Python's lock over for it (IssueGroup).
    from xgo_show.runtime.clock import MonotonicClock
    from xgo_show.runtime.executor import IssueGroup

    clock = MonotonicClock()
    group = IssueGroup()
    count = 20
    links = [_ThreadNoting(), _ThreadNoting()]
    executors = []
    for name, link in zip(("rex", "ivy"), links, strict=True):
        link.open()
        executors.append(PerformerExecutor(
            perf(name, count=count, spacing=0.01), link, clock=clock, profile=MINI,
            rest_at_end=False, group=group,
        ))
    recorders = [EventRecorder(ex.events) for ex in executors]
    start = clock.now() + 0.05
    for ex in executors:
        ex.start(start)
    assert all(ex.join(10.0) for ex in executors)
    assert [ex.state for ex in executors] == [ExecutorState.FINISHED] * 2
    for link, ex, rec in zip(links, executors, recorders, strict=True):
        # Every frame once, in order, each announced once by its own executor.
        assert [f.data for f in link.robot.received] == [f.data for f in ex.schedule.frames]
        assert [r.index for r in rec.sent() if r.kind == "frame"] == list(range(count))
    # Each instant's two frames from one thread, most of the time (a writer preempted while
    # it holds Python's lock can lose it to the other's wake-up on a loaded machine).
    together = sum(a == b for a, b in zip(links[0].writers, links[1].writers, strict=True))
    assert together >= count // 2
