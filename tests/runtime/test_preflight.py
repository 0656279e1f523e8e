"""Pre-flight checks against simulators on real ptys: nothing moves before they pass."""

from __future__ import annotations

import io

import pytest

from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.preflight import countdown, open_ports, preflight
from xgo_show.wire.xgo import TYPE_READ


def test_all_robots_pass_and_the_table_says_so(rig, perf, sched) -> None:
    schedule = sched(perf("rex", "mini"), perf("rita", "rider"))
    rig.for_schedule(schedule)
    report = preflight(schedule, rig.transports)
    assert report.ok
    table = report.table()
    assert "rex" in table and "M-1.4.1" in table and "100%" in table
    assert table.splitlines()[1].endswith("ok")


def test_wrong_model_and_low_battery_fail_with_reads_only(rig, perf, sched) -> None:
    schedule = sched(perf("rex", "mini"), perf("rita", "rider"))
    rig.add("rex", "mini", firmware="L-1.3.2")  # a Lite's firmware on the Mini's port
    rig.add("rita", "rider", battery=15)
    report = preflight(schedule, rig.transports, battery_floor=25)
    assert not report.ok and report.ports_ok
    rex, rita = report.rows
    assert rex.detected == "lite" and "not mini" in rex.problems[0]
    assert rita.battery == 15 and "below the floor of 25%" in rita.problems[0]
    assert "FAIL" in report.table()
    for server in rig.servers.values():
        assert all(f.data[3] == TYPE_READ for f in server.robot.received)


def test_a_port_that_does_not_open_is_named(perf, sched, tmp_path) -> None:
    schedule = sched(perf("rex", "mini"))
    missing = str(tmp_path / "ttyUSB9")
    transports, errors = open_ports(schedule, {"rex": missing})
    assert transports == {}
    assert missing in errors["rex"]
    report = preflight(schedule, transports, urls={"rex": missing}, open_errors=errors)
    assert not report.ports_ok
    assert missing in report.table()
    _, errors = open_ports(schedule, {})
    assert "no port given" in errors["rex"]


def test_xarm_is_recognised_by_its_answer(rig, sched) -> None:
    from xgo_show.compiler.schedule import PerformerSchedule
    from xgo_show.profiles import get_profile

    xarm = get_profile("xarm")
    schedule = sched(PerformerSchedule("arm", "xarm", xarm.link, (), end=1.0))
    rig.for_schedule(schedule)
    report = preflight(schedule, rig.transports)
    assert report.ok, report.table()
    assert report.rows[0].voltage == pytest.approx(7.6)
    assert "7.60 V" in report.table().splitlines()[1]
    assert "xArm: 6.48 V = 20% of 6.00..8.40 V" in report.table()


def test_xarm_below_the_mapped_floor_fails(rig, sched) -> None:
    from xgo_show.compiler.schedule import PerformerSchedule
    from xgo_show.profiles import get_profile

    xarm = get_profile("xarm")
    schedule = sched(PerformerSchedule("arm", "xarm", xarm.link, (), end=1.0))
    rig.add("arm", "xarm", battery_mv=6400)
    report = preflight(schedule, rig.transports)  # the show's floor: 20% -> 6.48 V
    assert not report.ok and report.ports_ok
    assert report.rows[0].problems == [
        "battery 6.40 V is below the floor of 6.48 V = 20% of 6.00..8.40 V"
    ]
    assert preflight(schedule, rig.transports, battery_floor=10).ok  # 6.24 V
    assert not preflight(schedule, rig.transports, battery_floor=50).ok  # 7.20 V
    assert rig.servers["arm"].snapshot()["moves"] == []  # reads only


def test_countdown_counts_whole_seconds_from_one_start() -> None:
    out = io.StringIO()
    clock = FakeClock()
    start = clock.now()
    countdown(2.5, out=out, clock=clock)
    assert out.getvalue().splitlines() == [
        "starting in 2.5 s",
        "starting in 1.5 s",
        "starting in 0.5 s",
    ]
    assert clock.now() == start + 2.5
    countdown(0, out=out, clock=clock)
    assert clock.now() == start + 2.5
