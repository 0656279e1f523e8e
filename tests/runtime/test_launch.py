"""The launch stages against simulators on real pseudo-terminals: open, pre-flight, arm, run."""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from types import SimpleNamespace

import pytest

from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import XgoShowError
from xgo_show.profiles import get_profile
from xgo_show.runtime import launch as launch_module
from xgo_show.runtime.clock import FakeClock, MonotonicClock
from xgo_show.runtime.events import (
    EventBus,
    EventRecorder,
    PreflightDone,
    ShowEnded,
    ShowStarted,
)
from xgo_show.runtime.executor import PerformerExecutor
from xgo_show.runtime.latency import Early
from xgo_show.runtime.launch import (
    Endpoint,
    Launch,
    LocalPorts,
    PerformerContext,
    endpoints_for,
    local_runner,
    register_endpoint,
)
from xgo_show.runtime.performer import Performer
from xgo_show.runtime.preflight import PreflightError, PreflightRow
from xgo_show.runtime.realtime import policy
from xgo_show.runtime.safety import UnsafeScheduleError
from xgo_show.sim import PtyServer, create_robot
from xgo_show.sim.bench import SimBench
from xgo_show.transports.sim import SimTransport
from xgo_show.wire.xgo import TYPE_READ, write_frame


def test_the_stages_in_order_on_simulators(perf, sched) -> None:
    schedule = sched(perf("rex", "mini", count=5), perf("lola", "lite", count=4))
    with SimBench(schedule, ["rex", "lola"]) as sims, Launch(
        schedule, sims.urls, clock=FakeClock(), telemetry=False
    ) as launch:
        rec = EventRecorder(launch.events)
        with pytest.raises(XgoShowError, match="arm the launch"):
            launch.run()
        assert launch.open() == {}
        report = launch.preflight()
        assert report.ok and [r.performer for r in report.rows] == ["rex", "lola"]
        assert [r.firmware[:1] for r in report.rows] == ["M", "L"]
        launch.arm()
        result = launch.run()
        assert result.completed
        sims.settle()
        summaries = sims.summaries()
    assert summaries["rex"].frames_received >= 5 and summaries["lola"].frames_received >= 4
    kinds = [type(e) for e in rec.events if isinstance(e, PreflightDone | ShowStarted | ShowEnded)]
    assert kinds == [PreflightDone, ShowStarted, ShowEnded]


def test_a_robot_of_the_wrong_model_refuses_to_arm_unless_forced(perf, sched) -> None:
    schedule = sched(perf("rex", "mini", count=3))
    with PtyServer(create_robot("lite")) as server:
        with Launch(schedule, {"rex": server.path}, telemetry=False) as launch:
            launch.open()
            report = launch.preflight()
            assert not report.ok and "not mini" in report.rows[0].problems[0]
            with pytest.raises(PreflightError, match="--force"):
                launch.arm()
            launch.arm(force=True)  # the operator's call; the robot answers, so it may go
        server.settle()
        received = server.robot.received
        assert received and all(f.data[3] == TYPE_READ for f in received)  # reads only


def test_a_port_that_does_not_open_refuses_even_when_forced(perf, sched, tmp_path) -> None:
    schedule = sched(perf("rex", "mini", count=3))
    with Launch(schedule, {"rex": str(tmp_path / "no-such-port")}, telemetry=False) as launch:
        errors = launch.open()
        assert "rex" in errors
        report = launch.preflight()
        assert not report.ports_ok
        with pytest.raises(PreflightError, match="did not open"):
            launch.arm(force=True)


def test_unsafe_writes_are_refused_before_anything_opens(perf, sched) -> None:
    from dataclasses import replace

    from xgo_show.compiler.schedule import ScheduledFrame
    from xgo_show.profiles import get_profile

    good = perf("rex", "mini", count=2)
    zero = write_frame(get_profile("mini").register("servo_zero").address, b"\x01")
    bad = replace(good, frames=(*good.frames, ScheduledFrame(0.5, zero)))
    with pytest.raises(UnsafeScheduleError, match="servo_zero"):
        Launch(sched(bad), {"rex": "/dev/null-never-opened"})


