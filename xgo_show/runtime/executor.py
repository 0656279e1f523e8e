"""Paced execution of one performer's schedule over one transport.

:class:`PerformerExecutor` needs only a :class:`~xgo_show.compiler.schedule.PerformerSchedule`,
a :class:`~xgo_show.transports.base.Transport`, a start time and a
:class:`~xgo_show.runtime.clock.Clock`; it assumes nothing about where the port is, so a relay
on another host runs it unchanged in front of its own local port.

Timing. Frame ``i`` is due at ``start + (frame.t - offset)``, one monotonic start for the whole
show (a resume or a seek sets a new one), so waits never accumulate error. A frame that goes out
late does not make the following ones bunch up on the wire: each frame waits for
``max(due, previous_actual + wire_time(previous) + gap)``, which keeps the link's silence
between frames. Every send is recorded (planned and actual time).

Threads. :meth:`start` runs the writer in its own thread (one per port, so a blocked port delays
no one else); a reader thread parses telemetry replies when a poller is given. All writes go
through one lock, which lets :meth:`safe_stop` (called from any thread) cut in between two
frames: it raises the abort flag, takes the lock, and sends the stop frames itself, so pending
schedule frames are dropped and the stop never waits behind them.

Pause holds the robot: speeds go to neutral; on resume the executor first sends the frames that
bring the robot back to the state it had at the pause (``reach``), then continues with the
timeline shifted by the length of the pause. A start at ``offset > 0`` does the same before the
first frame.
"""

from __future__ import annotations

