"""What a safe stop sends, and the check that refuses unsafe frames before a show starts.

Stop frames are built from the profile's data (``Profile.safe_stop``), never hard-coded per
model: an XGO gets its speed and periodic-motion registers written back to neutral (adjacent
registers merged into one frame, as :meth:`Profile.walk` lays them out), then action 255
(restore the default posture); an xArm gets GroupStop.
"""

from __future__ import annotations

from dataclasses import dataclass

from xgo_show.compiler.artifact import xarm_frame_problem
from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import ProfileError, XgoShowError
from xgo_show.profiles.model import Profile
from xgo_show.profiles.xarm import UNSAFE_COMMANDS
from xgo_show.wire.xarm import decode_one as decode_xarm
from xgo_show.wire.xgo import XgoDecoder, write_frame

__all__ = [
    "RESTORE_POSTURE_ACTION",
    "StopFrame",
    "UnsafeScheduleError",
    "check_unsafe",
    "rest_frames",
    "stop_frames",
]

RESTORE_POSTURE_ACTION = 255


class UnsafeScheduleError(XgoShowError):
    """A schedule writes a register that is never touched during a show."""


@dataclass(frozen=True)
class StopFrame:
    """One frame of a stop sequence and what it does (for the report)."""

    data: bytes
    label: str


def rest_frames(profile: Profile) -> list[StopFrame]:
    """Frames that bring the robot to rest without changing its posture (speeds to neutral).

    Used on pause and at the normal end of a show. Empty for robots with nothing to rest.
    """
    if profile.family != "xgo" or not profile.safe_stop:
        return []
    fields = sorted(
        ((profile.register(name), value) for name, value in profile.safe_stop),
        key=lambda rv: rv[0].address,
    )
    out: list[StopFrame] = []
    run: list[tuple[int, bytes, str]] = []

    def flush() -> None:
        if not run:
            return
        data = b"".join(d for _, d, _ in run)
        out.append(
            StopFrame(
                write_frame(run[0][0], data, write_type=profile.write_type),
                " ".join(label for _, _, label in run),
            )
        )
        run.clear()

    for reg, value in fields:
        if run and reg.address != run[-1][0] + 1:
            flush()
        run.append((reg.address, reg.encode_value(value), f"{reg.name}={value:g}"))
    flush()
    for frame in out:
        # The one layout walk must agree with the merge above (a 1-byte field per address).
        profile.walk(frame.data[4], frame.data[2] - 8)
    return out


def stop_frames(profile: Profile) -> list[StopFrame]:
    """The full safe stop: rest frames, then restore the default posture (XGO) or GroupStop."""
    if profile.family == "xarm":
        from xgo_show.wire.xarm import group_stop

        return [StopFrame(group_stop(), "GroupStop")]
    out = rest_frames(profile)
    try:
        action = profile.register("action")
    except ProfileError:
        return out
    data = action.encode_value(RESTORE_POSTURE_ACTION)
    out.append(
        StopFrame(
            write_frame(action.address, data, write_type=profile.write_type),
            f"action={RESTORE_POSTURE_ACTION} (restore default posture)",
        )
    )
    return out


def _xarm_unsafe(data: bytes) -> str | None:
    """What is unsafe about one xArm frame (None: a safe, valid request packet)."""
    problem = xarm_frame_problem(data)
    if problem is not None:
        return f"unknown packet: {problem}"
    _, packet = decode_xarm(data)
    assert packet is not None  # xarm_frame_problem found one whole packet
    why = UNSAFE_COMMANDS.get(int(packet.command))
    if why is None:
        return None
    return f"sends unsafe command {packet.command.label} ({int(packet.command)}: {why})"


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
        for index, sframe in enumerate(perf.frames):
            where = f"{perf.name} frame {index} at {sframe.t:.3f}s"
            if sframe.origin is not None:
                where += f" ({sframe.origin})"
            if profile.family == "xarm":
                problem = _xarm_unsafe(sframe.data)
                if problem is not None:
                    found.append(f"{where}: {problem}")
                continue
            if profile.family != "xgo":
                continue
            for frame in XgoDecoder().feed(sframe.data):
                if not frame.is_write:
                    continue
                try:
                    regs = profile.walk(frame.address, len(frame.data))
                except ProfileError as exc:
                    found.append(f"{where}: unknown write: {exc}")
                    continue
                found.extend(
                    f"{where}: writes unsafe register {reg.name}" for reg in regs if reg.unsafe
                )
    if found and not allow_unsafe:
        more = f" (and {len(found) - 3} more)" if len(found) > 3 else ""
        raise UnsafeScheduleError(
            "refusing to run: " + "; ".join(found[:3]) + more + "; pass --allow-unsafe to override"
        )
    return found