class _Renamed:
    """A test endpoint for the ``test:`` scheme: local ports behind another URL, showing that
    a new kind of performer (a relay) plugs into the launch without touching it."""

    def __init__(self, schedule: Schedule, urls: Mapping[str, str]) -> None:
        self.inner = LocalPorts(schedule, {n: u.removeprefix("test:") for n, u in urls.items()})

    def __getattr__(self, name: str) -> object:
        return getattr(self.inner, name)


def test_a_registered_scheme_mixes_with_local_ports_in_one_table(
    perf, sched, monkeypatch
) -> None:
    def factory(schedule: Schedule, urls: Mapping[str, str]) -> Sequence[Endpoint]:
        return [_Renamed(schedule, urls)]  # type: ignore[list-item]

    monkeypatch.setitem(launch_module._SCHEMES, "test", factory)
    schedule = sched(perf("rex", "mini", count=3), perf("lola", "lite", count=3))
    with SimBench(schedule, ["rex", "lola"]) as sims:
        urls = {"rex": sims.urls["rex"], "lola": "test:" + sims.urls["lola"]}
        with Launch(schedule, urls, clock=FakeClock(), telemetry=False) as launch:
            assert len(launch.endpoints) == 0  # endpoints are chosen when the launch opens
            launch.open()
            assert [type(e).__name__ for e in launch.endpoints] == ["LocalPorts", "_Renamed"]
            report = launch.preflight()
            assert report.ok and [r.performer for r in report.rows] == ["rex", "lola"]
            launch.arm()
            assert launch.run().completed
            with pytest.raises(XgoShowError, match="already open"):
                launch.map({"rex": "x"})


class _Waiting:
    """A test endpoint whose open and pre-flight meet the other endpoints' at a barrier (so
    they pass only when they all run at once), or raise instead of answering."""

    def __init__(self, names: Sequence[str], barrier: threading.Barrier, fail: bool) -> None:
        self.names = tuple(names)
        self.barrier, self.fail = barrier, fail
        self.closed = False

    def open(self) -> Mapping[str, str]:
        self.barrier.wait()
        if self.fail:
            raise RuntimeError("endpoint broke while opening")
        return {n: f"{n} did not answer" for n in self.names}

    def preflight(self, *, battery_floor: float) -> list[PreflightRow]:
        self.barrier.wait()
        return [PreflightRow(n, "mini", "test:") for n in self.names]

    def close(self) -> None:
        self.closed = True


def test_endpoints_open_and_check_concurrently_and_a_failure_closes_the_rest(
    perf, sched, monkeypatch
) -> None:
    made: list[_Waiting] = []
    fail: set[str] = set()
    barrier = threading.Barrier(3, timeout=5)

    def factory(schedule: Schedule, urls: Mapping[str, str]) -> Sequence[Endpoint]:
        made[:] = [_Waiting([n], barrier, n in fail) for n in urls]
        return made  # type: ignore[return-value]

    monkeypatch.setitem(launch_module._SCHEMES, "test", factory)
    schedule = sched(*(perf(n, "mini", count=2) for n in ("a", "b", "c")))
    urls = {n: "test:x" for n in ("a", "b", "c")}
    with Launch(schedule, urls, telemetry=False) as launch:
        # every endpoint's error is reported, each under its own performer
        assert launch.open() == {n: f"{n} did not answer" for n in ("a", "b", "c")}
        assert [r.performer for r in launch.preflight().rows] == ["a", "b", "c"]
    assert all(e.closed for e in made)
    fail.add("b")
    with Launch(schedule, urls, telemetry=False) as launch:
        with pytest.raises(RuntimeError, match="broke"):
            launch.open()
        assert launch.endpoints == []
    assert all(e.closed for e in made)  # the broken one too: it may have opened a part


class _Fake:
    """A test endpoint (``fake:`` URLs) that records what the launch asks of it and on which
    thread, and hands out stand-in performers."""

    def __init__(self, names: Sequence[str], log: list[tuple[str, str, object]],
                 problems: Sequence[str] = (), opened: bool = True,
                 broken: bool = False) -> None:
        self.names = tuple(names)
        self.log, self.problems, self.opened = log, list(problems), opened
        self.broken = broken

    def _say(self, what: str, arg: object = None) -> None:
        self.log.append((what, threading.current_thread().name, arg))

    def open(self) -> Mapping[str, str]:
        self._say("open")
        if self.broken:
            raise RuntimeError("endpoint broke while opening")
        return {} if self.opened else {n: f"{n} did not open" for n in self.names}

    def preflight(self, *, battery_floor: float) -> list[PreflightRow]:
        self._say("preflight", battery_floor)
        return [PreflightRow(n, "mini", "fake:", opened=self.opened, problems=self.problems)
                for n in reversed(self.names)]

    def performers(self, ctx: PerformerContext) -> dict[str, Performer]:
        self._say("performers", ctx)
        return {n: SimpleNamespace(name=n) for n in self.names}  # type: ignore[misc]

    def close(self) -> None:
        self._say("close")