import enum
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame, ready_frames
from xgo_show.errors import TransportError, XgoShowError
from xgo_show.profiles.model import Profile
from xgo_show.runtime.clock import Clock, FakeClock, hand_off_cpu, tighten_timer_slack
from xgo_show.runtime.events import (
    EventBus,
    FaultRaised,
    FrameSent,
    SafeStopped,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.realtime import HELPER_PRIORITY, enter_show_thread, leave_show_thread
from xgo_show.runtime.safety import rest_frames, stop_frames
from xgo_show.runtime.telemetry import TelemetryItem, TelemetryPoller
from xgo_show.transports.base import Transport

__all__ = [
    "ExecutorState",
    "IssueGroup",
    "PerformerExecutor",
    "Progress",
    "ReachFn",
    "SafeStopResult",
]

# Frames (bytes, label) that bring a robot to the register state it has at show time t.
ReachFn = Callable[[float], Sequence[tuple[bytes, str]]]

# Extra room a telemetry request must leave before the next scheduled frame is due, beyond its
# own wire time and gap: covers the OS write call and scheduling noise.
_POLL_MARGIN = 0.002


class ExecutorState(enum.Enum):
    IDLE = "idle"
    REACHING = "reaching"  # sending catch-up frames (mid-show start or resume)
    RUNNING = "running"
    PAUSED = "paused"
    FINISHED = "finished"  # every frame sent, robot at rest
    STOPPED = "stopped"  # safe-stopped
    FAILED = "failed"  # port or telemetry fault

    @property
    def ended(self) -> bool:
        """Whether nothing more will happen to the performer: finished, stopped or failed."""
        return self in _ENDED


_ENDED = frozenset({ExecutorState.FINISHED, ExecutorState.STOPPED, ExecutorState.FAILED})


@dataclass(frozen=True)
class Progress:
    """Where a performer is: state, show time, frames sent of total, current cue."""

    performer: str
    state: ExecutorState
    show_time: float
    sent: int
    total: int
    cue: str
    label: str


@dataclass(frozen=True)
class SafeStopResult:
    """What a safe stop did on one performer."""

    performer: str
    reason: str
    ok: bool
    frames: tuple[str, ...] = ()  # labels of the frames written
    error: str = ""
    elapsed: float = 0.0  # seconds from the request to the last byte queued


@dataclass
class _Timeline:
    start: float = 0.0  # clock time at which show time ``offset`` happens
    offset: float = 0.0

    def at(self, t: float) -> float:
        return self.start + (t - self.offset)

    def show_time(self, now: float) -> float:
        return now - self.start + self.offset


@dataclass
class _Flags:
    wake: threading.Event = field(default_factory=threading.Event)
    abort: threading.Event = field(default_factory=threading.Event)
    pause: bool = False
    pause_at: float | None = None  # clock time the pause takes effect (None: at once)
    resume: bool = False
    resume_at: float | None = None  # clock time the show goes on (None: at once)
    seek: tuple[float, float | None] | None = None  # (show time, clock time or None)


class _Armed:
    """A scheduled frame waiting for its deadline in an :class:`IssueGroup`."""

    __slots__ = ("actual", "claimed", "data", "deadline", "done", "error")

    def __init__(self, deadline: float, data: bytes) -> None:
        self.deadline = deadline
        self.data = data
        self.claimed = False  # a peer took it to write (under the group's lock)
        self.actual: float | None = None  # when the peer issued it (None: it did not)
        self.error: Exception | None = None  # the peer's write failed so
        self.done = threading.Event()  # the peer is through with it


class IssueGroup:
    """Writers of one process whose frames fall due together: the first awake writes them all.

    A show plays its performers' frames on one grid (50 frames a second), so several writers
    wake for the same instant. Each needs Python's lock to write, and they get it one after
    another, each hand-over costing the next a wake-up (measured on this 2-CPU VM, mixed_five's
    five robots: 0.07 ms for the first writer of an instant, 0.13, 0.21 and 0.40 ms (p50) for
    the 2nd, 3rd and 4th, p99 up to 1.3 ms; docs/realtime.md). In a group, a writer arms its
    next frame before it waits; the first writer to write at an instant then writes every
    armed frame of the others already due, back to back while it holds the lock, and each
    owner, when it wakes, only does the bookkeeping (:class:`FrameSent` at the peer's send
    time). A peer skips a frame whose owner has a request pending (pause, seek, abort, frames
    to send), whose link is not free, or whose owner is writing (its lock is taken): the owner
    writes it then, as without a group. Members share one clock.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._armed: dict[PerformerExecutor, _Armed] = {}

    def arm(self, owner: PerformerExecutor, deadline: float, data: bytes) -> _Armed:
        entry = _Armed(deadline, data)
        with self._lock:
            self._armed[owner] = entry
        return entry

    def disarm(self, owner: PerformerExecutor, entry: _Armed) -> float | None:
        """Take the owner's frame back: the time a peer issued it at, or None (it did not)."""
        with self._lock:
            self._armed.pop(owner, None)
            claimed = entry.claimed
        if not claimed:
            return None
        entry.done.wait()  # the peer is writing it now: microseconds
        if entry.error is not None:
            raise entry.error
        return entry.actual

    def issue_due(self, writer: PerformerExecutor, now: float) -> None:
        """Called by ``writer`` right after its own write: issue the others' due frames."""
        with self._lock:
            due = [(ex, e) for ex, e in self._armed.items()
                   if ex is not writer and not e.claimed and e.deadline <= now]
            for _, e in due:
                e.claimed = True
        if not due:
            return
        try:
            for ex, e in due:
                try:
                    e.actual = ex._issue_for_peer(e.data, now)
                except Exception as exc:  # the owner reports it, in its own thread
                    e.error = exc
        finally:
            for _, e in due:
                e.done.set()


class PerformerExecutor:
    """Sends one performer's frames on time; stops safely on request or fault.

    Implements the :class:`~xgo_show.runtime.performer.Performer` protocol. Parameters beyond
    the essential three are keyword-only:

    - ``clock``: the :class:`Clock` every deadline is read on (a :class:`FakeClock` runs the
      schedule without waiting);
    - ``profile``: the performer's profile (stop frames, telemetry layout); looked up from the
      schedule's model when omitted;
    - ``telemetry``: a :class:`TelemetryPoller` to poll in spare link time (None: no polling);
    - ``reach``: frames that bring the robot to its state at a show time (mid-show starts,
      resume after pause, seek); None: start from the first frame at or after the offset as is;
    - ``linger_until``: show time to keep polling telemetry after the last frame (the whole
      show's end, so a performer that finished early is still watched);
    - ``events``: the :class:`EventBus` to publish on (default: a bus of its own, ``.events``);
    - ``read_port``: False when the port's owner reads it and hands the bytes to
      :meth:`received` (a behaviour keeps one reader per port across the executors it runs
      one after another: a hand-over then waits for no reader to stop);
    - ``group``: an :class:`IssueGroup` shared with the other executors of the process (on
      the same clock), whose frames due at the same instant the first writer awake issues.
    """

    def __init__(
        self,
        schedule: PerformerSchedule,
        transport: Transport,
        *,
        clock: Clock,
        profile: Profile | None = None,
        telemetry: TelemetryPoller | None = None,
        reach: ReachFn | None = None,
        linger_until: float | None = None,
        events: EventBus | None = None,
        rest_at_end: bool = True,
        read_port: bool = True,
        group: IssueGroup | None = None,
    ) -> None:
        if profile is None:
            from xgo_show.profiles import get_profile

            profile = get_profile(schedule.model)
        self.schedule = schedule
        # A compiled schedule's frames are made when first read: here, not in the show thread.
        ready_frames(schedule.frames)
        self.transport = transport
        self.clock = clock
        self.profile = profile
        self.telemetry = telemetry if telemetry is not None and telemetry.enabled else None
        self.reach = reach
        self.linger_until = max(schedule.end, linger_until or 0.0)
        self.events = events if events is not None else EventBus()
        self.rest_at_end = rest_at_end
        self.read_port = read_port
        # Never on virtual time: each fake clock jumps on its own (no instant is shared).
        self._group = None if isinstance(clock, FakeClock) else group
        # What a pause and the normal end send: the same frames every time.
        self._rest = [(f.data, f.label) for f in rest_frames(profile)]
        self.fault: str | None = None
        self.stop_result: SafeStopResult | None = None
        self._state = ExecutorState.IDLE
        self._shown = ExecutorState.IDLE  # the state whose StateChanged is published (progress)
        self._timeline = _Timeline()
        self._flags = _Flags()
        self._write_lock = threading.Lock()
        self._state_lock = threading.Lock()
        self._ready_at = float("-inf")  # earliest time the link is free (wire time + gap)
        self._sent_frames = 0
        self._cue = ""
        self._paused_at: float | None = None
        self._writer: threading.Thread | None = None
        self._reader: threading.Thread | None = None
        self._reader_stop = threading.Event()
        self._extra: list[tuple[bytes, str]] = []  # frames to send beside the schedule

    # ------------------------------------------------------------------ public control

    @property
    def name(self) -> str:
        return self.schedule.name

    @property
    def model(self) -> str:
        return self.schedule.model

    @property
    def state(self) -> ExecutorState:
        return self._state

    @property
    def done(self) -> bool:
        """Whether the writer has nothing more to do (finished, stopped or failed)."""
        return self._state.ended

    @property
    def readings(self) -> Mapping[str, float]:
        """The latest telemetry values (a copy); empty without telemetry."""
        return dict(self.telemetry.last) if self.telemetry is not None else {}

    def lead_time(self, offset: float) -> float:
        """Seconds the catch-up frames of a start at ``offset`` need on the link (+50 ms)."""
        if offset <= 0 or self.reach is None:
            return 0.05
        link = self.schedule.link
        frames = self.reach(offset)
        return sum(link.wire_time(len(d)) + link.gap for d, _ in frames) + 0.05

    def start(self, start_at: float, *, offset: float = 0.0) -> None:
        """Run in background threads; show time ``offset`` happens at clock time ``start_at``."""
        self._start_reader()
        self._writer = threading.Thread(
            target=self._run_guarded, args=(start_at, offset), name=f"xgo-show writer {self.name}"
        )
        self._writer.daemon = True
        self._writer.start()

    def run(self, start_at: float, *, offset: float = 0.0) -> None:
        """Run in the calling thread until the performer's part is over or it is stopped."""
        self._start_reader()
        try:
            self._run_guarded(start_at, offset)
        finally:
            self.close()

    def join(self, timeout: float | None = None) -> bool:
        """Wait for the writer thread; return whether it has ended."""
        if self._writer is None:
            return True
        self._writer.join(timeout)
        return not self._writer.is_alive()

    def pause(self, *, at: float | None = None) -> None:
        """Hold from clock time ``at`` (default: the next frame): speeds to neutral, timeline
        frozen until :meth:`resume`. No frame planned at or after ``at`` goes out."""
        self._flags.pause_at = at
        self._flags.pause = True
        self._flags.wake.set()

    def resume(self, *, at: float | None = None) -> None:
        """Bring the robot back to where the show was and go on; with ``at``, the show time
        of the pause happens at clock time ``at`` (catch-up frames go before it)."""
        self._flags.resume_at = at
        self._flags.resume = True
        self._flags.wake.set()

    def send(self, frames: Iterable[tuple[bytes, str]]) -> None:
        """Write ``frames`` (data, label) as soon as the link is free, between scheduled frames
        (a setting or LED colour a behaviour writes beside the routine playing; frames given
        before :meth:`start` go before the first frame). Each may hold the next scheduled
        frame for its wire time; sent as ``"set"`` frames."""
        with self._state_lock:
            self._extra.extend(frames)
        self._flags.wake.set()

    def _send_extra(self) -> bool:
        """Send the frames :meth:`send` queued; False if aborted."""
        with self._state_lock:
            frames, self._extra = self._extra, []
        return self._send_now("set", frames)

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        """Jump to ``show_time``: catch-up frames, then the show goes on from there at clock
        time ``at`` (default: as soon as they are sent). While paused, takes effect on resume."""
        self._flags.seek = (max(0.0, show_time), at)
        self._flags.wake.set()

    def abort(self) -> None:
        """Stop sending schedule frames (no stop frames: see :meth:`safe_stop`)."""
        self._flags.abort.set()
        self._flags.wake.set()

    def safe_stop(self, reason: str, *, timeout: float = 0.1) -> SafeStopResult:
        """Drop pending frames and send the stop sequence now; safe to call from any thread.

        Waits at most ``timeout`` for a write in progress to return. Idempotent: a second call
        returns the first result.
        """
        requested = self.clock.now()
        self.abort()
        if not self._write_lock.acquire(timeout=timeout):
            result = SafeStopResult(self.name, reason, False, error="port blocked: write stuck")
            return self._finish_stop(result)
        try:
            if self.stop_result is not None:
                return self.stop_result
            sent: list[str] = []
            try:
                for frame in stop_frames(self.profile):
                    self._write_locked(frame.data, "stop", None, None, frame.label)
                    sent.append(frame.label)
            except Exception as exc:  # any failure of a dying port: report it, never raise
                result = SafeStopResult(
                    self.name, reason, False, tuple(sent), f"{exc}", self.clock.now() - requested
                )
            else:
                result = SafeStopResult(
                    self.name, reason, True, tuple(sent), "", self.clock.now() - requested
                )
            return self._finish_stop(result)
        finally:
            self._write_lock.release()

    def close(self) -> None:
        """Stop the reader thread (the transport stays open: its owner closes it)."""
        self._reader_stop.set()
        if self._reader is not None and self._reader is not threading.current_thread():
            self._reader.join(1.0)

    @property
    def progress(self) -> Progress:
        """Where the performer is; its state is the last one announced (its StateChanged
        published), which :attr:`state` may be ahead of for the time of that publication."""
        now = self.clock.now()
        sent = self._sent_frames  # schedule index + 1 of the last frame sent
        state = self._shown
        show_time = (
            0.0
            if state is ExecutorState.IDLE
            else self._timeline.show_time(self._paused_at if self._paused_at is not None else now)
        )
        return Progress(
            self.name,
            state,
            show_time,
            sent,
            len(self.schedule.frames),
            self._cue,
            self.schedule.frames[sent - 1].label if sent else "",
        )

    # ------------------------------------------------------------------ writer

    def _set_state(self, state: ExecutorState) -> None:
        with self._state_lock:
            if self.done and state not in (ExecutorState.STOPPED, ExecutorState.FAILED):
                return
            if state is self._state:
                return
            self._state = state
        now = self.clock.now()
        at = self._paused_at if self._paused_at is not None else now
        show_time = 0.0 if state is ExecutorState.IDLE else self._timeline.show_time(at)
        self.events.publish(StateChanged(now, self.name, state, show_time))
        # Only now may :attr:`progress` say so: whoever reads it there (a relay's heartbeat
        # answer, a status query) finds the event already published, so the state's own row
        # goes out with it, never after the end it announces. A later transition that came in
        # meanwhile sets its own after its event.
        with self._state_lock:
            if self._state is state:
                self._shown = state

    def _finish_stop(self, result: SafeStopResult) -> SafeStopResult:
        if self.stop_result is None:
            self.stop_result = result
            self._set_state(ExecutorState.STOPPED if self.fault is None else ExecutorState.FAILED)
            self.events.publish(SafeStopped(self.clock.now(), self.name, result))
        return self.stop_result

    def _run_guarded(self, start_at: float, offset: float) -> None:
        tighten_timer_slack()
        # SCHED_FIFO for this thread when the process's real-time policy grants it; a
        # writer on a fake clock never waits, so it must never be raised.
        raised = not isinstance(self.clock, FakeClock) and enter_show_thread()
        try:
            self._run(start_at, offset)
        except (TransportError, OSError) as exc:
            self._report_fault(f"port {self.transport.url}: {exc}")
        except XgoShowError as exc:
            self._report_fault(str(exc))
        except Exception as exc:  # any writer crash must still stop the robot
            self._report_fault(f"internal error in the executor: {exc!r}")
        finally:
            if raised:
                leave_show_thread()

    def _first_index(self, show_time: float) -> int:
        frames = self.schedule.frames
        return next((i for i, f in enumerate(frames) if f.t >= show_time - 1e-9), len(frames))

    def _run(self, start_at: float, offset: float) -> None:
        self._timeline = _Timeline(start_at, offset)
        frames = self.schedule.frames
        flags = self._flags
        index = self._first_index(offset)
        if offset > 0 and self.reach is not None:
            self._set_state(ExecutorState.REACHING)
            if not self._send_now("reach", self.reach(offset)):
                return  # aborted during the catch-up: it never ran
        self._set_state(ExecutorState.RUNNING)
        while True:
            flags.wake.clear()  # before reading the flags: a request after this wakes the wait
            if flags.abort.is_set():
                return
            if self._extra and not self._send_extra():
                return
            if flags.seek is not None:
                index = self._seek_now()
                continue
            if index >= len(frames):
                # Keep watching (telemetry) until the whole show is over.
                if flags.pause:
                    index = self._hold(index)
                    continue
                if self._wait(self._timeline.at(self.linger_until)):
                    break
                continue
            frame = frames[index]
            planned = self._timeline.at(frame.t)
            deadline = max(planned, self._ready_at)
            if flags.pause:
                pause_at = flags.pause_at
                if pause_at is None or planned >= pause_at:
                    index = self._hold(index)
                    continue
                deadline = min(deadline, pause_at)  # wake up for a pause due before this frame
            # The deadline is never before the frame's planned time (a pause at or before it
            # holds above): a wait that reaches it is one for this frame, which then goes out.
            group = self._group
            entry = group.arm(self, deadline, frame.data) if group is not None else None
            try:
                woke = self._wait(deadline)
            finally:
                # A peer may have written the frame meanwhile (then its time is kept).
                by_peer = None if group is None or entry is None else group.disarm(self, entry)
            if by_peer is not None:
                self._announce(frame.data, "frame", index, planned, frame, by_peer)
            else:
                if not woke:
                    continue  # woken by a request: re-check the flags
                # The wait ended at the deadline, which the link is free by unless a telemetry
                # request sent meanwhile was late enough to hold it longer: known without a
                # clock read (each costs a relayed writer's slewed clock some microseconds).
                ready = self._ready_at <= deadline
                if not self._write(frame.data, "frame", index, planned, frame, ready=ready):
                    return
            index += 1
            self._sent_frames = index
            if frame.origin is not None and frame.origin.cue:
                self._cue = frame.origin.cue
        if flags.abort.is_set():
            return
        if self.rest_at_end and not self._send_now("rest", self._rest):
            return
        self._set_state(ExecutorState.FINISHED)

    def _rebase(self, show_time: float, at: float) -> None:
        """Show time ``show_time`` happens at clock time ``at`` from now on."""
        self._timeline = _Timeline(at, show_time)

    def _go_on(
        self,
        show_time: float,
        at: float | None,
        index: int,
        catch_up: Sequence[tuple[bytes, str]] | None = None,
    ) -> None:
        """Catch up to ``show_time`` (with ``catch_up`` if made already, else the reach's
        frames), then play on from it (schedule ``index``) at clock time ``at`` (None: once the
        catch-up frames are sent). Aborted meanwhile, it returns early: the caller's loop ends."""
        self._sent_frames = index
        if self.reach is not None:
            frames = self.reach(show_time) if catch_up is None else catch_up
            if frames:
                self._set_state(ExecutorState.REACHING)
                if not self._send_now("reach", frames):
                    return
        now = self.clock.now()
        # As soon as possible means when the link is free after the catch-up frames: the
        # first frame then goes out on its planned time, not late by their wire time.
        go = at if at is not None and at > now else max(now, self._ready_at)
        self._rebase(show_time, go)
        self._paused_at = None
        if go > now and not self.clock.sleep_until(go, self._flags.abort):
            return
        self._set_state(ExecutorState.RUNNING)

    def _seek_now(self) -> int:
        """Apply a pending seek while playing; returns the index to continue from."""
        seek = self._flags.seek
        assert seek is not None
        self._flags.seek = None
        show_time, at = seek
        index = self._first_index(show_time)
        self._go_on(show_time, at, index)
        return index

    def _hold(self, index: int) -> int:
        """Pause: rest the robot, wait for resume (polling telemetry), then reach back.

        Returns the schedule index to go on from (a seek while paused moves it).
        """
        flags = self._flags
        pause_at = flags.pause_at
        flags.pause = False
        flags.pause_at = None
        if pause_at is not None and not self.clock.sleep_until(pause_at, flags.abort):
            return index
        # Every host given the same pause time holds at the same show time, even one that got
        # the request late (the frames it already sent are not taken back).
        self._paused_at = pause_at if pause_at is not None else self.clock.now()
        show_time = self._timeline.show_time(self._paused_at)
        self._set_state(ExecutorState.PAUSED)
        # A reach that knows what the rest frames change (the compiler's: ``at_rest``,
        # ``after_rest``) spares the rest frames when the show has the robot at rest there
        # already (the link stays free for a release), and makes the catch-up for going on
        # now, while the robot holds: only what the rest frames changed, so a resume (a
        # trigger's release) writes the next frame at once.
        at_rest = getattr(self.reach, "at_rest", None)
        after_rest = getattr(self.reach, "after_rest", None)
        rested = at_rest is not None and at_rest(show_time)
        if not rested and not self._send_now("rest", self._rest):
            return index
        catch_up: Sequence[tuple[bytes, str]] | None = (
            None if after_rest is None else [] if rested else after_rest(show_time))
        while not flags.resume and not flags.abort.is_set():
            if self._extra:
                self._send_extra()
            self._poll_once()
            flags.wake.wait(0.02)
            flags.wake.clear()
        flags.resume = False
        resume_at, flags.resume_at = flags.resume_at, None
        if flags.abort.is_set():
            return index
        if flags.seek is not None:
            show_time = flags.seek[0]
            flags.seek = None
            index = self._first_index(show_time)
            catch_up = None  # elsewhere: the whole state at the new place
        self._go_on(show_time, resume_at, index, catch_up)
        return index

    def _send_now(self, kind: str, frames: Iterable[tuple[bytes, str]]) -> bool:
        """Send frames outside the schedule (reach, rest) as soon as the link is free each
        time (:meth:`_write` waits for it); return False if aborted."""
        # all() stops at the first write refused (aborted): nothing is sent after it.
        return all(self._write(data, kind, None, None, label) for data, label in frames)

    def _wait(self, deadline: float) -> bool:
        """Wait for ``deadline``, sending due telemetry requests where they fit.

        Returns False when woken early by pause or abort.
        """
        clock = self.clock
        gap = self.schedule.link.gap
        while True:
            now = clock.now()
            if now >= deadline:
                return True
            target = deadline
            item = self.telemetry.due(now) if self.telemetry is not None else None
            if item is not None:
                link = self.schedule.link
                room = (
                    link.wire_time(len(item.request) + item.reply_bytes) + gap + _POLL_MARGIN
                )
                if now >= self._ready_at and now + room <= deadline:
                    if not self._send_read(item):
                        return False
                    continue
                if self._ready_at + room <= deadline:
                    target = max(self._ready_at, now)
            elif self.telemetry is not None:
                target = min(deadline, max(self.telemetry.next_due, now))
            if target <= now:
                target = deadline
            if not clock.sleep_until(target, self._flags.wake):
                return False
            if target == deadline:
                return True  # a clock's wait ends at or after its deadline: no second read

    def _poll_once(self) -> None:
        if self.telemetry is None:
            return
        now = self.clock.now()
        item = self.telemetry.due(now)
        if item is not None and now >= self._ready_at:
            self._send_read(item)

    def _send_read(self, item: TelemetryItem) -> bool:
        """Send one telemetry request; the link stays busy for its reply where it must."""
        assert self.telemetry is not None
        if not self._write(item.request, "read", None, None, item.name):
            return False
        if item.reply_bytes:
            with self._write_lock:
                self._ready_at += self.schedule.link.wire_time(item.reply_bytes)
        self.telemetry.sent(self.clock.now())
        return True

    def _write(
        self,
        data: bytes,
        kind: str,
        index: int | None,
        planned: float | None,
        label: str | ScheduledFrame,
        *,
        ready: bool = False,
    ) -> bool:
        """Write one frame unless aborted; return False if aborted.

        ``label`` names a frame outside the schedule, or is the schedule frame written (whose
        label listeners derive when they need it: not on the writer's time). ``ready``: the
        caller knows the link is free (its wait ended past :attr:`_ready_at`).
        """
        # Wait for the link outside the lock, so a safe stop never waits behind this frame.
        if not ready and self.clock.now() < self._ready_at:
            self.clock.sleep_until(self._ready_at, self._flags.abort)
        with self._write_lock:
            if self._flags.abort.is_set():
                return False
            self._write_locked(data, kind, index, planned, label, ready=ready)
            return True

    def _write_locked(
        self,
        data: bytes,
        kind: str,
        index: int | None,
        planned: float | None,
        label: str | ScheduledFrame,
        *,
        ready: bool = False,
    ) -> None:
        # Keep the link's silence after whatever went before (stop frames included); the link
        # stays ready under the lock (only writes move _ready_at, and they hold it).
        if not ready and self.clock.now() < self._ready_at:
            self.clock.sleep_until(self._ready_at)
        actual, after = self._issue(data)
        if self._group is not None and kind == "frame":
            # Before anything else of this thread's: the others' frames of this instant.
            self._group.issue_due(self, after)
        # A real-time writer lets the kernel worker that moves the bytes (ptys) run now, not
        # after this thread's bookkeeping; the link is busy for the frame meanwhile anyway.
        hand_off_cpu()
        self._announce(data, kind, index, planned, label, actual)

    def _issue_for_peer(self, data: bytes, now: float) -> float | None:
        """Write this executor's armed frame from a peer's thread (:class:`IssueGroup`):
        the send time, or None when the owner must write it itself."""
        if not self._write_lock.acquire(blocking=False):
            return None  # the owner is writing (a telemetry request, a stop)
        try:
            flags = self._flags
            if flags.wake.is_set() or flags.abort.is_set() or now < self._ready_at:
                return None  # a request pending, or the link still busy: the owner decides
            return self._issue(data)[0]
        finally:
            self._write_lock.release()

    def _issue(self, data: bytes) -> tuple[float, float]:
        """Write ``data`` now (the write lock held) and book the link for it: the send time
        and the time the write returned."""
        # The send time is when the write is issued: the bytes leave as soon as it queues them,
        # and the call may return late only because this thread lost its CPU meanwhile.
        actual = self.clock.now()
        self.transport.write(data)
        after = self.clock.now()
        # The link is busy for the frame's wire time from the send, and never free before the
        # write returned (a write that blocked means the bytes left late).
        link = self.schedule.link
        self._ready_at = max(actual + link.wire_time(len(data)), after) + link.gap
        return actual, after

    def _announce(
        self,
        data: bytes,
        kind: str,
        index: int | None,
        planned: float | None,
        label: str | ScheduledFrame,
        actual: float,
    ) -> None:
        """Publish what was written at ``actual``."""
        tl = self._timeline
        note, frame = (label, None) if isinstance(label, str) else ("", label)
        self.events.publish(
            FrameSent(
                actual,
                self.name,
                kind,
                index,
                planned,
                data,
                note,
                None if planned is None else tl.show_time(planned),
                tl.show_time(actual),
                frame,
            )
        )

    # ------------------------------------------------------------------ reader and faults

    def _start_reader(self) -> None:
        if self.telemetry is None or self._reader is not None or not self.read_port:
            return
        self._reader = threading.Thread(target=self._read_loop, name=f"xgo-show reader {self.name}")
        self._reader.daemon = True
        self._reader.start()

    def _read_loop(self) -> None:
        assert self.telemetry is not None
        # Below the writers but above every normal thread: this thread takes Python's lock
        # while frames are due, and one preempted while holding it keeps the writers waiting.
        raised = not isinstance(self.clock, FakeClock) and enter_show_thread(HELPER_PRIORITY)
        try:
            while not self._reader_stop.is_set():
                try:
                    chunk = self.transport.read(256, timeout=0.05)
                except (TransportError, OSError) as exc:
                    if not self._reader_stop.is_set() and not self.done:
                        self._report_fault(f"port {self.transport.url}: {exc}")
                    return
                if chunk and not self.received(chunk, self.clock.now()):
                    return
        finally:
            if raised:
                leave_show_thread()

    def received(self, chunk: bytes, now: float) -> bool:
        """Bytes read from the port at ``now``: publish the readings they complete; a fault
        they show stops the robot. Returns False once faulted (stop reading for it)."""
        if self.telemetry is None:
            return True
        for sample in self.telemetry.feed(chunk, now):
            self.events.publish(TelemetryRead(sample.t, self.name, sample.name, sample.value))
        if self.telemetry.fault is not None and not self.done:
            self._report_fault(self.telemetry.fault)
            return False
        return True

    def port_failed(self, reason: str) -> None:
        """The port's owner could not read it: a fault (a safe stop) unless already done."""
        if not self.done:
            self._report_fault(reason)

    def _report_fault(self, reason: str) -> None:
        with self._state_lock:
            if self.fault is not None:
                return
            self.fault = reason
        self.abort()
        self._set_state(ExecutorState.FAILED)
        self.events.publish(FaultRaised(self.clock.now(), self.name, reason))
