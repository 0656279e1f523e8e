"""compile_show: a validated, resolved show -> a paced frame schedule per performer.

A pure function: no clock, no randomness, no I/O; the same input gives the same schedule, frame
for frame and byte for byte. Errors are collected over the whole show and raised together.
"""

from __future__ import annotations

from xgo_show.choreo.resolved import ResolvedShow, ResolvedTrack
from xgo_show.compiler.frames import PlannedFrames, cue_label, to_us
from xgo_show.compiler.pacing import PaceResult, pace
from xgo_show.compiler.schedule import FrameColumns, Frames, PerformerSchedule, Schedule
from xgo_show.compiler.state import frame_labels
from xgo_show.diagnostics import Diagnostic, once_each
from xgo_show.errors import CompileError, ProfileError
from xgo_show.families import get_family
from xgo_show.gcpause import paused_gc
from xgo_show.profiles.model import Link, Profile
from xgo_show.profiles.registry import get_profile

__all__ = ["compile_diagnostics", "compile_show"]


def compile_show(show: ResolvedShow) -> Schedule:
    """Compile ``show`` into a :class:`Schedule`.

    Raises :class:`CompileError` carrying every error found (infeasible trajectories, tracks
    that do not fit their link, ...), each with the cue's origin. Non-fatal findings (the
    loader's, and decimation) are in ``Schedule.warnings``.
    """
    with paused_gc():  # see gcpause: millions of objects, no cycle to collect
        return _compile(show, keep=True)


def compile_diagnostics(show: ResolvedShow) -> tuple[Diagnostic, ...]:
    """What :func:`compile_show` finds in ``show``, without making its frames (``validate``).

    Raises the same :class:`CompileError`; returns the same ``Schedule.warnings``. An XGO
    performer whose frames provably fit its link (:mod:`~xgo_show.compiler.linkfit`: most
    shows) is only walked, not sampled nor paced; the others are compiled in full.
    """
    with paused_gc():
        return _compile(show, keep=False, quick=True).warnings


def _compile(show: ResolvedShow, *, keep: bool, quick: bool = False) -> Schedule:
    if show.control_rate <= 0:
        raise CompileError(f"control_rate must be positive, not {show.control_rate:g} Hz")
    errors: list[Diagnostic] = []
    warnings: list[Diagnostic] = list(show.warnings)
    performers: list[PerformerSchedule] = []
    for track in show.tracks:
        try:
            profile = get_profile(track.model)
        except ProfileError as exc:
            errors.append(Diagnostic("error", str(exc), None,
                                     f"tracks.{track.performer}"))
            continue
        if quick and profile.family == "xgo":
            found = _quick_track(show, track, profile)
            if found is not None:  # no frames: a schedule is never made of these
                errors.extend(found)
                continue
        performer, errs, warns = _compile_track(show, track, profile, keep)
        errors.extend(errs)
        warnings.extend(warns)
        performers.append(performer)
    # A cue in a repeat, or a phrase several tracks play, fails the same way each time.
    errors = once_each(errors)
    warnings = once_each(warnings)
    if errors:
        lines = "\n".join(d.format() for d in errors)
        count = f"{len(errors)} error{'s' if len(errors) != 1 else ''}"
        raise CompileError(f"show {show.name!r} cannot be compiled ({count}):\n{lines}",
                           tuple(errors))
    return Schedule(
        name=show.name,
        source=show.source,
        performers=tuple(performers),
        control_rate=show.control_rate,
        on_failure=show.on_failure,
        battery_floor=show.battery_floor,
        warnings=tuple(warnings),
        bpm=show.bpm,
        beats_per_bar=show.beats_per_bar,
        tempo_map=show.tempo_map,
        sections=show.sections,
        music=show.music,
    )


def _quick_track(
    show: ResolvedShow, track: ResolvedTrack, profile: Profile
) -> list[Diagnostic] | None:
    """The errors of an XGO performer whose frames provably fit the link (None: not proven)."""
    from xgo_show.compiler.linkfit import quick_track_diagnostics

    gap = profile.link.gap if show.gap is None else show.gap
    return quick_track_diagnostics(
        track, profile, rate=show.control_rate,
        link=Link(profile.link.baud, gap, profile.link.bits_per_byte), gap_us=to_us(gap),
        period_us=to_us(1.0 / show.control_rate), decimate=show.decimate,
    )


def _compile_track(
    show: ResolvedShow, track: ResolvedTrack, profile: Profile, keep: bool
) -> tuple[PerformerSchedule, list[Diagnostic], list[Diagnostic]]:
    gap = profile.link.gap if show.gap is None else show.gap
    link = Link(profile.link.baud, gap, profile.link.bits_per_byte)
    period_us = to_us(1.0 / show.control_rate)
    path = f"tracks.{track.performer}"
    family = get_family(profile)
    plan, remerge = family.plan_track(profile, track, rate=show.control_rate, link=link, gap=gap,
                                      details=show.decimate)
    errors = list(plan.diagnostics)
    warnings: list[Diagnostic] = []
    paced: PaceResult = pace(
        plan.frames, link=link, gap_us=to_us(gap), period_us=period_us,
        decimate=show.decimate, remerge=remerge,
    )
    seen: set[object] = set()
    for late in paced.late:
        f = late.frame
        key = f.origin if f.origin is not None else f.order
        if key in seen:
            continue
        seen.add(key)
        where = cue_label(f.origin) if f.origin is not None else "a frame"
        hint = "" if show.decimate else ", or set decimate: true"
        errors.append(Diagnostic(
            "error",
            f"the link does not fit {where}: its frame planned at "
            f"{f.t_us / 1e6:.3f} s could only start at {late.start_us / 1e6:.3f} s, more than one "
            f"control period ({period_us / 1000:g} ms) late at {link.baud} baud with "
            f"{gap * 1000:g} ms between frames; write fewer registers at once or lower "
            f"control_rate{hint}",
            f.origin, path,
        ))
    if paced.dropped:
        assert paced.first_drop_us is not None
        warnings.append(Diagnostic(
            "warning",
            f"decimated {paced.dropped} of {plan.samples} trajectory sample "
            f"frames to fit the link (first at {paced.first_drop_us / 1e6:.3f} s); their values "
            "went out with later frames",
            paced.first_drop_origin, path,
        ))
    # Columns, made into frames when read (see Frames); labels are derived from the bytes
    # when read (see ScheduledFrame.label): most never are.
    # The planned frames' own columns when pacing sent them all (PlannedFrames).
    sent = PlannedFrames.of(paced.sent if keep else [])
    frames = Frames(FrameColumns(
        paced.starts if keep else [], sent.data, sent.origins, sent.durations(),
        frame_labels(profile),
    ))
    end = plan.end if show.end is None else show.end
    if paced.starts:
        end = max(end, paced.starts[-1] / 1_000_000)
    performer = PerformerSchedule(
        name=track.performer, model=profile.model, link=link, frames=frames, end=end,
        port=track.port,
    )
    return performer, errors, warnings

