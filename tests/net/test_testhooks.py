"""Test-only hooks read from the environment: a skewed relay clock and delayed sync replies."""

from __future__ import annotations

import pytest

from xgo_show.net.testhooks import (
    CLOCK_ENV,
    DELAY_ENV,
    DelayInjector,
    SkewedClock,
    clock_from_env,
    delay_from_env,
)
from xgo_show.runtime.clock import FakeClock, MonotonicClock


def test_no_variable_means_the_plain_clock_and_no_delay() -> None:
    assert isinstance(clock_from_env({}), MonotonicClock)
    assert delay_from_env({}) is None


def test_the_clock_variable_makes_a_skewed_clock() -> None:
    base = FakeClock(100.0)
    clock = clock_from_env({CLOCK_ENV: "offset=12.5, ppm=-80"}, base)
    assert isinstance(clock, SkewedClock)
    assert (clock.offset, clock.ppm) == (12.5, -80.0)
    assert clock.now() == pytest.approx(112.5)


def test_the_delay_variable_draws_reproducible_delays_within_the_jitter() -> None:
    inj = delay_from_env({DELAY_ENV: "mean=0.005,jitter=0.002,seed=3"})
    assert inj is not None
    draws = [inj.draw() for _ in range(500)]
    assert all(0.003 <= d <= 0.007 for d in draws)
    assert max(draws) - min(draws) > 0.003
    again = DelayInjector(0.005, 0.002, 3)
    assert [again.draw() for _ in range(500)] == draws


