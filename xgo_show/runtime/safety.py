"""What a safe stop sends, and the check that refuses unsafe frames before a show starts.

Stop frames are built from the profile's data by the robot's family, never hard-coded per model
(:mod:`xgo_show.families`): an XGO gets its speed and periodic-motion registers written back
to neutral, then the reset action (restore the default posture); an xArm gets GroupStop.
"""

from __future__ import annotations

from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import UnsafeScheduleError
from xgo_show.families import get_family
from xgo_show.families.values import StopFrame
from xgo_show.profiles.model import Profile

__all__ = [
    "StopFrame",
    "UnsafeScheduleError",
    "check_unsafe",
    "rest_frames",
    "stop_frames",
]


def rest_frames(profile: Profile) -> list[StopFrame]:
    """Frames that bring the robot to rest without changing its posture (speeds to neutral).

    Used on pause and at the normal end of a show. Empty for robots with nothing to rest.
    """
    return get_family(profile).rest_frames(profile)


def stop_frames(profile: Profile) -> list[StopFrame]:
    """The full safe stop: rest frames, then restore the default posture (XGO) or GroupStop."""
    return get_family(profile).stop_frames(profile)


def check_unsafe(
    schedule: Schedule, profiles: dict[str, Profile], *, allow_unsafe: bool = False
) -> list[str]:
    """Decode every frame of a schedule and refuse unsafe registers and commands.

    XGO: every write frame is laid out with the profile and refused if it touches a register
    marked ``unsafe``. xArm: every frame must be one valid request packet, refused if its
    command is one of :data:`xgo_show.profiles.xarm.UNSAFE_COMMANDS`. Returns a description of
    each unsafe frame found (empty when none). Raises :class:`UnsafeScheduleError` naming the
    first ones unless ``allow_unsafe`` is true. A write to an address the profile does not know,
    or an xArm frame that is not one valid packet, is refused the same way: it cannot be checked.
    """
    found: list[str] = []
    for perf in schedule.performers:
        profile = profiles[perf.name]
        problems = get_family(profile).unsafe_problems
        for index, sframe in enumerate(perf.frames):
            where = f"{perf.name} frame {index} at {sframe.t:.3f}s"
            if sframe.origin is not None:
                where += f" ({sframe.origin})"
            found.extend(f"{where}: {problem}" for problem in problems(profile, sframe.data))
    if found and not allow_unsafe:
        more = f" (and {len(found) - 3} more)" if len(found) > 3 else ""
        raise UnsafeScheduleError(
            "refusing to run: " + "; ".join(found[:3]) + more + "; pass --allow-unsafe to override"
        )
    return found
