"""Semantic checks on a resolved show: does each robot support each cue, and do cues fight?

Run on the resolved cues (absolute times, physical values) with their :class:`CueSource`, so a
problem found in a phrase or an included file still points at the line that caused it.
Ranges are checked by the profile's own :meth:`Register.check` / ``encode_value`` (the one range
check in the package); this module only decides *which* check applies and words the message.
"""

from __future__ import annotations

import bisect
import heapq
from collections import defaultdict
from collections.abc import Iterator, Mapping
from operator import itemgetter
from typing import NamedTuple

from xgo_show.choreo.resolve import CueSource, Resolution
from xgo_show.choreo.resolved import ActionCue, ArmCue, Cue, FadeCue, MotionCue, SetCue
from xgo_show.choreo.validation import Suggestions
from xgo_show.diagnostics import Diagnostic, Origin, Severity
from xgo_show.errors import ValueRangeError
from xgo_show.families import get_family
from xgo_show.profiles import Encoding, Profile, Register, get_profile
from xgo_show.profiles.xarm import position_to_degrees

__all__ = ["PERIODIC_PAIRS", "check_show"]

# Periodic motion and the direct position on the same axis "cannot work at the same time".
PERIODIC_PAIRS: Mapping[str, str] = {
    "periodic_roll": "roll",
    "periodic_pitch": "pitch",
    "periodic_yaw": "yaw",
    "periodic_x": "body_x",
    "periodic_y": "body_y",
    "periodic_z": "body_z",
}
# Writes that do not move the robot, so they do not interrupt a running preset action.
_NON_MOTION_GROUPS = frozenset({"led", "setting"})
_EPS = 1e-9


class _Write(NamedTuple):
    """One cue writing one register over [start, end) (a tuple: one per value of the show)."""

    register: str
    start: float
    end: float
    cue: Cue
    source: CueSource
    key: str = ""  # the value's key in the cue (an xArm servo id), when not the register name


_START_END = itemgetter(1, 2)  # a _Write's (start, end), read at C level


def _fmt(t: float) -> str:
    return f"{t:.3f} s"


def _where(origin: Origin) -> str:
    return f"line {origin.line}" if origin.file else str(origin)


