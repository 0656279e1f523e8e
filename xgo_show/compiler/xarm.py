"""Plan an xArm performer: each ArmCue is one ServoMove packet at its start.

The xArm moves its servos itself over the time a ServoMove gives, so there is nothing to sample:
one packet per cue. Other cues make no sense for an arm and are errors.
"""

from __future__ import annotations

from xgo_show.choreo.resolved import ArmCue, ResolvedTrack
from xgo_show.compiler.frames import PlannedFrame, TrackPlan, cue_label, to_us
from xgo_show.diagnostics import Diagnostic
from xgo_show.errors import XgoShowError
from xgo_show.profiles.model import Profile

__all__ = ["plan_xarm_track"]

# ServoMove carries the time as an unsigned 16-bit number of milliseconds.
MAX_MOVE_MS = 0xFFFF


def plan_xarm_track(profile: Profile, track: ResolvedTrack) -> TrackPlan:
    """One planned ServoMove frame per ArmCue, with diagnostics for anything else."""
    from xgo_show.wire.xarm import servo_move

    frames: list[PlannedFrame] = []
    diags: list[Diagnostic] = []
    end = 0.0
    path = f"tracks.{track.performer}"
    for order, cue in enumerate(track.cues):
        where = cue.origin
        if not isinstance(cue, ArmCue):
            diags.append(Diagnostic(
                "error", f"{cue_label(where)}: an xArm only takes arm cues",
                where, path,
            ))
            continue
        time_ms = round(cue.duration * 1000)
        if not 0 <= time_ms <= MAX_MOVE_MS:
            diags.append(Diagnostic(
                "error",
                f"{cue_label(where)}: an xArm move takes 0..{MAX_MOVE_MS} ms, "
                f"not {time_ms} ms",
                where, path,
            ))
            continue
        unknown = sorted(set(cue.positions) - set(profile.xarm_servos))
        if unknown:
            diags.append(Diagnostic(
                "error", f"{cue_label(where)}: no xArm servo {unknown[0]}",
                where, path,
            ))
            continue
        try:
            data = servo_move(time_ms, dict(sorted(cue.positions.items())))
        except XgoShowError as exc:
            diags.append(Diagnostic(
                "error", f"{cue_label(where)}: {exc}", where, path
            ))
            continue
        t_us = to_us(cue.start)
        frames.append(PlannedFrame(
            t_us=t_us, data=data, fields=(), written=(), origin=where, order=order,
            droppable=False, action=False, duration=cue.duration,
        ))
        end = max(end, cue.start + cue.duration)
    frames.sort(key=lambda f: (f.t_us, f.order))
    return TrackPlan(frames, end, diags, 0)
