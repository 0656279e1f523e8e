"""What a relay accepts in an upload, checked in-process against robots on real simulator ptys:
the digest, the file, who owns each performer, the link budget, and unsafe writes."""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Iterator

import pytest

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.errors import UploadRefused
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Link
from xgo_show.relay.robots import OwnedRobot, close_robots, open_robots
from xgo_show.relay.validate import link_budget_problems, schedule_digest, validate_upload
from xgo_show.wire.xgo import write_frame

from .conftest import upload_text, walk_schedule

MINI = get_profile("mini")
BODY_Z = MINI.register("body_z")
SERVO_ZERO = 0x21  # an unsafe register of the XGO dogs


@pytest.fixture(scope="module")
def robots() -> Iterator[dict[str, OwnedRobot]]:
    owned = open_robots({"rex": "sim:mini", "rita": "sim:rider"}, {})
    yield owned
    close_robots(owned)


def frames_at(*times: float, size: int = 9) -> tuple[ScheduledFrame, ...]:
    """Frames of ``size`` bytes (a one-register write of ``size - 8`` bytes) at ``times``."""
    payload = bytes(size - 8)
    return tuple(ScheduledFrame(t, write_frame(BODY_Z.address, payload)) for t in times)


def with_frames(frames: tuple[ScheduledFrame, ...], link: Link = MINI.link) -> Schedule:
    perf = PerformerSchedule("rex", "mini", link, frames, end=1.0)
    return Schedule("t", "t.yaml", (perf,), 20.0)


def upload(schedule: Schedule, robots: dict[str, OwnedRobot], *, allow_unsafe: bool = False
           ) -> tuple[Schedule, list[str]]:
    text, sha = upload_text(schedule)
    return validate_upload(text, sha, robots, allow_unsafe=allow_unsafe)


def summary(schedule: Schedule) -> list[tuple[object, ...]]:
    """Who plays what: names, models, links, and each frame's time (to the µs the file keeps)
    and bytes."""
    return [(p.name, p.model, p.link, [(round(f.t, 6), f.data) for f in p.frames])
            for p in schedule.performers]


def test_the_digest_is_the_sha256_of_the_utf8_text() -> None:
    assert schedule_digest("é") == hashlib.sha256("é".encode()).hexdigest()


def test_a_valid_upload_comes_back_as_the_schedule_sent(robots) -> None:
    show = walk_schedule(0.5, rex="mini", rita="rider")
    schedule, unsafe = upload(show, robots)
    assert unsafe == []
    assert summary(schedule) == summary(show)


def test_text_that_is_not_the_announced_one_is_refused_naming_both_digests(robots) -> None:
    text, sha = upload_text(walk_schedule(0.3, rex="mini"))
    changed = text + " "  # still a valid file, but not the text announced
    with pytest.raises(UploadRefused) as err:
        validate_upload(changed, sha, robots, allow_unsafe=False)
    assert str(err.value) == (
        f"schedule text has SHA-256 {schedule_digest(changed)[:12]}..., not {sha[:12]}..."
    )


def test_text_that_is_no_schedule_is_refused_as_invalid(robots) -> None:
    text = '{"format": "nonsense"}'
    # The error locates the problem in the upload, as a file's would in its file.
    with pytest.raises(UploadRefused, match=r"^not a valid schedule: upload: "):
        validate_upload(text, schedule_digest(text), robots, allow_unsafe=False)


def test_a_schedule_without_performers_is_refused(robots) -> None:
    with pytest.raises(UploadRefused, match=r"^not a valid schedule: .*no performer$"):
        upload(Schedule("t", "t.yaml", (), 20.0), robots)


def test_a_performer_the_relay_does_not_own_is_refused_listing_what_it_owns(robots) -> None:
    with pytest.raises(UploadRefused) as err:
        upload(walk_schedule(0.3, rex="mini", max="mini"), robots)
    assert str(err.value) == "performer 'max' is not a robot of this relay (it owns rex, rita)"
    with pytest.raises(UploadRefused, match=r"\(it owns none\)$"):
        upload(walk_schedule(0.3, rex="mini"), {})


def test_a_performer_of_another_model_is_refused_naming_both(robots) -> None:
    with pytest.raises(UploadRefused) as err:
        upload(walk_schedule(0.3, rex="lite"), robots)
    assert str(err.value) == (
        "performer 'rex' is a lite in the schedule, but the robot here is a mini"
    )


@pytest.mark.parametrize("link", [dataclasses.replace(MINI.link, baud=MINI.link.baud * 2),
                                  dataclasses.replace(MINI.link, bits_per_byte=11)])
