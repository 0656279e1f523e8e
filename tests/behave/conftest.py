"""Behaviours the behave tests write: two performers (rex, a Mini; ada, a Rider) and routines
of one move each, whose parts' lengths are given, so that every time a test sees can be
counted by hand."""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from pathlib import Path

MODELS = {"rex": "mini", "ada": "rider"}


def write_behaviour(folder: Path, routines: Mapping[str, Mapping[str, float]], rules: str,
                    extra: str = "") -> Path:
    """``folder/b.yaml``, a behaviour of rex and ada with ``rules`` (and the top-level keys in
    ``extra``), and its routines: each (name -> part -> seconds) a move of body_z a part."""
    for name, parts in routines.items():
        tracks = "".join(f"  {p}:\n    - move: {{body_z: 100}}\n      duration: {d}\n"
                         for p, d in parts.items())
        (folder / f"{name}.yaml").write_text(
            f"show: {name}\nperformers: {{"
            + ", ".join(f"{p}: {{model: {MODELS[p]}}}" for p in parts)
            + "}\ntracks:\n" + tracks)
    listing = ", ".join(f"{name}: {name}.yaml" for name in routines)
    path = folder / "b.yaml"
    path.write_text("behaviour: T\nperformers: {rex: {model: mini}, ada: {model: rider}}\n"
                    f"routines: {{{listing}}}\n" + extra + "rules:\n"
                    + textwrap.indent(textwrap.dedent(rules), "  "))
    return path
