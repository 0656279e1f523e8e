"""The families' run-time hooks in-process: telemetry items and replies, the reset posture's
registers, pre-flight rows and their problems, the xArm's stop frame and unsafe commands."""

from __future__ import annotations

import struct
from dataclasses import replace

import pytest

from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.families import get_family
from xgo_show.families.values import StopFrame, TelemetryItem
from xgo_show.families.xgo.posture import RESET_ACTION, posture_after
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Access, Profile
from xgo_show.runtime.preflight import PreflightRow, preflight
from xgo_show.sim import create_robot
from xgo_show.transports.sim import SimTransport
from xgo_show.wire import xarm as xarm_wire
from xgo_show.wire.xgo import XgoDecoder, read_frame, reply_frame, write_frame


def _with(profile: Profile, name: str, **changes: object) -> Profile:
    """``profile`` with register ``name`` changed (or dropped, with ``drop=True``)."""
    drop = changes.pop("drop", False)
    regs = tuple(r if r.name != name else replace(r, **changes) for r in profile.registers
                 if not (drop and r.name == name))
    return replace(profile, registers=regs)


def _items(profile: Profile) -> list[str]:
    return [i.name for i in get_family(profile).telemetry_items(profile)]


def test_xgo_telemetry_reads_only_what_the_model_has_readable_and_adjacent() -> None:
    mini = get_profile("mini")
    assert _items(mini) == ["battery", "status", "attitude"]
    assert _items(_with(mini, "battery", drop=True)) == ["status", "attitude"]
    assert _items(_with(mini, "status", access=Access.WRITE)) == ["battery", "attitude"]
    pitch = mini.register("imu_pitch")
    apart = _with(mini, "imu_pitch", address=pitch.address + 0x10)  # no longer after roll
    assert _items(apart) == ["battery", "status"]
    attitude = get_family(mini).telemetry_items(mini)[2]
    roll = mini.register("imu_roll")
    assert attitude == TelemetryItem("attitude", roll.address, (roll, pitch),
                                     read_frame(roll.address, 8))


def test_xgo_telemetry_values_read_each_field_of_a_reply_in_turn() -> None:
    rider = get_profile("rider")
    family = get_family(rider)
    items = {i.address: i for i in family.telemetry_items(rider)}
    roll = rider.register("imu_roll").address
    [frame] = XgoDecoder().feed(reply_frame(roll, struct.pack("<ff", 3.5, -2.0)))
    assert family.telemetry_values(items, frame) == [("imu_roll", 3.5),
                                                            ("imu_pitch", -2.0)]
    status = rider.register("status").address
    [named] = XgoDecoder().feed(reply_frame(status, b"\x01"))
    assert family.telemetry_values(items, named) == [("status", 1.0)]


def test_the_reset_posture_holds_only_ranged_registers_with_an_initial_value() -> None:
    mini = get_profile("mini")
    odd = _with(mini, "body_x", initial=None)
    assert "body_x" in posture_after(mini, RESET_ACTION)
    assert "body_x" not in posture_after(odd, RESET_ACTION)
    enum_posture = replace(mini, default_posture=("status", *mini.default_posture))
    assert list(posture_after(enum_posture, RESET_ACTION)) == list(mini.default_posture)


def _schedule(model: str) -> Schedule:
    """One performer ``rex`` of ``model`` with nothing to send: pre-flight reads only."""
    profile = get_profile(model)
    return Schedule("test", "show.yaml",
                    (PerformerSchedule("rex", model, profile.link, (), end=1.0),), 1.0)


def _sim(model: str, **options: object) -> SimTransport:
    link = SimTransport(create_robot(model, **options))
    link.open()
    return link


def test_xgo_preflight_names_an_unknown_firmware_and_a_battery_below_the_floor() -> None:
    schedule = _schedule("mini")
    report = preflight(schedule, {"rex": _sim("mini", firmware="Z-9.9.9", battery=24)},
                       battery_floor=25, low_latency=False)
    assert report.rows[0].problems == [
        "firmware 'Z-9.9.9' is an unknown model, not mini",
        "battery 24% is below the floor of 25%",
    ]
    at_floor = preflight(schedule, {"rex": _sim("mini", battery=25)}, battery_floor=25,
                         low_latency=False)
    assert at_floor.ok  # the floor itself is enough


class Deaf(SimTransport):
    """A port whose robot never hears the request."""

    def write(self, data: bytes) -> None:
        pass