@pytest.fixture
def fake(monkeypatch):  # type: ignore[no-untyped-def]
    """Registers the ``fake`` scheme: one endpoint per performer; returns the calls log."""
    log: list[tuple[str, str, object]] = []
    options: dict[str, object] = {}
    monkeypatch.setattr(launch_module, "_SCHEMES", {})

    def factory(schedule: Schedule, urls: Mapping[str, str]) -> Sequence[Endpoint]:
        return [_Fake([n], log, **options) for n in urls]  # type: ignore[arg-type, list-item]

    register_endpoint("Fake", factory)  # schemes are case-insensitive
    return SimpleNamespace(log=log, options=options)


def test_the_launch_hands_its_options_to_every_stage(perf, sched, fake) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2),
                     on_failure="halt_all")
    clock, bus = FakeClock(), EventBus()
    built: list[PerformerContext] = []

    def music(ctx: PerformerContext) -> Mapping[str, Performer]:
        built.append(ctx)
        return {"music": SimpleNamespace(name="music")}  # type: ignore[dict-item]

    launch = Launch(schedule, {"rex": "FAKE:one", "lola": "fake:two:7447"}, clock=clock,
                    events=bus, battery_floor=25.0, on_failure="continue", telemetry=False,
                    stop_timeout=0.3, progress_hz=10.0, command_lead=0.2,
                    extra_performers=[music], latency={"rex": 0.04, "lola": 0.0})
    rec = EventRecorder(bus)
    assert launch.open() == {} and launch.open_errors == {}
    report = launch.preflight(realtime="as tested")
    assert (report.battery_floor, report.realtime) == (25.0, "as tested")
    assert [r.performer for r in report.rows] == ["rex", "lola"]  # the show's order
    clock.advance(3.0)
    runner = launch.arm()
    assert rec.events[0] == PreflightDone(clock.now(), report, forced=False)
    ctx = next(arg for what, _, arg in fake.log if what == "performers")
    assert ctx == PerformerContext(clock, bus, False, 25.0, schedule.duration) and built == [ctx]
    # Each stage on named threads (two endpoints: they run at once).
    threads = {(what, where.rsplit("_", 1)[0]) for what, where, _ in fake.log}
    assert {("open", "xgo-show open"), ("preflight", "xgo-show pre-flight")} <= threads
    assert ("preflight", "", 25.0) in [(w, "", a) for w, _, a in fake.log]
    rex, lola = runner.performers["rex"], runner.performers["lola"]
    assert isinstance(rex, Early) and rex.seconds == 0.04 and rex.inner.name == "rex"
    assert not isinstance(lola, Early) and lola.name == "lola"
    assert set(runner.performers) == {"rex", "lola", "music"}
    assert (runner.clock, runner.events, runner.on_failure, runner.battery_floor) == (
        clock, bus, "continue", 25.0)
    assert (runner.progress_interval, runner.stop_timeout, runner.command_lead) == (
        pytest.approx(0.1), 0.3, 0.2)
    launch.close()
    assert launch.endpoints == []
    closes = [where for what, where, _ in fake.log if what == "close"]
    assert len(closes) == 2 and all(w.startswith("xgo-show close") for w in closes)


