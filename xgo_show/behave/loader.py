"""Load a behaviour file: parse, validate, check every name, compile every routine.

:func:`load_behaviour` gives a :class:`Behaviour` (the validated file and one compiled
:class:`~xgo_show.compiler.schedule.Schedule` per routine) or raises
:class:`~xgo_show.errors.ChoreographyError` listing every problem at ``file:line:col``, with the
same located-error machinery as routines. A rule that names a missing routine, performer,
trigger or set is an error here, not on stage.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from xgo_show.behave.cues import compile_cue, compile_phrase
from xgo_show.behave.model import (
    AllOf,
    AnyOf,
    BatteryBelow,
    BehaviourFile,
    InSet,
    LedCue,
    Loop,
    NotC,
    Offline,
    Online,
    PerformerIs,
    Play,
    RoutineEnded,
    SafeStop,
    SetCue,
    Stop,
    Switch,
    TelemetryCondition,
    TiltBeyond,
    TimeCondition,
)
from xgo_show.choreo.source import Document, Loc, read_yaml
from xgo_show.choreo.validation import did_you_mean, validate
from xgo_show.compiler.schedule import Schedule
from xgo_show.diagnostics import Diagnostic
from xgo_show.errors import ChoreographyError, XgoShowError

__all__ = ["Behaviour", "check_behaviour", "load_behaviour", "played", "write_key"]


def played(action: Play | Loop) -> str:
    """The name of what a play or loop action plays: its routine, or ``routine.phrase`` (with
    the phrase's parameter values, if any: ``greet.wave(speed=2)``)."""
    if isinstance(action, Loop) or action.phrase is None:
        return action.play if isinstance(action, Play) else action.loop
    args = ",".join(f"{k}={v}" for k, v in sorted((action.with_ or {}).items()))
    return f"{action.play}.{action.phrase}" + (f"({args})" if args else "")


def write_key(rule: str, index: int) -> str:
    """The key of the frames of the ``set``/``led`` action ``do[index]`` of rule ``rule``."""
    return f"{rule}.do[{index}]"


@dataclass(frozen=True)
class Behaviour:
    """A loaded behaviour: the file's model, each routine (and each phrase played on its own,
    under :func:`played`'s name) compiled, and the frames of each ``set``/``led`` action
    (under :func:`write_key`) compiled as one-cue routines."""

    path: str
    model: BehaviourFile
    routines: dict[str, Schedule]
    writes: dict[str, Schedule] = field(default_factory=dict)

    def routine_performers(self, routine: str) -> tuple[str, ...]:
        return tuple(p.name for p in self.routines[routine].performers)


class _Checker:
    def __init__(self, doc: Document, model: BehaviourFile) -> None:
        self.doc = doc
        self.model = model
        self.diags: list[Diagnostic] = []

    def error(self, loc: Loc, message: str) -> None:
        self.diags.append(Diagnostic("error", message, self.doc.origin(loc), self.doc.path(loc)))

    def name(self, loc: Loc, value: str, known: list[str], what: str) -> bool:
        if value in known:
            return True
        listing = ", ".join(known) if known else "none declared"
        self.error(loc, f"no {what} {value!r}{did_you_mean(value, known)} ({what}s: {listing})")
        return False

    def performers(self, loc: Loc, names: list[str] | None) -> None:
        for i, name in enumerate(names or []):
            self.name((*loc, i), name, list(self.model.performers), "performer")


def _conditions(cond: object, loc: Loc) -> Iterator[tuple[object, Loc]]:
    yield cond, loc
    if isinstance(cond, AllOf):
        for i, c in enumerate(cond.and_):
            yield from _conditions(c, (*loc, "and", i))
    elif isinstance(cond, AnyOf):
        for i, c in enumerate(cond.or_):
            yield from _conditions(c, (*loc, "or", i))
    elif isinstance(cond, NotC):
        yield from _conditions(cond.not_, (*loc, "not"))


def _check_names(c: _Checker, routines: dict[str, Schedule]) -> None:
    m = c.model
    sets = list(m.sets)
    perf_names = list(m.performers)
    if m.initial is not None:
        c.name(("initial",), m.initial, sets, "set")
    seen: dict[str, int] = {}
    used_triggers: set[str] = set()
    for r, rule in enumerate(m.rules):
        base: Loc = ("rules", r)
        if rule.name in seen:
            first = seen[rule.name]
            c.error((*base, "name"), f"a second rule named {rule.name!r} (rules[{first}])")
        seen.setdefault(rule.name, r)
        for i, s in enumerate(rule.sets or []):
            c.name((*base, "sets", i), s, sets, "set")
        for t, trig in enumerate(rule.when):
            tl: Loc = (*base, "when", t)
            if hasattr(trig, "trigger"):
                used_triggers.add(trig.trigger)
                c.name((*tl, "trigger"), trig.trigger, list(m.triggers), "trigger")
            if isinstance(trig, RoutineEnded):
                c.name((*tl, "routine_ended"), trig.routine_ended, list(c.model.routines),
                       "routine")
            if isinstance(trig, (BatteryBelow, TiltBeyond, Offline, Online, RoutineEnded)):
                c.performers((*tl, "performers"), trig.performers)
            bad_clear = (
                isinstance(trig, BatteryBelow)
                and trig.clear is not None
                and trig.clear <= trig.battery_below
            )
            if bad_clear:
                c.error((*tl, "clear"), "clear: must be above the level (hysteresis: it "
                        "re-arms the trigger)")
            if isinstance(trig, TiltBeyond) and trig.clear is not None and (
                trig.clear >= trig.tilt_beyond
            ):
                c.error((*tl, "clear"), "clear: must be below the angle (hysteresis: it "
                        "re-arms the trigger)")
        if rule.if_ is not None:
            for cond, cl in _conditions(rule.if_, (*base, "if")):
                if isinstance(cond, PerformerIs):
                    c.name((*cl, "performer"), cond.performer, perf_names, "performer")
                    if cond.routine is not None:
                        c.name((*cl, "routine"), cond.routine, list(m.routines), "routine")
                elif isinstance(cond, TelemetryCondition):
                    c.name((*cl, "telemetry", "performer"), cond.telemetry.performer,
                           perf_names, "performer")
                    if cond.telemetry.below is None and cond.telemetry.above is None:
                        c.error((*cl, "telemetry"), "give below:, above: or both")
                elif isinstance(cond, TimeCondition):
                    w = cond.time
                    if w.after is None and w.before is None:
                        c.error((*cl, "time"), "give after:, before: or both (HH:MM)")
                    elif w.after is not None and w.after == w.before:
                        c.error((*cl, "time"), f"an empty window: after and before are both "
                                f"{w.after}")
                elif isinstance(cond, InSet):
                    c.name((*cl, "in_set"), cond.in_set, sets, "set")
        for a, action in enumerate(rule.do):
            al: Loc = (*base, "do", a)
            if isinstance(action, (SetCue, LedCue)):
                c.performers((*al, "performers"), action.performers)
            elif isinstance(action, Play) and action.phrase is None and action.with_:
                c.error((*al, "with"), "with: gives a phrase's parameter values: add phrase:")
            if isinstance(action, (Play, Loop)):
                key = "play" if isinstance(action, Play) else "loop"
                routine = action.play if isinstance(action, Play) else action.loop
                if c.name((*al, key), routine, list(m.routines), "routine") and routine in routines:
                    has = [p.name for p in routines[routine].performers]
                    for i, p in enumerate(action.performers or []):
                        here = (*al, "performers", i)
                        if c.name(here, p, perf_names, "performer") and p not in has:
                            c.error(here, f"routine {routine!r} has no part for {p!r} (it has "
                                    f"{', '.join(has)})")
            elif isinstance(action, (Stop, SafeStop)):
                key = "stop" if isinstance(action, Stop) else "safe_stop"
                value = action.stop if isinstance(action, Stop) else action.safe_stop
                if value != "all":
                    c.performers((*al, key), list(value))
            elif isinstance(action, Switch):
                c.name((*al, "switch"), action.switch, sets, "set")
    for i, name in enumerate(m.triggers):
        if name not in used_triggers:
            c.error(("triggers", i), f"trigger {name!r} is declared but no rule waits for it")
    if m.sets and m.initial is None:
        c.error(("sets",), "sets: needs initial: (the set active at start-up)")


def _compile_routines(c: _Checker, base_dir: Path) -> dict[str, Schedule]:
    from xgo_show.choreo import load_show
    from xgo_show.compiler import compile_show

    out: dict[str, Schedule] = {}
    for name, file in c.model.routines.items():
        loc: Loc = ("routines", name)
        path = base_dir / file
        if not path.is_file():
            c.error(loc, f"routine {name!r}: no such file {str(path)!r}")
            continue
        try:
            schedule = compile_show(load_show(path))
        except ChoreographyError as exc:
            lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
            c.error(loc, f"routine {name!r} does not load: {' '.join(lines)}")
            continue
        except XgoShowError as exc:
            c.error(loc, f"routine {name!r} does not compile: {exc}")
            continue
        ok = True
        for perf in schedule.performers:
            declared = c.model.performers.get(perf.name)
            if declared is None:
                c.error(loc, f"routine {name!r} has a part for {perf.name!r}, not a performer "
                        f"of this behaviour ({', '.join(c.model.performers)})")
                ok = False
            elif declared.model != perf.model:
                c.error(loc, f"routine {name!r} plays {perf.name!r} as a {perf.model}; the "
                        f"behaviour says {declared.model}")
                ok = False
        if ok:
            out[name] = schedule
    return out


def _compile_actions(
    c: _Checker, routines: dict[str, Schedule], base_dir: Path
) -> dict[str, Schedule]:
    """Compile each phrase played on its own (into ``routines``, by :func:`played`) and each
    ``set``/``led`` action (returned, by :func:`write_key`); errors at the action."""
    m = c.model
    writes: dict[str, Schedule] = {}
    for r, rule in enumerate(m.rules):
        for a, action in enumerate(rule.do):
            al: Loc = ("rules", r, "do", a)
            if isinstance(action, Play) and action.phrase is not None:
                if action.play not in routines:
                    continue  # reported: no such routine, or it does not load
                has = routines[action.play].performers
                perfs = tuple(p.name for p in has
                              if action.performers is None or p.name in action.performers)
                schedule, problems = compile_phrase(
                    base_dir / m.routines[action.play], action.phrase, action.with_, perfs)
                for problem in problems:
                    c.error((*al, "phrase"), f"phrase {action.phrase!r} of routine "
                            f"{action.play!r}: {problem}")
                if schedule is not None:
                    routines[played(action)] = schedule
            elif isinstance(action, (SetCue, LedCue)):
                kind, value = ("set", action.set) if isinstance(action, SetCue) else (
                    "led", action.led)
                names = action.performers or list(m.performers)
                models = {p: m.performers[p].model for p in names if p in m.performers}
                if len(models) < len(names):
                    continue  # reported: no such performer
                schedule, problems = compile_cue(c.doc.file, kind, value, models)
                for problem in problems:
                    c.error((*al, kind), problem)
                if schedule is not None:
                    writes[write_key(rule.name, a)] = schedule
    return writes


def check_behaviour(path: str | Path) -> tuple[Behaviour | None, list[Diagnostic]]:
    """Parse, validate, check and compile ``path``: the behaviour (if no errors) and every
    problem found."""
    doc, diags = read_yaml(Path(path), str(path))
    if diags:
        return None, diags
    if not isinstance(doc.data, dict):
        kind = type(doc.data).__name__
        return None, [Diagnostic("error", "a behaviour is a mapping with behaviour, performers, "
                                 f"routines and rules, not {kind}", doc.origin(()))]
    model, diags = validate(BehaviourFile, doc, doc.data)
    if model is None:
        return None, diags
    checker = _Checker(doc, model)
    for name, ref in model.performers.items():
        from xgo_show.profiles import get_profile

        try:
            get_profile(ref.model)
        except XgoShowError as exc:
            checker.error(("performers", name, "model"), str(exc))
    routines = _compile_routines(checker, Path(path).parent)
    _check_names(checker, routines)
    writes = _compile_actions(checker, routines, Path(path).parent)
    diags = sorted(checker.diags, key=lambda d: (d.origin.line, d.origin.column) if d.origin
                   else (0, 0))
    if diags:
        return None, diags
    return Behaviour(str(path), model, routines, writes), []


def load_behaviour(path: str | Path) -> Behaviour:
    """Load the behaviour at ``path``; :class:`ChoreographyError` with every problem found."""
    behaviour, diags = check_behaviour(path)
    if behaviour is None:
        lines = "\n".join(d.format() for d in diags)
        raise ChoreographyError(f"{path}: {len(diags)} error(s):\n{lines}", tuple(diags))
    return behaviour
