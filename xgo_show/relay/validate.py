"""What a relay checks in an uploaded schedule before it accepts it.

The relay is the authority for its robots, whatever the conductor asks:

1. the text is the schedule whose SHA-256 the conductor announced (nothing lost or changed);
2. it is a valid schedule file (format name, version, every field, every frame decoded:
   :func:`~xgo_show.compiler.artifact.schedule_from_bytes`);
3. every performer in it is a robot this relay owns, of the same model;
4. every performer's frames fit its link: the link is the robot's (same baud rate and bits),
   and each frame starts after the previous one's wire time plus the link's silence gap;
5. no frame writes an unsafe register or sends an unsafe command, unless the RELAY was started
   with ``--allow-unsafe`` (:func:`~xgo_show.runtime.safety.check_unsafe`).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping

from xgo_show.compiler.artifact import schedule_from_bytes
from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.errors import UploadRefused, XgoShowError
from xgo_show.profiles.model import Profile
from xgo_show.relay.robots import OwnedRobot
from xgo_show.runtime.safety import check_unsafe

__all__ = ["UploadRefused", "link_budget_problems", "schedule_digest", "validate_upload"]

# A frame may start this early against the link's budget (rounding of microsecond times).
_BUDGET_TOLERANCE = 2e-6



def schedule_digest(text: str) -> str:
    """The SHA-256 (hex) of a schedule's text, as uploads name it."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def link_budget_problems(perf: PerformerSchedule, profile: Profile) -> list[str]:
    """Where ``perf``'s frames do not fit the robot's link (empty when they all do)."""
    link = profile.link
    if (perf.link.baud, perf.link.bits_per_byte) != (link.baud, link.bits_per_byte):
        return [
            f"{perf.name}: schedule paced for {perf.link.baud} baud, "
            f"{perf.link.bits_per_byte} bits a byte; the {profile.model}'s link is "
            f"{link.baud} baud, {link.bits_per_byte} bits"
        ]
    problems: list[str] = []
    free_at = float("-inf")
    gap = max(link.gap, perf.link.gap)
    for index, frame in enumerate(perf.frames):
        if frame.t + _BUDGET_TOLERANCE < free_at:
            problems.append(
                f"{perf.name} frame {index} at {frame.t:.6f} s starts "
                f"{(free_at - frame.t) * 1e3:.3f} ms before the link is free"
            )
            if len(problems) >= 3:
                break
        free_at = frame.t + link.wire_time(len(frame.data)) + gap
    return problems


def validate_upload(
    text: str,
    sha256: str,
    robots: Mapping[str, OwnedRobot],
    *,
    allow_unsafe: bool,
) -> tuple[Schedule, list[str]]:
    """Check an upload; return the schedule and the unsafe writes allowed (if any).

    Raises :class:`UploadRefused` with a one-line reason.
    """
    digest = schedule_digest(text)
    if digest != sha256:
        raise UploadRefused(f"schedule text has SHA-256 {digest[:12]}..., not {sha256[:12]}...")
    try:
        schedule = schedule_from_bytes(text.encode("utf-8"), name="upload")
    except XgoShowError as exc:
        raise UploadRefused(f"not a valid schedule: {exc}") from exc
    if not schedule.performers:
        raise UploadRefused("the schedule has no performer")
    profiles: dict[str, Profile] = {}
    for perf in schedule.performers:
        robot = robots.get(perf.name)
        if robot is None:
            raise UploadRefused(
                f"performer {perf.name!r} is not a robot of this relay "
                f"(it owns {', '.join(robots) or 'none'})"
            )
        if perf.model != robot.model:
            raise UploadRefused(
                f"performer {perf.name!r} is a {perf.model} in the schedule, "
                f"but the robot here is a {robot.model}"
            )
        profiles[perf.name] = robot.profile
    budget = [
        problem
        for perf in schedule.performers
        for problem in link_budget_problems(perf, profiles[perf.name])
    ]
    if budget:
        raise UploadRefused("frames over the link budget: " + "; ".join(budget[:3]))
    try:
        unsafe = check_unsafe(schedule, profiles, allow_unsafe=allow_unsafe)
    except XgoShowError as exc:
        why = str(exc).replace(
            "pass --allow-unsafe to override", "this relay was started without --allow-unsafe"
        )
        raise UploadRefused(why) from exc
    return schedule, unsafe
