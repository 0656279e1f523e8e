"""Pre-flight checks against simulators on real ptys: nothing moves before they pass."""

from __future__ import annotations

import io
import time

import pytest

from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.preflight import (
    PreflightReport,
    PreflightRow,
    countdown,
    open_ports,
    preflight,
)
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


def _rows() -> list[PreflightRow]:
    return [
        PreflightRow("rex", "mini", "/dev/ttyUSB0", opened=True, firmware="M-1.4.1",
                     detected="mini", battery=87.4, low_latency=True),
        PreflightRow("rita", "rider", "sim:rider", opened=True, firmware="L-1.3.2",
                     detected="lite", problems=["not rider", "no battery"], notes=["forced"]),
        PreflightRow("arm", "xarm", "sim:xarm", opened=True, voltage=7.6, battery=66.7),
        PreflightRow("spot", "lite", "-", problems=["port not open"]),
    ]  # fmt: skip


def test_the_table_one_line_a_performer_then_the_floor_and_a_legend() -> None:
    report = PreflightReport(_rows(), 25.0, realtime="SCHED_FIFO 80")
    assert report.table().splitlines() == [
        "performer  model  port          firmware        battery  latency  result",
        "rex        mini   /dev/ttyUSB0  M-1.4.1         87%      low      ok",
        "rita       rider  sim:rider     L-1.3.2 (lite)  -        default  FAIL: not rider; no "
        "battery (forced)",
        "arm        xarm   sim:xarm      -               7.60 V   default  ok",
        "spot       lite   -             -               -        default  FAIL: port not open",
        "battery floor 25% (xArm: 6.60 V = 25% of 6.00..8.40 V); real-time scheduling: "
        "SCHED_FIFO 80",
        "(firmware: as reported, with the model it implies if another; battery: charge, an "
        "xArm's supply in V;",
        " latency: the serial adapter's low-latency mode; result: ok, or every check that "
        "failed)",
    ]
    dogs = PreflightReport(_rows()[:1], 20.0)
    assert dogs.table().splitlines()[2] == (
        "battery floor 20%; real-time scheduling: not requested")  # no xArm: no note


def test_a_report_passes_when_every_port_opened_and_no_check_failed() -> None:
    rows = _rows()
    report = PreflightReport(rows, 25.0)
    assert [r.ok for r in rows] == [True, False, True, False]
    assert not report.ok and not report.ports_ok
    assert PreflightReport([rows[0], rows[2]], 25.0).ok
    opened = PreflightReport(rows[:3], 25.0)
    assert opened.ports_ok and not opened.ok
    assert not PreflightRow("x", "mini", "-").ok  # not opened, even with no problem listed
    assert PreflightReport([], 20.0).ok


def test_the_report_as_plain_data() -> None:
    record = PreflightReport(_rows()[:3], 25.0, realtime="SCHED_FIFO 80").as_record()
    assert record == {
        "ok": False,
        "realtime": "SCHED_FIFO 80",
        "rows": [
            {"performer": "rex", "port": "/dev/ttyUSB0", "firmware": "M-1.4.1",
             "battery": 87.4, "voltage": None, "low_latency": True, "problems": []},
            {"performer": "rita", "port": "sim:rider", "firmware": "L-1.3.2", "battery": None,
             "voltage": None, "low_latency": False, "problems": ["not rider", "no battery"]},
            {"performer": "arm", "port": "sim:xarm", "firmware": "", "battery": 66.7,
             "voltage": 7.6, "low_latency": False, "problems": []},
        ],
    }  # fmt: skip


def test_low_latency_is_asked_for_unless_turned_off(rig, perf, sched) -> None:
    schedule = sched(perf("rex", "mini"))
    rig.for_schedule(schedule)
    asked = preflight(schedule, rig.transports)
    # A pty has no low-latency mode: asked for, not granted; not asked for, not tried.
    assert asked.rows[0].low_latency is False
    calls: list[bool] = []
    transport = rig.transports["rex"]
    original = transport.set_low_latency
    transport.set_low_latency = lambda: calls.append(True) or True  # type: ignore[method-assign]
    try:
        granted = preflight(schedule, rig.transports)
        assert calls == [True] and granted.rows[0].low_latency
        skipped = preflight(schedule, rig.transports, low_latency=False)
        assert calls == [True] and not skipped.rows[0].low_latency
    finally:
        transport.set_low_latency = original  # type: ignore[method-assign]
    assert asked.battery_floor == 20.0 and preflight(
        schedule, rig.transports, battery_floor=5).battery_floor == 5
    named = preflight(schedule, rig.transports, urls={"rex": "/dev/ttyACM0"})
    assert named.rows[0].port == "/dev/ttyACM0"


