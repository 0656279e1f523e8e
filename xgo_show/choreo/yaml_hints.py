"""Mistakes that YAML accepts silently but that change what a routine says.

An unquoted ``#ff8800`` after ``led1:`` starts a comment: the colour is gone (the value is
null, or a flow mapping ``{led1: #ff8800}`` loses its closing brace and the parser reports
something far away). :func:`colour_comment_hints` finds such places so the user is told at the
``#`` itself to quote the colour.
"""

from __future__ import annotations

import re

from xgo_show.diagnostics import Diagnostic, Origin

__all__ = ["colour_comment_hints"]

# A value position (after ':', '-', '[', ',' or '{' and a blank), then '#' and six hex digits
# that end there: a colour written like CSS. A comment ("# ff8800 is orange") has a blank
# after its '#', and a whole-line comment has nothing before it.
_COLOUR = re.compile(r"[:\-\[,{][ \t]+(#[0-9A-Fa-f]{6})(?![0-9A-Za-z_])")


def colour_comment_hints(text: str, file: str) -> list[Diagnostic]:
    """An error at each unquoted ``#RRGGBB`` in ``text`` that YAML reads as a comment."""
    if "#" not in text:
        return []
    out = []
    for number, line in enumerate(text.split("\n"), 1):
        if "#" not in line:
            continue
        for match in _COLOUR.finditer(line):
            before = line[: match.start(1)]
            if before.count('"') % 2 or before.count("'") % 2 or "#" in before:
                continue  # inside a quoted string, or already in a comment
            colour = match[1]
            out.append(Diagnostic(
                "error",
                f"{colour} without quotes starts a YAML comment, so the colour is lost: "
                f"write '{colour}' (in quotes)",
                Origin(file, number, match.start(1) + 1),
            ))
    return out