@pytest.mark.parametrize("model", ["mini", "xarm"])
def test_preflight_gives_a_silent_robot_the_time_it_is_told(model: str) -> None:
    schedule = _schedule(model)
    link = Deaf(create_robot(model))
    link.open()
    report = preflight(schedule, {"rex": link}, timeout=0.2, low_latency=False)
    [problem] = report.rows[0].problems
    assert problem.startswith("no reply from sim:") and problem.endswith("within 0.2 s")


def test_xarm_preflight_fills_its_row_and_judges_the_voltage_at_the_floor() -> None:
    from xgo_show.families.xarm.runtime import floor_text
    from xgo_show.profiles.xarm import battery_floor_mv, battery_percent

    xarm = get_profile("xarm")
    family = get_family(xarm)
    floor_mv = int(battery_floor_mv(20))
    row = PreflightRow("arm", "xarm", "sim:xarm")
    family.preflight(row, _sim("xarm", battery_mv=floor_mv), xarm, 20, 0.5)
    assert (row.firmware, row.detected, row.voltage, row.battery, row.problems) == (
        "xArm controller", "xarm", floor_mv / 1000, battery_percent(floor_mv), [])
    low = PreflightRow("arm", "xarm", "sim:xarm")
    family.preflight(low, _sim("xarm", battery_mv=floor_mv - 1), xarm, 20, 0.5)
    assert low.problems == [f"battery {(floor_mv - 1) / 1000:.2f} V is below the floor of "
                            f"{floor_text(20)}"]


def test_the_xarm_stop_is_one_labelled_group_stop_and_its_one_telemetry_item() -> None:
    xarm = get_profile("xarm")
    family = get_family(xarm)
    assert family.stop_frames(xarm) == [StopFrame(xarm_wire.group_stop(), "GroupStop")]
    assert family.telemetry_items(xarm) == (TelemetryItem(
        "battery_v", int(xarm_wire.XarmCommand.GET_BATTERY_VOLTAGE), (),
        xarm_wire.get_battery_voltage(), reply_bytes=6),)


def test_xarm_unsafe_problems_name_the_command_or_the_bad_packet() -> None:
    xarm = get_profile("xarm")
    family = get_family(xarm)
    assert family.unsafe_problems(xarm, xarm_wire.servo_move(20, {1: 500})) == []
    off = xarm_wire.encode_packet(20, b"\x01\x01")
    assert family.unsafe_problems(xarm, off) == [
        "sends unsafe command ServoOff (20: ServoOff: unpowers servos, the arm drops)"]
    [bad] = family.unsafe_problems(xarm, b"\x55\x55\x02")
    assert bad.startswith("unknown packet: ")


def test_xgo_frame_problems_and_labels() -> None:
    mini = get_profile("mini")
    family = get_family(mini)
    frame = write_frame(mini.register("vx").address, b"\x80")
    assert family.frame_problem(frame) is None
    assert family.frame_problem(frame[:-1]) == "not one valid XGO frame (bad length or checksum)"
    assert "vx" in family.frame_labels(mini)(frame)


def _probe(robot: str, given: str | None, *, firmware: str | None = None,
           table: str = "mini") -> dict[str, str]:
    from xgo_show.client import XgoClient

    options = {} if firmware is None else {"firmware": firmware}
    client = XgoClient(_sim(robot, **options), get_profile(table), timeout=0.5)
    return dict(get_family(get_profile(table)).probe(client, given=given))


def test_probe_says_where_the_model_it_names_came_from() -> None:
    assert _probe("mini", None) == {"port": "sim:mini", "model": "mini (from firmware)",
                                    "firmware": "M-1.4.1", "battery": "100 %",
                                    "status": _probe("mini", "mini")["status"]}
    assert _probe("mini", None, firmware="Z-9.9.9")["model"] == "mini (from the URL)"
    assert _probe("lite", None)["model"] == "mini (from the URL)"  # the firmware says lite
    assert _probe("mini", "mini")["model"] == "mini"
    assert _probe("mini", "mini", firmware="Z-9.9.9")["model"] == "mini"  # nothing to contradict
    named = _probe("lite", "mini")
    assert named["model"] == "mini (given; the firmware names a lite)"
    assert named["battery"] == "100 %"


