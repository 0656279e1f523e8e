"""``xgo-show info MODEL``: what a robot model offers a routine, from its profile.

Preset actions with their documented durations, the registers a routine may write with their
units and ranges (grouped as the profile groups them), the LEDs, an xArm's servos by name, and
the serial link. Everything printed comes from the same profile tables the validator uses.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from xgo_show.compiler.layout import ACTION_REGISTER
from xgo_show.profiles import MODELS, Encoding, Profile, Register, get_profile
from xgo_show.profiles.xarm import DEGREES_MAX, DEGREES_MIN, POSITION_MAX, SERVO_NAMES

__all__ = ["add_parser", "describe_model", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``info`` subcommand."""
    parser = sub.add_parser(
        "info",
        help="what a robot model offers: actions, registers with units and ranges, LEDs, servos",
        description=(
            "Print what a routine can ask of MODEL: its preset actions (with the duration the "
            "documents give, or none), the registers a cue may write with their units and "
            "ranges, its LEDs, an xArm's servos, and its serial link."
        ),
        epilog="example:\n  xgo-show info mini\n  xgo-show info rider\n  xgo-show info xarm",
    )
    parser.add_argument("model", metavar="MODEL", help=f"one of: {', '.join(MODELS)}")
    parser.set_defaults(func=run)


def _range(reg: Register) -> str:
    unit = f" {reg.unit}" if reg.unit else ""
    if reg.choices:
        return "one of: " + ", ".join(reg.choices)
    if reg.encoding is Encoding.RGB:
        return "colour: a name (red) or '#RRGGBB'"
    if reg.minimum is not None and reg.maximum is not None:
        off = "0 = off, else " if reg.encoding is Encoding.U8_PERIODIC else ""
        return f"{off}{reg.minimum:g} .. {reg.maximum:g}{unit}"
    return f"{reg.encoding.value}{unit}"


def _table(rows: Sequence[tuple[str, ...]], indent: str = "  ") -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return [indent + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
            for r in rows]


def describe_model(profile: Profile) -> str:
    """The text ``xgo-show info`` prints for ``profile``."""
    lines = [f"{profile.title} (model: {profile.model}, family: {profile.family})",
             f"serial link: {profile.link.baud} baud, {profile.link.gap * 1000:g} ms between "
             "frames"]
    if profile.actions:
        lines += ["", "preset actions (action: NAME or number; a cue needs duration, beats or "
                  "bars where none is documented):"]
        lines += _table([("id", "name", "duration")] + [
            (str(a.id), a.name, f"{a.duration:g} s" if a.duration is not None else "not documented")
            for a in profile.actions])
    writable = [r for r in profile.registers  # the action register: see the actions above
                if r.access.writable and not r.unsafe and r.name != ACTION_REGISTER]
    leds = [r for r in writable if r.encoding is Encoding.RGB]
    others = [r for r in writable if r.encoding is not Encoding.RGB]
    if others:
        lines += ["", "registers a cue may write (move: for smooth moves, set: for settings):"]
        rows = [("name", "range", "group", "moves smoothly")]
        for reg in sorted(others, key=lambda r: (r.group, r.address)):
            rows.append((reg.name, _range(reg), reg.group or "-",
                         "yes" if reg.limits is not None else "no"))
        lines += _table(rows)
    if leds:
        lines += ["", "LEDs (led: {NAME: colour}, 'all' for every one; fade: to blend):",
                  "  " + ", ".join(r.name for r in leds)]
    if profile.xarm_servos:
        lines += ["", f"servos (pose: positions 0..{POSITION_MAX}, 500 = centre; pose_deg: "
                  f"degrees {DEGREES_MIN:g}..{DEGREES_MAX:g}, 0 = centre):"]
        lines += _table([("id", "name")] + [
            (str(i), SERVO_NAMES.get(i, "")) for i in profile.xarm_servos])
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    print(describe_model(get_profile(args.model)))
    return 0