def test_a_performer_without_a_transport_is_not_opened_and_says_why(perf, sched) -> None:
    schedule = sched(perf("rex", "mini"), perf("rita", "rider"))
    report = preflight(schedule, {}, open_errors={"rex": "busy"})
    assert [(r.opened, r.problems) for r in report.rows] == [
        (False, ["busy"]), (False, ["port not open"])]  # fmt: skip


class _Port:
    """A transport that only records being opened and closed."""

    def __init__(self, log: list[str], url: str) -> None:
        self.log, self.url = log, url

    def open(self) -> None:
        self.log.append(f"open {self.url}")

    def close(self) -> None:
        self.log.append(f"close {self.url}")


def test_ports_open_at_their_links_baud_rate(perf, sched) -> None:
    from xgo_show.compiler.schedule import PerformerSchedule
    from xgo_show.profiles import get_profile

    xarm = get_profile("xarm")
    schedule = sched(perf("rex", "mini"), PerformerSchedule("arm", "xarm", xarm.link, (), 1.0))
    asked: dict[str, object] = {}
    log: list[str] = []

    def opener(url: str, **kw: object) -> _Port:
        asked[url] = kw
        return _Port(log, url)

    transports, errors = open_ports(schedule, {"rex": "a", "arm": "b"}, opener=opener)
    assert errors == {} and sorted(transports) == ["arm", "rex"]
    assert asked == {"a": {"baudrate": 115200}, "b": {"baudrate": 9600}}
    assert sorted(log) == ["open a", "open b"]
    _, errors = open_ports(schedule, {"rex": "a"}, opener=opener)
    assert errors == {"arm": "no port given (map it with --map NAME=PORT or in the show file)"}


def test_a_port_failing_unexpectedly_closes_the_ports_that_opened(perf, sched) -> None:
    schedule = sched(perf("rex", "mini"), perf("rita", "rider"))
    log: list[str] = []

    def opener(url: str, **kw: object) -> _Port:
        if url == "bad":
            time.sleep(0.05)  # the other port is open by then
            raise RuntimeError("driver bug")
        return _Port(log, url)

    with pytest.raises(RuntimeError, match="driver bug"):
        open_ports(schedule, {"rex": "good", "rita": "bad"}, opener=opener)
    assert log == ["open good", "close good"]


def test_a_row_without_a_port_says_dash(perf, sched) -> None:
    schedule = sched(perf("rex", "mini"))
    (row,) = preflight(schedule, {}).rows
    assert row.port == (schedule.performers[0].port or "-")
    report = PreflightReport([PreflightRow("a", "xarm", "-", opened=True,
                                           notes=["forced", "firmware unread"])], 20.0)
    assert report.table().splitlines()[1].endswith("ok (forced; firmware unread)")


class _Flushes(io.StringIO):
    def __init__(self) -> None:
        super().__init__()
        self.flushes = 0

    def flush(self) -> None:
        self.flushes += 1
        super().flush()


def test_a_countdown_of_one_second_and_each_line_shown_at_once() -> None:
    out = _Flushes()
    clock = FakeClock()
    start = clock.now()
    countdown(1, out=out, clock=clock)
    assert out.getvalue() == "starting in 1 s\n" and clock.now() == start + 1
    assert out.flushes >= 1  # shown when printed, not when the show starts
    countdown(-1, out=out, clock=clock)
    assert out.getvalue() == "starting in 1 s\n"


def test_a_robot_that_does_not_answer_is_given_half_a_second(perf, sched) -> None:
    from xgo_show.sim import create_robot
    from xgo_show.transports.sim import SimTransport

    class Deaf(SimTransport):
        """A port whose robot never hears the request (a dead or unpowered robot)."""

        def write(self, data: bytes) -> None:
            pass

    schedule = sched(perf("rex", "mini"))
    link = Deaf(create_robot("mini"))
    link.open()
    began = time.monotonic()
    report = preflight(schedule, {"rex": link}, low_latency=False)
    took = time.monotonic() - began
    assert not report.ok and report.ports_ok
    # Half a second for its answer (waited for in full), then it is a problem.
    assert report.rows[0].problems == [
        "no reply from sim:mini to a read of firmware (0x07) within 0.5 s"]
    assert took >= 0.45