class _Checker:
    def __init__(self, res: Resolution) -> None:
        self.res = res
        self.diags: list[Diagnostic] = []
        self.suggest = Suggestions()  # did-you-mean hints, bounded in number
        # Per profile (by id: the checker lives as long as one check of one show).
        self.by_name: dict[int, dict[str, Register]] = {}
        self.accessories: dict[int, frozenset[str]] = {}
        # (id(profile), arm, name) -> the register, for names register() found nothing
        # wrong with: it says the same of every value of the show for them.
        self.valid: dict[tuple[int, bool, str], Register] = {}

    def error(self, message: str, origin: Origin | None, src: CueSource, sub: str = "") -> None:
        """Report at ``origin``; None: at the value ``sub`` of the cue (found only now: most
        values have nothing to report)."""
        self.report("error", message, origin, src, sub)

    def warning(self, message: str, origin: Origin | None, src: CueSource, sub: str = ""
                ) -> None:
        self.report("warning", message, origin, src, sub)

    def report(self, severity: Severity, message: str, origin: Origin | None,
               src: CueSource, sub: str) -> None:
        if origin is None:
            origin = src.values.get(sub, src.origin)
        path = src.paths.get(sub, src.path)
        self.diags.append(Diagnostic(severity, message, origin, path))

    def registers(self, profile: Profile) -> dict[str, Register]:
        """The profile's registers by name (looked up once per value of the show)."""
        found = self.by_name.get(id(profile))
        if found is None:
            found = self.by_name[id(profile)] = {r.name: r for r in profile.registers}
        return found

    def run(self) -> list[Diagnostic]:
        show = self.res.show
        if show is None:
            return self.diags
        for track in show.tracks:
            profile = get_profile(track.model)
            performer = self.res.performers[track.performer]
            for cue in track.cues:
                self.check_cue(cue, profile, performer.arm)
            if track.performer not in self.res.untimed:  # times after a broken cue are guesses
                self.check_conflicts(track.cues, profile)
        return self.diags

    # -- one cue --------------------------------------------------------------------------

    def register(
        self, name: str, profile: Profile, arm: bool, src: CueSource, origin: Origin | None
    ) -> Register | None:
        reg = self.registers(profile).get(name)
        if reg is None:
            valid = sorted(
                r.name for r in profile.registers
                if r.access.writable and not r.unsafe and r.name != "action"
            )
            self.error(f"the {profile.title} has no register {name!r}{self.suggest(name, valid)}; "
                       f"valid: {', '.join(valid)}", origin, src, name)
            return None
        if reg.unsafe:
            self.error(f"{name} is refused in a show: it is unsafe ({reg.description})",
                       origin, src, name)
            return None
        if not reg.access.writable:
            self.error(f"{name} is read-only", origin, src, name)
            return None
        if reg.name == "action":
            self.error("write preset actions with an action: cue", origin, src, name)
            return None
        accessories = self.accessories.get(id(profile))
        if accessories is None:
            accessories = self.accessories[id(profile)] = get_family(
                profile).accessory_registers(profile)
        if not arm and name in accessories:
            self.error(f"{name} needs the arm accessory: set 'arm: true' on performer "
                       f"{src.performer!r}", origin, src, name)
            return None
        return reg

    def value(self, reg: Register, value: object, src: CueSource, origin: Origin | None
              ) -> None:
        lo, hi = reg.minimum, reg.maximum
        if (lo is not None and hi is not None and value.__class__ in (float, int)
                and lo - 1e-9 <= value <= hi + 1e-9):
            return  # a number in a linear register's range: what reg.check lets pass
        try:
            if reg.linear:
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    unit = f" {reg.unit}" if reg.unit else ""
                    raise ValueRangeError(
                        f"{reg.name} takes a number in [{reg.minimum:g}, {reg.maximum:g}]{unit}, "
                        f"not {value!r}"
                    )
                if reg.encoding is Encoding.U8_PERIODIC and value == 0:
                    return  # 0 switches a periodic motion off
                reg.check(float(value))
            elif reg.encoding is Encoding.ENUM:
                if isinstance(value, float) and not value.is_integer():
                    raise ValueRangeError(f"{reg.name} takes one of {', '.join(reg.choices)}")
                reg.encode_value(int(value) if isinstance(value, float) else value)
            else:
                reg.encode_value(value)
        except ValueRangeError as exc:
            message = str(exc)
            if reg.encoding is Encoding.U8_PERIODIC:
                message += " (0 = off)"
            self.error(message, origin, src, reg.name)
        except (TypeError, ValueError):
            self.error(f"{reg.name} cannot take {value!r}", origin, src, reg.name)

    def check_cue(self, cue: Cue, profile: Profile, arm: bool) -> None:
        src = self.res.source(cue)
        if isinstance(cue, ArmCue):
            for sid, pos in cue.positions.items():
                if sid not in profile.xarm_servos:
                    ids = ", ".join(map(str, profile.xarm_servos))
                    self.error(f"the xArm has no servo {sid}; servos: {ids}", None, src, str(sid))
                    continue
                try:
                    position_to_degrees(pos)
                except ValueRangeError as exc:
                    self.error(str(exc), None, src, str(sid))
            return
        if isinstance(cue, ActionCue):
            return
        values: Mapping[str, object]
        if isinstance(cue, FadeCue):
            values = {cue.register: cue.to}
        elif isinstance(cue, MotionCue):
            values = cue.targets
        else:
            values = cue.values
        # Each value's own place is found only if there is something to say (origin None).
        origin: Origin | None = None
        valid, key = self.valid, id(profile)
        motion = isinstance(cue, MotionCue)
        for name, value in values.items():
            reg = valid.get((key, arm, name))
            if reg is None:
                reg = self.register(name, profile, arm, src, origin)
                if reg is None:
                    continue
                valid[key, arm, name] = reg
            if motion and reg.limits is None:
                # Only registers the profile gives limits are trajectory-capable; a cue's own
                # limits tune a move, they do not make a switch or a period movable.
                self.error(f"{name} cannot be moved smoothly; write it with set:", origin,
                           src, name)
                continue
            if src.kind == "walk" and reg.group != "speed":
                speeds = [r.name for r in profile.registers if r.group == "speed"]
                self.error(f"walk takes speeds ({', '.join(speeds)}), not {name}", origin, src,
                           name)
                continue
            self.value(reg, value, src, origin)
            if src.kind == "set" and reg.group == "speed" and value not in (0, 0.0):
                self.warning(f"set {name} keeps the robot moving until another cue stops it; "
                             "walk: with a length stops by itself", origin, src, name)

    # -- conflicts ------------------------------------------------------------------------

    def writes(self, cues: tuple[Cue, ...]) -> Iterator[_Write]:
        for cue in cues:
            src = self.res.source(cue)
            if isinstance(cue, MotionCue):
                for name in cue.targets:
                    yield _Write(name, cue.start, src.end, cue, src)
            elif isinstance(cue, SetCue):
                end = src.end if src.kind == "walk" and cue.start < src.end else cue.start
                for name in cue.values:
                    yield _Write(name, cue.start, end, cue, src)
            elif isinstance(cue, FadeCue):
                yield _Write(cue.register, cue.start, cue.start + cue.duration, cue, src)
            elif isinstance(cue, ArmCue):  # a servo moving is driven as a dog register is
                for sid in cue.positions:
                    yield _Write(f"servo {sid}", cue.start, cue.start + cue.duration, cue, src,
                                 str(sid))

    def check_conflicts(self, cues: tuple[Cue, ...], profile: Profile) -> None:
        writes_all = list(self.writes(cues))
        by_reg: dict[str, list[_Write]] = defaultdict(list)
        for w in writes_all:
            by_reg[w.register].append(w)
        for name, writes in by_reg.items():
            writes.sort(key=_START_END)
            longest: _Write | None = None
            for w in writes:
                if (
                    longest is not None
                    and longest.cue is not w.cue
                    and w.start < longest.end - _EPS
                    and (w.end > w.start + _EPS or w.start > longest.start + _EPS)
                    and not getattr(w.cue, "interrupts", False)
                ):
                    self.error(
                        f"{name} is already driven by the cue at "
                        f"{_where(longest.source.origin)} ({_fmt(longest.start)} to "
                        f"{_fmt(longest.end)}); this cue starts at {_fmt(w.start)}: two cues "
                        "cannot drive one register at once (add 'interrupt: true' to cut the "
                        "earlier move on purpose)",
                        w.source.values.get(w.key or name, w.source.origin), w.source,
                        w.key or name,
                    )
                if longest is None or w.end > longest.end:
                    longest = w
        self.check_actions(cues, profile)
        self.check_actions_cut_moves(cues, writes_all, profile)
        self.check_periodic(cues, by_reg)

    def check_actions(self, cues: tuple[Cue, ...], profile: Profile) -> None:
        starts = [c.start for c in cues]  # the track is sorted by start time
        for i, act in enumerate(cues):
            if not isinstance(act, ActionCue):
                continue
            asrc = self.res.source(act)
            busy_until = act.start + max(asrc.running, 0.0)
            last = bisect.bisect_left(starts, busy_until - _EPS)
            # Only the cues after it: one at the very same time but earlier in the track is
            # sent first, which is fine.
            for other in cues[i + 1:last]:
                if not self.is_motion(other, profile):
                    continue
                if getattr(other, "interrupts", False):
                    continue
                osrc = self.res.source(other)
                self.error(
                    f"starts at {_fmt(other.start)} while action {act.name!r} (from "
                    f"{_where(asrc.origin)}) runs until {_fmt(busy_until)}; any motion "
                    "command cuts a running action: start later, or add 'interrupt: true' if "
                    "that is what you want",
                    osrc.origin, osrc,
                )

    def check_actions_cut_moves(
        self, cues: tuple[Cue, ...], writes_all: list[_Write], profile: Profile
    ) -> None:
        """An action that starts while a move or a timed walk still runs cuts it short.

        (The robot drops whatever it was following when an action starts, and the compiler
        stops sampling there too.) A move sent just before the action, at the same time, is
        cut before it begins. One sweep in track order: moves enter a heap by end time; those
        over by an action's start leave it.
        """
        if not any(isinstance(c, ActionCue) and not c.interrupts for c in cues):
            return  # nothing to cut
        # One write per cue stands for it (a cue's writes share its start and end).
        moving: dict[int, _Write] = {}
        for w in writes_all:
            if w.end > w.start + _EPS and id(w.cue) not in moving:
                moving[id(w.cue)] = w
        running: list[tuple[float, int, _Write]] = []
        for order, act in enumerate(cues):  # sorted by start
            if not isinstance(act, ActionCue):
                move = moving.get(id(act))
                if move is not None and self.is_motion(act, profile):
                    heapq.heappush(running, (move.end, order, move))
                continue
            while running and running[0][0] <= act.start + _EPS:
                heapq.heappop(running)
            if act.interrupts:
                continue
            asrc = self.res.source(act)
            for _, _, w in sorted(running, key=lambda item: item[1]):
                self.error(
                    f"action {act.name!r} starts at {_fmt(act.start)} while the cue at "
                    f"{_where(w.source.origin)} still moves the robot ({_fmt(w.start)} to "
                    f"{_fmt(w.end)}); the action cuts it short: start the action when it ends, "
                    "or add 'interrupt: true' to the action to cut it on purpose",
                    asrc.origin, asrc,
                )

    def is_motion(self, cue: Cue, profile: Profile) -> bool:
        names: list[str]
        if isinstance(cue, FadeCue):
            return False
        if isinstance(cue, SetCue):
            names = list(cue.values)
        elif isinstance(cue, MotionCue):
            names = list(cue.targets)
        else:
            return True
        regs = self.registers(profile)
        groups = {regs[n].group for n in names if n in regs}
        return not groups <= _NON_MOTION_GROUPS

    def check_periodic(self, cues: tuple[Cue, ...], by_reg: Mapping[str, list[_Write]]) -> None:
        for periodic, direct in PERIODIC_PAIRS.items():
            if periodic not in by_reg or direct not in by_reg:
                continue
            # Intervals during which the periodic motion is on.
            spans: list[tuple[float, float, CueSource]] = []
            on: tuple[float, CueSource] | None = None
            for w in sorted(by_reg[periodic], key=lambda w: w.start):
                value = w.cue.values.get(periodic) if isinstance(w.cue, SetCue) else None
                running = isinstance(value, (int, float)) and value != 0
                if running and on is None:
                    on = (w.start, w.source)
                elif not running and on is not None:
                    spans.append((on[0], w.start, on[1]))
                    on = None
            if on is not None:
                spans.append((on[0], float("inf"), on[1]))
            for w in by_reg[direct]:
                for start, end, psrc in spans:
                    if w.start < end - _EPS and start < max(w.end, w.start + _EPS) - _EPS:
                        until = "the end" if end == float("inf") else _fmt(end)
                        self.error(
                            f"{direct} is set while {periodic} (started at "
                            f"{_where(psrc.origin)}) runs from {_fmt(start)} to {until}; the "
                            "periodic motion and the direct position cannot work at the same "
                            f"time: stop it first with periodic: {{{periodic[9:]}: 0}}",
                            w.source.values.get(direct, w.source.origin), w.source, direct,
                        )
                        break


def check_show(res: Resolution) -> list[Diagnostic]:
    """Every support, range, safety and timing problem in a resolved show."""
    return _Checker(res).run()