def test_xarm_telemetry_reads_volts_from_battery_replies_only() -> None:
    xarm = get_profile("xarm")
    family = get_family(xarm)
    items = {i.address: i for i in family.telemetry_items(xarm)}

    def values(data: bytes) -> list[tuple[str, float]] | None:
        _, packet = xarm_wire.decode_one(data)
        assert packet is not None
        return family.telemetry_values(items, packet)

    assert values(xarm_wire.battery_reply(7600)) == [("battery_v", pytest.approx(7.6))]
    assert values(xarm_wire.get_battery_voltage()) is None  # the request, not a reply
    assert values(xarm_wire.positions_reply({1: 500})) is None


def test_xarm_battery_low_judges_volts_against_the_mapped_floor() -> None:
    from xgo_show.profiles.xarm import battery_floor_mv

    family = get_family("xarm")
    floor_v = battery_floor_mv(20) / 1000.0
    text = (f"battery {floor_v:.2f} V is below the floor of {floor_v:.2f} V "
            "(20% of the xArm's range)")
    assert family.battery_low("battery_v", floor_v, 20) == (False, text)
    assert family.battery_low("battery_v", floor_v - 0.01, 20)[0] is True  # type: ignore[index]
    assert family.battery_low("battery", 1.0, 20) is None


def test_xarm_probe_rows_name_the_port_model_battery_and_servos() -> None:
    from xgo_show.client import XarmClient

    xarm = get_profile("xarm")
    client = XarmClient(_sim("xarm"), xarm, timeout=0.5)
    rows = get_family(xarm).probe(client, given=None)
    assert rows[:3] == [("port", "sim:xarm"), ("model", "xarm (from the URL)"),
                        ("battery", "7.60 V")]
    assert [label for label, _ in rows[3:]] == [f"servo {s}" for s in xarm.xarm_servos]
    assert dict(get_family(xarm).probe(client, given="xarm"))["model"] == "xarm"


def test_probe_reading_with_the_robots_own_table_keeps_the_timeout_given() -> None:
    from xgo_show.client import XgoClient
    from xgo_show.errors import XgoShowError

    class AnswersOnce(SimTransport):
        """A robot that answers the firmware read, then goes silent."""

        heard = 0

        def write(self, data: bytes) -> None:
            self.heard += 1
            if self.heard == 1:
                super().write(data)

    link = AnswersOnce(create_robot("lite"))
    link.open()
    client = XgoClient(link, get_profile("mini"), timeout=0.2)
    with pytest.raises(XgoShowError, match=r"within 0\.2 s"):
        get_family(get_profile("mini")).probe(client, given="mini")


@pytest.mark.parametrize("model", ["mini", "xarm"])
def test_each_family_hook_answers_for_the_profile_and_arguments_it_is_given(model: str) -> None:
    """The families hand each hook's arguments on to the module that implements it: the
    answers are those modules' answers for the same profile, frames and times."""
    from xgo_show.compiler import state as state_module
    from xgo_show.compiler import timeline as timeline_module
    from xgo_show.compiler import xarm as xarm_compiler
    from xgo_show.compiler.schedule import ScheduledFrame

    profile = get_profile(model)
    family = get_family(profile)
    if model == "xarm":
        data = [xarm_wire.servo_move(20, {1: 300}), xarm_wire.servo_move(20, {1: 600, 2: 400})]
    else:
        data = [write_frame(profile.register("vx").address, b"\x90"),
                write_frame(profile.register("body_z").address, b"\x70")]
    frames = [ScheduledFrame(0.1, data[0]), ScheduledFrame(0.5, data[1])]
    performer = PerformerSchedule("p", model, profile.link, tuple(frames), end=1.0)
    at_03 = family.state_at(profile, frames, 0.3)
    at_06 = family.state_at(profile, frames, 0.6)
    assert at_03 and at_06 != at_03
    if model == "xarm":
        assert at_06 == xarm_compiler.xarm_state_at(frames, 0.6)
        assert family.describe_frame(profile, data[1]) == xarm_compiler.describe_xarm_frame(
            data[1])
        slow = family.frames_to_reach(profile, at_06, move_time=2.0)
        assert [f.data for f in slow] == [f.data for f in xarm_compiler.xarm_frames_to_reach(
            profile, at_06, move_time=2.0)]
        assert slow != family.frames_to_reach(profile, at_06, move_time=0.5)
        timeline = timeline_module.xarm_timeline(profile, performer, 1.0)
        assert family.refuse_cue("gripper", profile) == (
            "on the xArm the gripper is servo 1: use pose: {1: POSITION}")
        assert family.after_action(profile, 255) == {}
        assert family.simulate_options(seed=3, battery=None) == {}
        assert family.frame_labels(profile)(data[0]) == state_module.frame_label(profile, data[0])
    else:
        assert at_06 == state_module.xgo_state_at(profile, frames, 0.6)
        assert family.describe_frame(profile, data[1]) == state_module.describe_xgo_frame(
            profile, data[1])
        assert [f.data for f in family.frames_to_reach(profile, at_06, move_time=1.0)] == [
            f.data for f in state_module.xgo_frames_to_reach(profile, at_06)]
        timeline = timeline_module.xgo_timeline(profile, performer, 1.0)
        assert family.refuse_cue("pose", profile) == (
            f"pose is for the xArm; the {profile.title} moves with move: (registers) "
            "or arm: / gripper:")
        assert family.refuse_cue("move", profile) is None
        assert family.after_action(profile, RESET_ACTION) == posture_after(profile, RESET_ACTION)
        assert family.simulate_options(seed=3, battery=40.0) == {"seed": 3, "battery": 40.0}
        assert family.simulate_options(seed=4, battery=None) == {"seed": 4}
    assert family.timeline(profile, performer, 1.0) == timeline
    client = family.client(_sim(model), profile, timeout=0.25)
    assert client.profile is profile and client.timeout == 0.25


