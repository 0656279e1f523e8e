"""What the event publisher (control/publisher.py) puts on Zenoh for each runtime event, in
this process on a fake clock: the keys and payloads, cues only when they change, progress and
telemetry at most once an interval, the noisy-trigger windows, and what a failing put costs.
Every payload read back is checked against its schema (schemas/zenoh-api.v1.schema.json):
the fault and robot safe-stop events too, which the tour of test_server.py cannot provoke."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import jsonschema
import pytest

from xgo_show.choreo.sections import Section, Wait
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.control.director import TriggerRefused, WaitReleased, WaitStarted
from xgo_show.control.protocol import PROTOCOL_VERSION
from xgo_show.control.publisher import EventPublisher
from xgo_show.control.schemas import definition
from xgo_show.control.status import robots_status
from xgo_show.diagnostics import Origin
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import (
    FaultRaised,
    FrameSent,
    ProgressTick,
    SafeStopped,
    ShowEnded,
    ShowPaused,
    ShowResumed,
    ShowSought,
    ShowStarted,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult
from xgo_show.runtime.show_runner import ShowProgress

LINK = get_profile("mini").link
SECTIONS = (Section("intro", 0.0), Section("drop", 4.0, Wait("go", 2.5, "end")))
SCHEDULE = Schedule("demo", "demo.yaml", (PerformerSchedule("rex", "mini", LINK, (), 8.0),),
                    50.0, sections=SECTIONS, bpm=120.0)  # type: ignore[arg-type]


#: The fields of a refused trigger's event beside its name (a noisy event as the server makes it).
REFUSED = {"accepted": False, "reason": "no section waits for it"}


class Sink:
    """What the publisher put, in order; ``fail`` makes the next puts raise."""

    def __init__(self) -> None:
        self.sent: list[tuple[str, dict[str, Any]]] = []
        self.fail = 0
        self.lock = threading.Lock()

    def put(self, key: str, payload: dict[str, Any]) -> None:
        with self.lock:
            if self.fail:
                self.fail -= 1
                raise RuntimeError("session closed")
            self.sent.append((key, payload))

    def events(self) -> list[dict[str, Any]]:
        """Payloads without their envelope (``v`` and ``time``), keys checked against them,
        each payload against its schema."""
        out = []
        with self.lock:
            for key, payload in self.sent:
                assert payload["v"] == PROTOCOL_VERSION
                schema = jsonschema.Draft202012Validator(definition(f"event-{payload['event']}"))
                errors = [e.message for e in schema.iter_errors(payload)]
                assert not errors, (payload, errors)
                body = {k: v for k, v in payload.items() if k not in ("v", "time")}
                kind = "event/telemetry/" + body["robot"] if body["event"] == "telemetry" else \
                    "event/" + body["event"]
                assert key == f"stage/{kind}", (key, body)
                out.append(body)
        return out


def until(predicate: Any, timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, "not in time"
        time.sleep(0.002)


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def sink() -> Sink:
    return Sink()


@pytest.fixture
def pub(clock: FakeClock, sink: Sink) -> Iterator[EventPublisher]:
    publisher = EventPublisher("stage", sink.put, clock=clock, progress_interval=1.0,
                               noisy_per_second=3, window=1.0)
    yield publisher
    publisher.close()


def sent_after(pub: EventPublisher, sink: Sink, n: int) -> list[dict[str, Any]]:
    """The events once ``n`` are out (the publisher thread sends them)."""
    until(lambda: len(sink.sent) >= n)
    time.sleep(0.01)  # and no more
    return sink.events()


def cue_frame(t: float, performer: str, cue: str | None, *, show_t: float = 1.0) -> FrameSent:
    origin = None if cue is None else Origin("show.yaml", 3, 5, cue)
    frame = ScheduledFrame(show_t, b"\x01", origin)
    actual = show_t + 0.25 + 2.4e-7  # published to the microsecond
    return FrameSent(t, performer, "frame", 0, t, b"\x01", "", show_t, actual, frame)


def test_each_state_event_is_published_with_its_fields(pub: EventPublisher, sink: Sink) -> None:
    on = pub.listen(SCHEDULE)
    stopped = SafeStopResult("rex", "SIGINT", False, error="port gone")
    events = [
        ShowStarted(1.0, "demo", 0.5000004, 1.0, ("rex",), "halt_all", 20),
        StateChanged(1.0, "rex", ExecutorState.RUNNING, 0.1234567),
        FaultRaised(1.1, "rex", "battery low"),
        SafeStopped(1.2, "rex", stopped),
        ShowPaused(1.3, 2.2500004),
        ShowResumed(1.4, 2.5000004),
        ShowSought(1.5, 5.0, 5.0),
        WaitStarted(1.6, "drop", "go", 4.12345678, 2.5),
        WaitReleased(1.7, "drop", "go", "trigger", "continue"),
        ShowEnded(1.8, False, "fault: rex", {"rex": "battery low"}),
    ]
    for event in events:
        on(event)
    assert sent_after(pub, sink, len(events)) == [
        {"event": "state", "state": "playing", "show": "demo", "offset": 0.5},
        {"event": "state", "robot": "rex", "state": "running", "show_time": 0.123457},
        {"event": "fault", "robot": "rex", "reason": "battery low"},
        {"event": "state", "robot": "rex", "state": "safe_stopped", "ok": False,
         "reason": "SIGINT", "error": "port gone"},
        {"event": "state", "state": "paused", "show_time": 2.25},
        {"event": "state", "state": "playing", "show_time": 2.5},
        {"event": "state", "state": "seek", "show_time": 5.0, "bar": 3, "beat": 3.0,
         "section": "drop"},
        {"event": "wait", "state": "waiting", "section": "drop", "trigger": "go",
         "show_time": 4.123457, "timeout": 2.5},
        {"event": "wait", "state": "released", "section": "drop", "trigger": "go",
         "how": "trigger", "goto": "continue"},
        {"event": "state", "state": "ended", "completed": False, "reason": "fault: rex",
         "faults": {"rex": "battery low"}},
    ]


def test_every_payload_carries_the_protocol_version_and_the_wall_time(
    pub: EventPublisher, sink: Sink
) -> None:
    before = time.time()
    pub.publish("hello", n=1)
    until(lambda: sink.sent)
    key, payload = sink.sent[0]
    assert key == "stage/event/hello"
    assert payload["v"] == PROTOCOL_VERSION and payload["event"] == "hello" and payload["n"] == 1
    assert before - 1e-3 <= payload["time"] <= time.time() + 1e-3


def test_a_seek_before_any_show_is_not_published(pub: EventPublisher, sink: Sink) -> None:
    on = pub._on_event  # no show listened to yet
    on(ShowSought(1.0, 5.0, 5.0))
    on(ShowPaused(1.1, 1.0))
    assert sent_after(pub, sink, 1) == [{"event": "state", "state": "paused", "show_time": 1.0}]


def test_a_cue_is_published_when_it_changes_for_each_robot(
    pub: EventPublisher, sink: Sink
) -> None:
    on = pub.listen(SCHEDULE)
    for event in [
        cue_frame(1.0, "rex", "wave"),
        cue_frame(1.1, "rex", "wave"),  # the same cue: nothing new
        cue_frame(1.15, "rex", None),  # a frame from no place in the file: nothing
        cue_frame(1.16, "rex", ""),  # from a place outside any cue: nothing
        cue_frame(1.2, "ivy", "wave", show_t=2.0),  # another robot's
        cue_frame(1.3, "rex", "bow", show_t=3.0),
        cue_frame(1.4, "rex", "wave", show_t=4.0),  # back again: a change
    ]:
        on(event)
    on(FrameSent(1.5, "rex", "rest", None, None, b"\x02", "rest", None, 4.5))  # not scheduled
    assert sent_after(pub, sink, 4) == [
        {"event": "cue", "robot": "rex", "cue": "wave", "show_time": 1.25},
        {"event": "cue", "robot": "ivy", "cue": "wave", "show_time": 2.25},
        {"event": "cue", "robot": "rex", "cue": "bow", "show_time": 3.25},
        {"event": "cue", "robot": "rex", "cue": "wave", "show_time": 4.25},
    ]


def test_a_new_show_starts_with_no_cues_and_no_readings(pub: EventPublisher, sink: Sink
                                                        ) -> None:
    on = pub.listen(SCHEDULE)
    on(cue_frame(1.0, "rex", "wave"))
    on(TelemetryRead(1.0, "rex", "battery", 90.0))
    on = pub.listen(SCHEDULE)
    on(cue_frame(2.0, "rex", "wave"))  # the same cue, but a new show: published
    on(progress_tick(2.0))
    events = sent_after(pub, sink, 3)
    assert [e["event"] for e in events] == ["cue", "cue", "progress"]  # no telemetry left


def progress_tick(t: float, show_time: float = 5.0) -> ProgressTick:
    rex = Progress("rex", ExecutorState.RUNNING, show_time, 10, 20, "wave", "pitch 6")
    return ProgressTick(t, ShowProgress(show_time, 8.12345678, (rex,), {}))


def test_progress_and_readings_go_out_at_most_once_an_interval(
    pub: EventPublisher, sink: Sink, clock: FakeClock
) -> None:
    on = pub.listen(SCHEDULE)
    on(TelemetryRead(1.0, "rex", "battery", 90.0))
    on(TelemetryRead(1.0, "rex", "pitch", 2.5))
    on(TelemetryRead(1.0, "ivy", "battery", 70.0))
    tick = progress_tick(1.0)
    on(tick)
    first = sent_after(pub, sink, 3)
    assert first[0] == {"event": "progress", "duration": 8.123457, "show_time": 5.0, "bar": 3,
                        "beat": 3.0, "section": "drop",
                        "robots": robots_status(tick.progress, {})}
    assert first[0]["robots"]["rex"]["cue"] == "wave"
    assert first[1:] == [
        {"event": "telemetry", "robot": "rex", "readings": {"battery": 90.0, "pitch": 2.5}},
        {"event": "telemetry", "robot": "ivy", "readings": {"battery": 70.0}},
    ]
    on(TelemetryRead(1.0, "rex", "battery", 89.0))
    clock.advance(0.999)
    on(progress_tick(1.0, 5.5))  # within the interval: nothing
    time.sleep(0.02)
    assert len(sink.sent) == 3
    clock.advance(0.001)
    on(progress_tick(1.0, 6.0))  # the interval is over
    events = sent_after(pub, sink, 6)
    assert events[3]["show_time"] == 6.0
    assert events[4] == {"event": "telemetry", "robot": "rex",
                         "readings": {"battery": 89.0, "pitch": 2.5}}


def test_no_progress_before_a_show_is_listened_to(pub: EventPublisher, sink: Sink) -> None:
    pub._on_event(progress_tick(1.0))
    pub.publish("warning", message="marker")
    assert sent_after(pub, sink, 1) == [{"event": "warning", "message": "marker"}]


def test_refused_triggers_are_noisy_a_few_a_window_then_one_warning(
    pub: EventPublisher, sink: Sink, clock: FakeClock
) -> None:
    on = pub.listen(SCHEDULE)
    for i in range(5):
        on(TriggerRefused(1.0, f"t{i}", "no section waits for it"))
    assert pub.suppressed == 2
    refused = sent_after(pub, sink, 3)
    assert refused == [{"event": "trigger", "trigger": f"t{i}", "accepted": False,
                        "reason": "no section waits for it"} for i in range(3)]
    clock.advance(0.999)
    assert not pub.publish_noisy("trigger", trigger="late", **REFUSED)  # the same window
    clock.advance(0.001)  # it is over: the publisher thread says what was left out
    events = sent_after(pub, sink, 4)
    assert events[3] == {"event": "warning", "suppressed": 3,
                         "message": "3 refused or malformed trigger(s) not published in the "
                         "last 1 s"}
    assert pub.suppressed == 3
    # A new window: three more go out; its one left out is said when it ends, alone.
    assert [pub.publish_noisy("trigger", trigger=f"n{i}", **REFUSED) for i in range(4)] == [
        True, True, True, False]
    assert pub.suppressed == 4
    clock.advance(1.0)
    events = sent_after(pub, sink, 8)
    assert [e["event"] for e in events[4:]] == ["trigger"] * 3 + ["warning"]
    assert events[7]["suppressed"] == 1


def test_a_window_without_suppressed_events_ends_without_a_warning(
    pub: EventPublisher, sink: Sink, clock: FakeClock
) -> None:
    assert all(pub.publish_noisy("trigger", trigger=f"t{i}", **REFUSED) for i in range(3))
    clock.advance(1.0)
    assert all(pub.publish_noisy("trigger", trigger=f"u{i}", **REFUSED) for i in range(3))
    time.sleep(0.02)
    assert [e["event"] for e in sent_after(pub, sink, 6)] == ["trigger"] * 6
    assert pub.suppressed == 0


def test_the_rate_is_per_second_over_the_window(sink: Sink, clock: FakeClock) -> None:
    pub = EventPublisher("stage", sink.put, clock=clock, noisy_per_second=4, window=0.5)
    try:
        assert [pub.publish_noisy("trigger", trigger="t", **REFUSED) for _ in range(3)] == [
            True, True, False]
        clock.advance(0.5)
        assert pub.publish_noisy("trigger", trigger="t", **REFUSED)
        events = sent_after(pub, sink, 4)
        assert events[2]["message"].endswith("in the last 0.5 s")
    finally:
        pub.close()


def test_a_full_queue_drops_the_oldest(clock: FakeClock) -> None:
    gate = threading.Event()
    sent: list[int] = []

    def slow(key: str, payload: dict[str, Any]) -> None:
        gate.wait(5.0)
        sent.append(payload["n"])

    pub = EventPublisher("stage", slow, clock=clock, maxlen=3)
    try:
        pub.publish("state", n=0)
        until(lambda: not pub._queue)  # the thread holds 0
        for n in range(1, 6):
            pub.publish("state", n=n)
        assert pub.dropped == 2
        gate.set()
        until(lambda: len(sent) == 4)
        assert sent == [0, 3, 4, 5]
    finally:
        pub.close()


def test_a_put_that_fails_is_counted_and_the_next_goes_out(
    pub: EventPublisher, sink: Sink
) -> None:
    sink.fail = 2
    for word in ("first", "second", "third"):
        pub.publish("warning", message=word)
    assert [e["message"] for e in sent_after(pub, sink, 1)] == ["third"]
    assert pub.dropped == 2


def test_close_sends_what_is_queued_then_ends_the_thread(clock: FakeClock) -> None:
    gate = threading.Event()
    sent: list[str] = []

    def slow(key: str, payload: dict[str, Any]) -> None:
        gate.wait(5.0)
        sent.append(payload["event"])

    pub = EventPublisher("stage", slow, clock=clock)
    for kind in ("a", "b", "c"):
        pub.publish(kind)
    gate.set()
    pub.close()
    assert sent == ["a", "b", "c"]
    assert not pub._thread.is_alive()


def test_the_defaults(clock: FakeClock) -> None:
    """A queue of 1024 events, progress once a second, ten noisy events a second."""
    gate = threading.Event()
    sent: list[dict[str, Any]] = []

    def slow(key: str, payload: dict[str, Any]) -> None:
        gate.wait(5.0)
        sent.append(payload)

    pub = EventPublisher("stage", slow, clock=clock)
    try:
        pub.publish("hold")
        until(lambda: not pub._queue)  # the thread holds it, blocked in put
        for n in range(1024):
            pub.publish("state", n=n)
        assert pub.dropped == 0
        pub.publish("state", n=1024)
        assert pub.dropped == 1
        assert [pub.publish_noisy("trigger") for _ in range(11)] == [True] * 10 + [False]
        on = pub.listen(SCHEDULE)
        on(progress_tick(1.0))
        clock.advance(0.999)
        on(progress_tick(1.0))
        assert [p for _, p in pub._queue if p["event"] == "progress"].__len__() == 1
        clock.advance(0.001)
        on(progress_tick(1.0))
        assert [p for _, p in pub._queue if p["event"] == "progress"].__len__() == 2
        assert [pub.publish_noisy("trigger") for _ in range(10)] == [True] * 10
    finally:
        gate.set()
        pub.close()


def test_the_publisher_thread_is_a_named_daemon(pub: EventPublisher) -> None:
    # Named for the thread-leak check; a daemon, so a publisher left open never keeps the
    # process alive at exit.
    threads = [t for t in threading.enumerate() if t is pub._thread]
    assert [(t.name, t.daemon) for t in threads] == [("xgo-show events", True)]


def test_close_waits_two_seconds_at_most_for_a_subscriber_that_hangs(clock: FakeClock
                                                                     ) -> None:
    hang = threading.Event()
    pub = EventPublisher("stage", lambda key, payload: hang.wait(30), clock=clock)
    pub.publish("stuck")
    until(lambda: not pub._queue)
    start = time.monotonic()
    pub.close()
    assert 1.9 < time.monotonic() - start < 2.9
    hang.set()
