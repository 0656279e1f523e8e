"""The launch stages against simulators on real pseudo-terminals: open, pre-flight, arm, run."""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence

import pytest

from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import XgoShowError
from xgo_show.runtime import launch as launch_module
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import EventRecorder, PreflightDone, ShowEnded, ShowStarted
from xgo_show.runtime.launch import Endpoint, Launch, LocalPorts
from xgo_show.runtime.preflight import PreflightError, PreflightRow
from xgo_show.runtime.safety import UnsafeScheduleError
from xgo_show.sim import PtyServer, create_robot
from xgo_show.sim.bench import SimBench
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