def test_the_xarm_simulator_refuses_a_battery_percentage_and_says_why() -> None:
    from xgo_show.errors import UsageError

    with pytest.raises(UsageError) as refused:
        get_family("xarm").simulate_options(seed=1, battery=50.0)
    assert str(refused.value) == ("--battery is a percentage for XGO robots; the xArm reports "
                                  "millivolts (its simulator starts at 7600 mV)")


def test_the_xgo_plan_and_its_remerge_are_the_planners_and_mergers_for_that_link() -> None:
    from xgo_show.choreo.resolved import ActionCue, MotionCue, ResolvedTrack
    from xgo_show.compiler.frames import Write
    from xgo_show.compiler.layout import ACTION_REGISTER
    from xgo_show.compiler.merge import merge_writes
    from xgo_show.compiler.planner import plan_xgo_track
    from xgo_show.compiler.state import layout_of
    from xgo_show.diagnostics import Origin

    mini = get_profile("mini")
    track = ResolvedTrack("p", "mini", (
        MotionCue(0.0, Origin("show.yaml", 1, 1, "lean"), {"roll": 10.0, "body_z": 90.0}, 1.0),
        ActionCue(1.5, Origin("show.yaml", 2, 1, "wave"), 19, "wave", 1.0),
    ))
    layout = layout_of(mini)
    for rate, gap, details in ((50.0, 0.003, True), (20.0, 0.001, False)):
        plan, remerge = get_family(mini).plan_track(mini, track, rate=rate, link=mini.link,
                                                    gap=gap, details=details)
        want = plan_xgo_track(layout, track, rate=rate, link=mini.link, gap=gap, details=details)
        assert plan.frames == want.frames and plan.samples == want.samples
        assert remerge is not None
        action = layout.by_name[ACTION_REGISTER]
        writes = [Write(action.address, b"\x13", None, 0, False, 1.0),
                  Write(mini.register("vx").address, b"\x90", None, 1, False),
                  Write(mini.register("vy").address, b"\x70", None, 2, False)]
        assert remerge(2_000, writes) == merge_writes(layout, mini.link, gap, 2_000, writes, {},
                                                       action_address=action.address)
        assert remerge(2_000, writes) != merge_writes(layout, mini.link, gap, 2_000, writes, {},
                                                       action_address=None)


def test_the_xarm_plan_is_the_arm_planners_for_that_profile_and_track() -> None:
    from xgo_show.choreo.resolved import ArmCue, ResolvedTrack
    from xgo_show.compiler.xarm import plan_xarm_track
    from xgo_show.diagnostics import Origin

    xarm = get_profile("xarm")
    track = ResolvedTrack("arm", "xarm", (
        ArmCue(0.0, Origin("show.yaml", 1, 1, "reach"), {1: 300, 2: 700}, 0.5),
        ArmCue(1.0, Origin("show.yaml", 2, 1, "far"), {9: 500}, 0.5),  # no such servo
    ))
    plan, remerge = get_family(xarm).plan_track(xarm, track, rate=50.0, link=xarm.link,
                                                gap=0.001, details=False)
    want = plan_xarm_track(xarm, track)
    assert remerge is None
    assert plan.frames == want.frames and len(plan.frames) == 1
    assert [d.message for d in plan.diagnostics] == [d.message for d in want.diagnostics]
    assert len(plan.diagnostics) == 1
