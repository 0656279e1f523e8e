"""Text that came from a file, made safe to print on a terminal.

A routine (a YAML ``"\\e[2J"``), a schedule file or a relay may carry terminal escape codes,
bell characters or bidirectional overrides in a name, a label or a message. Printed raw they
clear the screen, retitle the window or hide text. Everything printed that came from outside
goes through :func:`printable`; :func:`control_characters` lets loaders refuse such text.
"""

from __future__ import annotations

import re

__all__ = ["control_characters", "printable"]

# C0 and C1 controls (tab and newline included: a one-line message has none), DEL, the
# Unicode format characters that reorder or hide text (bidi overrides, zero-width marks), and
# lone surrogates (YAML's "\ud800" escape makes one): no encoding can write them out.
_UNSAFE = re.compile(
    "[\x00-\x1f\x7f-\x9f\u200b-\u200f\u202a-\u202e\u2066-\u2069\ufeff\ud800-\udfff]")


def _escape(match: re.Match[str]) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def printable(text: str) -> str:
    """``text`` with every control or text-direction character written as a visible escape
    (``\\x1b``, ``\\u202e``); plain text is returned unchanged."""
    return _UNSAFE.sub(_escape, text)


def control_characters(text: str) -> str | None:
    """The first control or text-direction character in ``text`` as an escape, or None."""
    found = _UNSAFE.search(text)
    return None if found is None else _escape(found)
