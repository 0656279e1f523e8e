"""Plan an xArm performer (each ArmCue is one ServoMove packet at its start) and read it back.

The xArm moves its servos itself over the time a ServoMove gives, so there is nothing to sample:
one packet per cue. Other cues make no sense for an arm and are errors.

Read back (the xArm family's answers to :mod:`xgo_show.compiler.state`): the xArm has no
register table; its state is one entry per servo, ``servo_<id>``, the position as two bytes
little-endian, as a ServoMove carries it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from xgo_show.choreo.resolved import ArmCue, ResolvedTrack
from xgo_show.compiler.frames import PlannedFrame, TrackPlan, cue_label, to_us
from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.diagnostics import Diagnostic
from xgo_show.errors import ProtocolError, XgoShowError
from xgo_show.profiles.model import Profile

__all__ = ["describe_xarm_frame", "plan_xarm_track", "xarm_frames_to_reach", "xarm_state_at"]

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


def _xarm_move(data: bytes) -> tuple[int, list[tuple[int, int]]]:
    """(time ms, [(servo id, position)]) of one ServoMove packet."""
    from xgo_show.wire.xarm import ServoMove, decode_one, parse_request

    used, packet = decode_one(data)
    if packet is None or used != len(data):
        raise ProtocolError(f"not a single xArm packet: {data.hex(' ')}")
    request = parse_request(packet)
    if not isinstance(request, ServoMove):
        raise ProtocolError(f"not an xArm ServoMove: {data.hex(' ')}")
    return request.time_ms, sorted(request.positions.items())


def describe_xarm_frame(data: bytes) -> list[tuple[str, object]]:
    """``("time_ms", n)`` then ``("servo_<id>", position)`` per servo of a ServoMove."""
    time_ms, positions = _xarm_move(data)
    return [("time_ms", time_ms), *((f"servo_{i}", p) for i, p in positions)]


def xarm_state_at(frames: Sequence[ScheduledFrame], t: float) -> dict[str, bytes]:
    """``servo_<id>`` -> 2-byte little-endian target of the last move started by ``t``."""
    state: dict[str, bytes] = {}
    for frame in frames:
        if frame.t > t:
            break
        for servo, pos in _xarm_move(frame.data)[1]:
            state[f"servo_{servo}"] = pos.to_bytes(2, "little")
    return state


def xarm_frames_to_reach(
    profile: Profile, state: Mapping[str, bytes], *, move_time: float
) -> list[ScheduledFrame]:
    """One ServoMove taking ``move_time`` seconds to the servo positions in ``state``."""
    from xgo_show.compiler.state import reach_frame
    from xgo_show.wire.xarm import servo_move

    positions = {
        int(name.removeprefix("servo_")): int.from_bytes(raw, "little")
        for name, raw in state.items()
        if name.startswith("servo_")
    }
    if not positions:
        return []
    data = servo_move(round(move_time * 1000), dict(sorted(positions.items())))
    return [reach_frame(profile, data, move_time)]