def test_the_launch_defaults(perf, sched, fake) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2),
                     on_failure="continue")
    launch = Launch(schedule, {"rex": "fake:1", "lola": "fake:2"})
    assert isinstance(launch.clock, MonotonicClock) and isinstance(launch.events, EventBus)
    assert (launch.battery_floor, launch.telemetry, launch.open_errors, launch.report) == (
        schedule.battery_floor, True, {}, None)
    launch.open()
    runner = launch.arm()  # no pre-flight yet: arm runs it
    assert launch.report is not None and launch.report.realtime == policy().summary
    assert launch.report.battery_floor == schedule.battery_floor
    assert (runner.on_failure, runner.stop_timeout, runner.command_lead) == ("continue", 0.1, 0.0)
    assert runner.progress_interval == pytest.approx(0.25)
    ctx = next(arg for what, _, arg in fake.log if what == "performers")
    assert ctx.telemetry is True and ctx.clock is launch.clock and ctx.events is launch.events
    floor = Launch(schedule, {"rex": "fake:1", "lola": "fake:2"}, battery_floor=0.0)
    assert floor.battery_floor == 0.0  # a floor of 0 is a floor, not "the show's"
    launch.close()


def test_arm_refuses_failed_checks_unless_forced_and_a_closed_port_always(perf, sched,
                                                                        fake) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2))
    urls = {"rex": "fake:1", "lola": "fake:2"}
    fake.options["problems"] = ["battery 5% below the floor"]
    with Launch(schedule, urls, clock=FakeClock()) as launch:
        rec = EventRecorder(launch.events)
        launch.open()
        with pytest.raises(PreflightError) as refused:
            launch.arm()
        assert str(refused.value) == ("pre-flight failed; nothing was moved (--force to start "
                                      "anyway)")
        launch.arm(force=True)
        assert [e.forced for e in rec.events if isinstance(e, PreflightDone)] == [False, True]
    fake.options["opened"] = False
    with Launch(schedule, urls, clock=FakeClock()) as launch:
        assert launch.open() == {"rex": "rex did not open", "lola": "lola did not open"}
        assert launch.open_errors == {"rex": "rex did not open", "lola": "lola did not open"}
        with pytest.raises(PreflightError) as closed:
            launch.arm(force=True)
        assert str(closed.value) == "pre-flight failed: a port did not open; nothing was moved"


def test_run_plays_the_armed_show_as_asked(perf, sched, fake) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2))
    with Launch(schedule, {"rex": "fake:1", "lola": "fake:2"}) as launch:
        with pytest.raises(XgoShowError) as early:
            launch.run()
        assert str(early.value) == "arm the launch before running it (pre-flight first)"
        launch.runner = SimpleNamespace(run=lambda **how: how)  # type: ignore[assignment]
        assert launch.run() == {"offset": 0.0, "start_at": None, "handle_signals": True}
        assert launch.run(offset=2.5, start_at=9.0, handle_signals=False) == {
            "offset": 2.5, "start_at": 9.0, "handle_signals": False}


def test_performers_map_to_urls_before_the_launch_opens_only(perf, sched, fake) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2))
    with Launch(schedule, {"rex": "fake:1"}) as launch:
        launch.map({"lola": "fake:2"})
        assert launch.urls == {"rex": "fake:1", "lola": "fake:2"}
        launch.open()
        assert [e.names for e in launch.endpoints] == [("rex",), ("lola",)]
        with pytest.raises(XgoShowError) as late:
            launch.map({"rex": "fake:3"})
        assert str(late.value) == ("the launch is already open: map performers before "
                                   "opening it")
        with pytest.raises(XgoShowError) as again:
            launch.open()
        assert str(again.value) == "the launch is already open"


def test_a_performer_without_a_url_is_local_with_none(perf, sched, fake) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2))
    endpoints = endpoints_for(schedule, {"lola": "fake:2"})
    assert isinstance(endpoints[0], LocalPorts) and endpoints[0].urls == {"rex": ""}
    assert endpoints[0].names == ("rex",) and endpoints[1].names == ("lola",)