@pytest.mark.parametrize(
    ("env", "message"),
    [
        ({CLOCK_ENV: "12.5"}, "expected offset=N, ppm=N"),
        ({CLOCK_ENV: "offset=soon"}, "offset is not a number"),
        ({CLOCK_ENV: "ppm=20000"}, "under 10,000 ppm"),
        ({DELAY_ENV: "mean=0.001,jitter=0.002"}, "0 <= jitter <= mean"),
    ],
)
def test_bad_values_are_one_line_errors(env: dict[str, str], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        if CLOCK_ENV in env:
            clock_from_env(env, FakeClock())
        else:
            delay_from_env(env)


def test_host_time_walks_a_relay_clock_down_to_this_machine() -> None:
    from xgo_show.net.offset import Timebase
    from xgo_show.net.slew import SlewingClock
    from xgo_show.net.testhooks import host_time

    host = FakeClock(500.0)
    skewed = SkewedClock(host, offset=40.0, ppm=100.0)  # the relay's own clock
    show = SlewingClock(skewed)  # the conductor's time as the relay knows it
    show.follow(Timebase(offset=39.9, rate=100e-6, ref=500.0))
    host.advance(2.0)
    # What each clock reads now maps back to the host's own reading, and a time ahead too.
    assert host_time(show, show.now()) == pytest.approx(502.0, abs=1e-9)
    assert host_time(skewed, skewed.now()) == pytest.approx(502.0, abs=1e-9)
    assert host_time(show, show.now() + 1.0) == pytest.approx(503.0, abs=1e-6)
    assert host_time(host, 7.5) == 7.5  # a clock with no base is the host's


def test_the_start_tracer_logs_each_robots_first_frame_once_per_show() -> None:
    from xgo_show.net.testhooks import SkewedClock as Skewed
    from xgo_show.net.testhooks import StartTracer
    from xgo_show.runtime.events import EventBus, FrameSent, ShowEnded, ShowStarted

    host = FakeClock(100.0)
    clock = Skewed(host, offset=10.0)
    bus = EventBus()
    logged: list[tuple[str, dict[str, object]]] = []
    tracer = StartTracer(bus, clock, lambda event, **fields: logged.append((event, fields)))

    def frame(performer: str, kind: str, planned: float | None, t: float) -> FrameSent:
        return FrameSent(t, performer, kind, 0, planned, b"\x00", "", None, 0.0)

    def show(start: float) -> None:
        bus.publish(ShowStarted(start - 1, "s", 0.0, start, ("a", "b"), "halt_all", 0.0))
        bus.publish(frame("a", "read", None, start - 0.5))  # not a scheduled frame
        bus.publish(frame("a", "frame", start, start + 0.002))
        bus.publish(frame("a", "frame", start + 0.05, start + 0.051))  # not the first
        bus.publish(frame("b", "frame", start, start + 0.001))
        assert not logged or logged[-1][0] == "frames_host"  # nothing logged until the end
        bus.publish(ShowEnded(start + 1, True, "completed"))

    show(120.0)
    show(130.0)
    tracer.close()
    bus.publish(ShowStarted(139.0, "s", 0.0, 140.0, ("a",), "halt_all", 0.0))
    bus.publish(frame("a", "frame", 140.0, 140.0))  # after close: nothing
    logged = [(e, f) for e, f in logged if e == "first_frame"]
    assert [(e, f["performer"], f["start_at"]) for e, f in logged] == [
        ("first_frame", "a", 120.0),
        ("first_frame", "b", 120.0),
        ("first_frame", "a", 130.0),
        ("first_frame", "b", 130.0),
    ]
    first = logged[0][1]
    assert first == {"performer": "a", "start_at": 120.0, "planned": 120.0,
                     "actual": 120.002, "start_host": pytest.approx(110.0),
                     "planned_host": pytest.approx(110.0),  # 10 s behind the relay's clock
                     "actual_host": pytest.approx(110.002),
                     "seen_host": pytest.approx(100.0)}  # seen when the host clock read 100


def test_the_start_tracer_logs_every_scheduled_frame_on_the_host_clock_when_the_show_ends() -> None:
    from xgo_show.net.testhooks import SkewedClock as Skewed
    from xgo_show.net.testhooks import StartTracer
    from xgo_show.runtime.events import EventBus, FrameSent, ShowEnded, ShowStarted

    host = FakeClock(100.0)
    clock = Skewed(host, offset=10.0)
    bus = EventBus()
    logged: list[tuple[str, dict[str, object]]] = []
    tracer = StartTracer(bus, clock, lambda event, **fields: logged.append((event, fields)))

    def frame(performer: str, kind: str, index: int, planned: float | None, t: float) -> FrameSent:
        return FrameSent(t, performer, kind, index, planned, b"\x00", "", None, 0.0)

    bus.publish(ShowStarted(119.0, "s", 0.0, 120.0, ("a", "b"), "halt_all", 0.0))
    bus.publish(frame("a", "frame", 0, 120.0, 120.002))
    bus.publish(frame("a", "read", 1, None, 120.01))  # not a scheduled frame
    bus.publish(frame("a", "rest", 1, 120.05, 120.05))  # a stop frame: not either
    bus.publish(frame("a", "frame", 1, 120.05, 120.0515))
    host.advance(0.25)
    bus.publish(frame("b", "frame", 0, 120.0, 120.001))
    assert logged == []  # nothing until the end
    bus.publish(ShowEnded(121.0, True, "completed"))
    tracer.close()
    assert [e for e, _ in logged] == ["first_frame", "first_frame", "frames_host"]
    assert logged[1][1]["actual_host"] == pytest.approx(110.001)
    event, fields = logged[-1]
    assert event == "frames_host"
    assert fields["start_host"] == pytest.approx(110.0)
    frames = fields["frames"]
    assert isinstance(frames, dict) and set(frames) == {"a", "b"}
    assert [row[0] for row in frames["a"]] == [0, 1]
    assert frames["a"][1][1:] == pytest.approx((110.05, 110.0515, 100.0))  # seen: host now
    assert frames["b"][0][1:] == pytest.approx((110.0, 110.001, 100.25))
    bus.publish(ShowEnded(122.0, True, "completed"))  # after close: nothing
    assert len(logged) == 3  # nothing more


def test_host_time_stops_at_a_clock_that_cannot_say_how_it_maps_onto_its_base() -> None:
    from xgo_show.net.testhooks import host_time

    class Mapped:  # maps onto a base it does not name
        def to_base(self, t: float) -> float:
            return t - 1000.0

    class Based:  # names a base but cannot map onto it
        base = FakeClock(0.0)

    assert host_time(Mapped(), 5.0) == 5.0  # type: ignore[arg-type]
    assert host_time(Based(), 5.0) == 5.0  # type: ignore[arg-type]


def test_the_start_tracer_ignores_frames_outside_a_show_and_numbers_unindexed_ones_minus_1(
) -> None:
    from xgo_show.net.testhooks import StartTracer
    from xgo_show.runtime.events import EventBus, FrameSent, ShowEnded, ShowStarted

    host = FakeClock(100.0)
    bus = EventBus()
    logged: list[tuple[str, dict[str, object]]] = []
    tracer = StartTracer(bus, host, lambda event, **fields: logged.append((event, fields)))
    bus.publish(FrameSent(99.0, "a", "frame", 0, 99.0, b"\x00", "", None, 0.0))  # no show yet
    bus.publish(ShowEnded(99.5, True, "completed"))  # an end without a start: nothing
    assert logged == [] and bus.listener_errors == 0
    bus.publish(ShowStarted(100.0, "s", 0.0, 101.0, ("a",), "halt_all", 0.0))
    bus.publish(FrameSent(101.0, "a", "frame", None, 101.0, b"\x00", "", None, 0.0))
    bus.publish(FrameSent(101.0, "z", "frame", 0, 101.0, b"\x00", "", None, 0.0))  # not in it
    bus.publish(ShowEnded(102.0, True, "completed"))
    tracer.close()
    assert bus.listener_errors == 0
    assert logged[-1] == ("frames_host", {"start_host": 101.0,
                                          "frames": {"a": [(-1, 101.0, 101.0, 100.0)]}})


def test_the_start_tracer_converts_each_frame_by_the_mapping_it_was_timed_by() -> None:
    # The writer only keeps a row (no conversion right after its write); the conversion at
    # the show's end must still use the relay clock's mapping of that frame's time, not the
    # one a later estimate put in force (here 125 us apart).
    from xgo_show.net.offset import Timebase
    from xgo_show.net.slew import SlewingClock
    from xgo_show.net.testhooks import StartTracer, host_time
    from xgo_show.runtime.events import EventBus, FrameSent, ShowEnded, ShowStarted

    host = FakeClock(100.0)
    show = SlewingClock(SkewedClock(host, offset=40.0, ppm=50.0))
    show.follow(Timebase(offset=39.9, rate=50e-6, ref=100.0))
    bus = EventBus()
    logged: list[tuple[str, dict[str, object]]] = []
    tracer = StartTracer(bus, show, lambda event, **fields: logged.append((event, fields)))
    start = show.now() + 0.1
    bus.publish(ShowStarted(show.now(), "s", 0.0, start, ("a",), "halt_all", 0.0))
    host.advance(0.1)
    t = show.now()
    want = (host_time(show, start), host_time(show, t), host.now())
    bus.publish(FrameSent(t, "a", "frame", 0, start, b"\x00", "", 0.0, t - start))
    host.advance(0.25)
    show.follow(Timebase(offset=39.8, rate=50e-6, ref=100.0))  # 0.1 s off: slews from now
    assert abs(host_time(show, t) - want[1]) > 1e-4  # the new mapping puts t elsewhere
    bus.publish(ShowEnded(show.now(), True, "completed"))
    tracer.close()
    fields = dict(logged)["frames_host"]
    frames = fields["frames"]
    assert isinstance(frames, dict) and len(frames["a"]) == 1 and frames["a"][0][0] == 0
    assert frames["a"][0][1:] == pytest.approx(want, abs=1e-9)


def test_the_start_tracer_maps_frames_of_a_clock_that_names_no_base_by_its_mapping() -> None:
    from types import SimpleNamespace

    from xgo_show.net.testhooks import StartTracer
    from xgo_show.runtime.events import EventBus, FrameSent, ShowEnded, ShowStarted

    class Mapped:  # maps itself onto the host clock (1000 s behind) but names no base
        def now(self) -> float:
            return 1102.0

        def mapping(self) -> SimpleNamespace:
            return SimpleNamespace(base_time=lambda t: t - 1000.0)

    bus = EventBus()
    logged: list[tuple[str, dict[str, object]]] = []
    tracer = StartTracer(bus, Mapped(), lambda event, **fields: logged.append((event, fields)))  # type: ignore[arg-type]
    bus.publish(ShowStarted(1100.0, "s", 0.0, 1101.0, ("a",), "halt_all", 0.0))
    bus.publish(FrameSent(1101.5, "a", "frame", 0, 1101.0, b"\x00", "", None, 0.0))
    bus.publish(ShowEnded(1103.0, True, "completed"))
    tracer.close()
    assert bus.listener_errors == 0
    event, fields = logged[-1]
    assert event == "frames_host" and fields["frames"] == {"a": [(0, 101.0, 101.5, 102.0)]}
