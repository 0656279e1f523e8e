"""Safe stops cost as little wire time as the register layout allows; unsafe frames are refused.

A stop is sent when something already went wrong, so its length on the wire is part of its
safety: the tests state how many frames (and bytes) each model's stop takes, not only what it
decodes to.
"""

from __future__ import annotations

import pytest

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.profiles import MODELS, get_profile
from xgo_show.profiles.model import Profile
from xgo_show.runtime.safety import UnsafeScheduleError, check_unsafe, rest_frames, stop_frames
from xgo_show.wire.xgo import XgoDecoder, read_frame, write_frame


def _runs(addresses: list[int]) -> int:
    """How many runs of consecutive addresses ``addresses`` (sorted) fall into."""
    return sum(1 for i, a in enumerate(addresses) if i == 0 or a != addresses[i - 1] + 1)


@pytest.mark.parametrize("model", MODELS)
def test_rest_frames_are_one_frame_per_run_of_adjacent_registers(model: str) -> None:
    profile = get_profile(model)
    frames = [f for sf in rest_frames(profile) for f in XgoDecoder().feed(sf.data)]
    addresses = sorted(profile.register(name).address for name, _ in profile.safe_stop)
    # As few frames as the layout allows: adjacent registers always share a frame ...
    assert len(frames) == _runs(addresses)
    # ... and every rest register is written exactly once, with its neutral value.
    written = {}
    for frame in frames:
        for offset, byte in enumerate(frame.data):
            assert frame.address + offset not in written
            written[frame.address + offset] = byte
    neutral = {profile.register(name).address:
               profile.register(name).encode_value(value)[0] for name, value in profile.safe_stop}
    assert written == neutral


# Frames and bytes each shipped model's full stop puts on the wire (rest + posture reset, or
# the xArm's GroupStop): a Mini's 10 rest registers lie in 3 runs, the Rider's 4 in 4.
STOP_COST = {"mini": (4, 43), "lite": (4, 43), "rider": (5, 45), "xarm": (1, 4)}


@pytest.mark.parametrize("model", MODELS)
def test_the_full_stop_of_each_model_costs_what_it_should_on_the_wire(model: str) -> None:
    frames = stop_frames(get_profile(model))
    assert (len(frames), sum(len(f.data) for f in frames)) == STOP_COST[model]
    # The rest frames come first, then the one frame that takes the posture back.
    rest = rest_frames(get_profile(model))
    assert [f.data for f in frames[: len(rest)]] == [f.data for f in rest]


def _schedule(profile: Profile, *frames: bytes) -> Schedule:
    scheduled = tuple(ScheduledFrame(0.1 * i, data) for i, data in enumerate(frames))
    perf = PerformerSchedule("rex", profile.model, profile.link, scheduled, end=1.0)
    return Schedule("t", "show.yaml", (perf,), 50.0)


def test_unsafe_frames_are_refused_unless_explicitly_allowed() -> None:
    mini = get_profile("mini")
    unsafe = write_frame(mini.register("servo_zero").address, b"\x01")
    schedule = _schedule(mini, write_frame(mini.register("body_z").address, b"\x80"), unsafe)
    with pytest.raises(UnsafeScheduleError, match=r"rex frame 1 at 0\.100s: writes unsafe "
                                                  r"register servo_zero; pass --allow-unsafe"):
        check_unsafe(schedule, {"rex": mini})  # the default refuses
    assert check_unsafe(schedule, {"rex": mini}, allow_unsafe=True) == [
        "rex frame 1 at 0.100s: writes unsafe register servo_zero"]


@pytest.mark.parametrize("count", [3, 4, 5])
def test_the_refusal_names_three_unsafe_frames_and_counts_the_rest(count: int) -> None:
    mini = get_profile("mini")
    unsafe = write_frame(mini.register("calibration").address, b"\x01")
    with pytest.raises(UnsafeScheduleError) as err:
        check_unsafe(_schedule(mini, *[unsafe] * count), {"rex": mini})
    named = "; ".join(f"rex frame {i} at 0.{i}00s: writes unsafe register calibration"
                      for i in range(3))
    more = f" (and {count - 3} more)" if count > 3 else ""
    assert str(err.value) == f"refusing to run: {named}{more}; pass --allow-unsafe to override"


def test_an_unsafe_frame_is_named_with_the_cue_it_came_from() -> None:
    from xgo_show.diagnostics import Origin

    mini = get_profile("mini")
    frame = ScheduledFrame(0.25, write_frame(mini.register("servo_zero").address, b"\x01"),
                           Origin("show.yaml", 12, 5, "rex: set servo_zero"))
    perf = PerformerSchedule("rex", "mini", mini.link, (frame,), end=1.0)
    found = check_unsafe(Schedule("t", "show.yaml", (perf,), 50.0), {"rex": mini},
                         allow_unsafe=True)
    assert found == [f"rex frame 0 at 0.250s ({frame.origin}): writes unsafe register servo_zero"]


def test_a_write_the_profile_cannot_lay_out_is_refused_as_unknown() -> None:
    mini = get_profile("mini")
    known = {r.address for r in mini.registers}
    nowhere = next(a for a in range(0x100) if a not in known)
    body_z = mini.register("body_z").address
    schedule = _schedule(mini, write_frame(nowhere, b"\x00"),
                         write_frame(body_z, b"\x80" * 40))  # runs past the table's end
    found = check_unsafe(schedule, {"rex": mini}, allow_unsafe=True)
    assert len(found) == 2 and all(": unknown write: " in f for f in found)
    assert f"has no register at 0x{nowhere:02X}" in found[0]
    with pytest.raises(UnsafeScheduleError, match="unknown write"):
        check_unsafe(schedule, {"rex": mini})


def test_reading_an_unsafe_register_is_not_a_write() -> None:
    mini = get_profile("mini")
    read = read_frame(mini.register("servo_zero").address, 1)
    assert check_unsafe(_schedule(mini, read), {"rex": mini}) == []


def test_a_clean_schedule_passes_with_the_default() -> None:
    mini = get_profile("mini")
    frames = [sf.data for sf in stop_frames(mini)]  # the stop itself must be safe to send
    assert check_unsafe(_schedule(mini, *frames), {"rex": mini}) == []


def test_each_stop_frame_says_what_it_does_for_the_report() -> None:
    labels = [f.label for f in stop_frames(get_profile("mini"))]
    assert labels == ["vx=0 vy=0 vyaw=0",
                      "periodic_roll=0 periodic_pitch=0 periodic_yaw=0 mark_time=0",
                      "periodic_x=0 periodic_y=0 periodic_z=0",
                      "action=255 (restore default posture)"]


def test_every_frame_packed_in_one_write_is_checked() -> None:
    # A scheduled frame's bytes may hold several XGO frames: a read or an unknown write
    # first must not hide an unsafe write after it.
    mini = get_profile("mini")
    known = {r.address for r in mini.registers}
    nowhere = next(a for a in range(0x100) if a not in known)
    unsafe = write_frame(mini.register("servo_zero").address, b"\x01")
    for first in (read_frame(mini.register("body_z").address, 1), write_frame(nowhere, b"\x00")):
        found = check_unsafe(_schedule(mini, first + unsafe), {"rex": mini}, allow_unsafe=True)
        assert found[-1] == "rex frame 0 at 0.000s: writes unsafe register servo_zero"