def test_local_runner_builds_one_executor_per_transport_with_the_shows_settings(
    perf, sched
) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2),
                     on_failure="continue")
    clock = FakeClock()
    clock.advance(7.0)
    links = {n: SimTransport(create_robot(m), clock=clock.now, sleep=clock.advance)
             for n, m in (("rex", "mini"), ("lola", "lite"))}
    runner = local_runner(schedule, links, clock=clock, stop_timeout=0.4)
    assert runner.clock is clock and runner.stop_timeout == 0.4
    assert runner.battery_floor == schedule.battery_floor and runner.on_failure == "continue"
    for name, model in (("rex", "mini"), ("lola", "lite")):
        ex = runner.performers[name]
        assert isinstance(ex, PerformerExecutor) and ex.transport is links[name]
        assert ex.profile is get_profile(model) and ex.events is runner.events
        # Its own fork of virtual time, at the same instant.
        assert isinstance(ex.clock, FakeClock) and ex.clock is not clock
        assert ex.clock.now() == clock.now()
        assert ex.telemetry is not None and ex.telemetry.battery_floor == schedule.battery_floor
        assert ex.reach is not None and ex.reach(0.5) is not None
        assert ex.linger_until == schedule.duration
    quiet = local_runner(schedule, links, clock=clock, telemetry=False, battery_floor=0.0)
    assert quiet.battery_floor == 0.0
    assert all(p.telemetry is None for p in quiet.performers.values())  # type: ignore[attr-defined]
    real = local_runner(schedule, links)
    assert isinstance(real.clock, MonotonicClock)
    assert all(p.clock is real.clock for p in real.performers.values())  # type: ignore[attr-defined]
    with pytest.raises(XgoShowError, match="no port for performer"):
        local_runner(schedule, {"rex": links["rex"]}, clock=clock)


def test_local_ports_open_check_and_close_only_their_own_performers(perf, sched,
                                                                   tmp_path) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2),
                     perf("bob", "mini", count=2))
    missing = str(tmp_path / "no-such-port")
    ports = LocalPorts(schedule, {"rex": "sim:mini", "lola": missing})
    ports.close()  # nothing opened yet: nothing to close
    errors = ports.open()
    assert list(errors) == ["lola"] and list(ports.transports) == ["rex"]
    rows = {r.performer: r for r in ports.preflight(battery_floor=101.0)}
    assert list(rows) == ["rex", "lola"]  # not bob: another endpoint's
    assert rows["rex"].opened and rows["rex"].port == "sim:mini"
    assert any("101" in p for p in rows["rex"].problems)  # the floor asked for, not the show's
    assert not rows["lola"].opened and rows["lola"].port == missing
    assert any(errors["lola"] in p for p in rows["lola"].problems)
    rex = ports.transports["rex"]
    ports.close()
    ports.close()  # twice is harmless
    assert not rex.is_open and ports.transports == {}


def test_unsafe_writes_pass_only_when_allowed(perf, sched) -> None:
    from dataclasses import replace

    from xgo_show.compiler.schedule import ScheduledFrame

    good = perf("rex", "mini", count=2)
    zero = write_frame(get_profile("mini").register("servo_zero").address, b"\x01")
    bad = sched(replace(good, frames=(*good.frames, ScheduledFrame(0.5, zero))))
    link = {"rex": SimTransport(create_robot("mini"))}
    with pytest.raises(UnsafeScheduleError, match="servo_zero"):
        local_runner(bad, link)
    assert local_runner(bad, link, allow_unsafe=True).performers["rex"] is not None
    allowed = Launch(bad, {"rex": "/dev/null-never-opened"}, allow_unsafe=True)
    assert [w for w in allowed.unsafe] != []


def test_local_runner_uses_the_bus_given_and_watches_until_the_show_ends(perf, sched) -> None:
    schedule = sched(perf("rex", "mini", count=2, end=1.0), perf("lola", "lite", end=3.0))
    bus, clock = EventBus(), FakeClock()
    links = {"rex": SimTransport(create_robot("mini")), "lola": SimTransport(create_robot("lite"))}
    runner = local_runner(schedule, links, clock=clock, events=bus)
    rex = runner.performers["rex"]
    assert runner.events is bus and rex.events is bus  # type: ignore[attr-defined]
    # rex's part ends at 1 s; its telemetry is watched until the show's end at 3 s.
    assert rex.linger_until == schedule.duration == 3.0  # type: ignore[attr-defined]


def test_a_failed_open_closes_every_endpoint_on_named_threads(perf, sched, fake) -> None:
    schedule = sched(perf("rex", "mini", count=2), perf("lola", "lite", count=2))
    fake.options["broken"] = True
    with Launch(schedule, {"rex": "fake:1", "lola": "fake:2"}) as launch, pytest.raises(
        RuntimeError, match="broke"
    ):
        launch.open()
    closes = [where for what, where, _ in fake.log if what == "close"]
    assert len(closes) == 2 and all(w.startswith("xgo-show close") for w in closes)
