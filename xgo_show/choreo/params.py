"""Parameters of phrases and parts: ``$name`` (and ``-$name``) in a block's cues.

:func:`substitute` puts the values into a copy of the block's raw cues *before* they are
validated, so a value is checked by the same rules (and with the same messages) as one written
in place, and keeps the type it was written with: ``500`` stays an int (an xArm position),
``1.5`` a float, ``red`` a string, ``[255, 0, 0]`` a list. Every node filled in is linked to
where its value was written (:class:`~xgo_show.choreo.source.Link`), so an error in it points
at that ``file:line:col`` and its field path names the parameter and the use.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field

from xgo_show.choreo.source import Document, Link, Loc
from xgo_show.choreo.validation import did_you_mean

__all__ = ["PARAM", "Argument", "Substitution", "negate", "substitute"]

PARAM = re.compile(r"^(-?)\$([A-Za-z_][A-Za-z0-9_]*)$")


@dataclass(frozen=True)
class Argument:
    """A parameter's value and where it was written (``with:`` entry or default)."""

    value: object
    doc: Document
    loc: Loc


@dataclass
class Substitution:
    """The block's cues with the values put in, and what went wrong on the way."""

    data: object
    links: dict[Loc, Link] = field(default_factory=dict)
    # (loc, message, key): ``key`` points at a mapping key rather than a value
    problems: list[tuple[Loc, str, bool]] = field(default_factory=list)
    holes: list[Loc] = field(default_factory=list)  # uses of a parameter that has no value


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def negate(value: object) -> object | None:
    """``-value`` for a number, element by element for a list of numbers; None otherwise."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return -value
    if isinstance(value, list) and value and all(_is_number(v) for v in value):
        return [-v for v in value]
    return None


def substitute(
    raw: object, args: Mapping[str, Argument | None], *, at: Loc, label: str, base: Loc,
    owner: str,
) -> Substitution:
    """Replace every ``$name`` / ``-$name`` value in ``raw`` (found at ``at``).

    ``args`` maps each parameter of the block to its value; ``None`` marks a parameter without
    one (a structural check of a part on its own), whose uses are left as they are and listed
    in ``holes``. ``label`` (``phrase nod``) and ``base`` (the block's place) go into the
    links; ``owner`` (``phrase 'nod'``) names the block in messages. Parameter values are not
    searched for ``$`` themselves: a value is used as written.
    """
    out = Substitution(None)
    names = list(args)

    def walk(node: object, here: Loc) -> object:
        if isinstance(node, dict):
            for key in node:
                if isinstance(key, str) and PARAM.match(key):
                    out.problems.append(((*here, key), "parameters stand for values, not "
                                         "keys: write the key itself here", True))
            return {k: walk(v, (*here, k)) for k, v in node.items()}
        if isinstance(node, list):
            return [walk(v, (*here, i)) for i, v in enumerate(node)]
        match = PARAM.match(node) if isinstance(node, str) else None
        if match is None:
            return node
        minus, name = match[1], match[2]
        if name not in args:
            listing = ", ".join(names) or "none"
            out.problems.append((here, f"unknown parameter ${name} in {owner}"
                                 f"{did_you_mean(name, names)}; parameters: {listing}", False))
            return node
        arg = args[name]
        if arg is None:
            out.holes.append(here)
            return node
        out.links[here] = Link(arg.doc, arg.loc, label, base)
        if not minus:
            return arg.value
        value = negate(arg.value)
        if value is None:
            out.problems.append((here, f"-${name} needs a number (or a list of numbers), but "
                                 f"{name} is {arg.value!r}", False))
            return node
        return value

    out.data = walk(raw, at)
    return out
