"""XGO stop and rest frames, built from the profile's data, and the unsafe-write check.

Rest: the profile's ``safe_stop`` registers (speeds and periodic motion) written back to neutral,
adjacent registers merged into one frame as :meth:`Profile.walk` lays them out. Stop: rest,
then the reset action (restore the default posture).
"""

from __future__ import annotations

from xgo_show.errors import ProfileError
from xgo_show.families.values import StopFrame
from xgo_show.families.xgo.posture import RESET_ACTION
from xgo_show.profiles.model import Profile
from xgo_show.wire.xgo import XgoDecoder, write_frame

__all__ = ["rest_frames", "stop_frames", "unsafe_problems"]


def rest_frames(profile: Profile) -> list[StopFrame]:
    """Frames that bring the robot to rest without changing its posture (speeds to neutral)."""
    if not profile.safe_stop:
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
    """The full safe stop: rest frames, then the reset action (restore the default posture)."""
    out = rest_frames(profile)
    try:
        action = profile.register("action")
    except ProfileError:
        return out
    data = action.encode_value(RESET_ACTION)
    out.append(
        StopFrame(
            write_frame(action.address, data, write_type=profile.write_type),
            f"action={RESET_ACTION} (restore default posture)",
        )
    )
    return out


def unsafe_problems(profile: Profile, data: bytes) -> list[str]:
    """Every write in ``data`` laid out with the profile: registers marked ``unsafe`` and
    writes to addresses the profile does not know (they cannot be checked)."""
    found: list[str] = []
    for frame in XgoDecoder().feed(data):
        if not frame.is_write:
            continue
        try:
            regs = profile.walk(frame.address, len(frame.data))
        except ProfileError as exc:
            found.append(f"unknown write: {exc}")
            continue
        found.extend(f"writes unsafe register {reg.name}" for reg in regs if reg.unsafe)
    return found