def test_a_schedule_paced_for_another_link_is_refused(robots, link: Link) -> None:
    with pytest.raises(UploadRefused) as err:
        upload(with_frames(frames_at(0.0), link), robots)
    assert str(err.value) == (
        f"frames over the link budget: rex: schedule paced for {link.baud} baud, "
        f"{link.bits_per_byte} bits a byte; the mini's link is {MINI.link.baud} baud, "
        f"{MINI.link.bits_per_byte} bits"
    )


def busy(nbytes: int = 9, link: Link = MINI.link) -> float:
    """Seconds a frame of ``nbytes`` holds the link: its wire time plus the silence gap."""
    return link.wire_time(nbytes) + link.gap


def test_frames_that_exactly_fill_the_link_are_accepted() -> None:
    times = [i * busy() for i in range(6)]
    perf = with_frames(frames_at(*times)).performers[0]
    assert link_budget_problems(perf, MINI) == []
    # Up to 2 µs early is rounding of microsecond times, not an overrun.
    early = [t - 1.9e-6 * (i > 0) for i, t in enumerate(times)]
    assert link_budget_problems(with_frames(frames_at(*early)).performers[0], MINI) == []


def test_a_frame_that_starts_before_the_link_is_free_is_named_with_how_early() -> None:
    # Frame 2 is 1.25 ms early against frame 1 (which is on time after frame 0).
    times = (0.0, busy(), 2 * busy() - 1.25e-3, 5.0)
    problems = link_budget_problems(with_frames(frames_at(*times)).performers[0], MINI)
    assert problems == [f"rex frame 2 at {times[2]:.6f} s starts 1.250 ms before the link is free"]


def test_the_budget_counts_each_frames_own_length() -> None:
    # A 20-byte frame holds the link longer than a 9-byte one: the next 9-byte frame placed
    # for a 9-byte predecessor is early.
    first = ScheduledFrame(0.0, write_frame(BODY_Z.address, bytes(12)))
    second = frames_at(busy(9))
    perf = with_frames((first, *second)).performers[0]
    assert len(first.data) == 20
    assert link_budget_problems(perf, MINI) != []
    on_time = frames_at(busy(20))
    assert link_budget_problems(with_frames((first, *on_time)).performers[0], MINI) == []


def test_the_budget_keeps_the_longer_of_the_two_gaps() -> None:
    wider = dataclasses.replace(MINI.link, gap=MINI.link.gap + 1e-3)
    tight = frames_at(0.0, busy())
    assert link_budget_problems(with_frames(tight, wider).performers[0], MINI) != []
    assert link_budget_problems(with_frames(frames_at(0.0, busy(link=wider)), wider)
                                .performers[0], MINI) == []


def test_at_most_three_overruns_are_listed_and_the_upload_names_them(robots) -> None:
    crowded = frames_at(*(i * 1e-4 for i in range(10)))
    problems = link_budget_problems(with_frames(crowded).performers[0], MINI)
    assert [p.split(" at ")[0] for p in problems] == [f"rex frame {i}" for i in (1, 2, 3)]
    with pytest.raises(UploadRefused) as err:
        upload(with_frames(crowded), robots)
    assert str(err.value) == "frames over the link budget: " + "; ".join(problems)
    # Two crowded performers: still the first three overruns only.
    rider = get_profile("rider")
    both = Schedule("t", "t.yaml", (with_frames(crowded).performers[0], PerformerSchedule(
        "rita", "rider", rider.link, crowded, end=1.0)), 20.0)
    with pytest.raises(UploadRefused) as err:
        upload(both, robots)
    assert str(err.value) == "frames over the link budget: " + "; ".join(problems)


def test_an_unsafe_write_is_refused_saying_the_relay_does_not_allow_it(robots) -> None:
    show = with_frames((ScheduledFrame(0.0, write_frame(SERVO_ZERO, b"\x01")),))
    with pytest.raises(UploadRefused) as err:
        upload(show, robots)
    message = str(err.value)
    assert message.startswith("refusing to run: rex frame 0 at 0.000s")
    assert "servo_zero" in message
    assert message.endswith("; this relay was started without --allow-unsafe")


def test_a_relay_started_with_allow_unsafe_accepts_it_and_lists_it(robots) -> None:
    show = with_frames((ScheduledFrame(0.0, write_frame(SERVO_ZERO, b"\x01")),))
    schedule, unsafe = upload(show, robots, allow_unsafe=True)
    assert summary(schedule) == summary(show)
    assert len(unsafe) == 1 and "servo_zero" in unsafe[0]
