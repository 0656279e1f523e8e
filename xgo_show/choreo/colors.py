"""LED colours by name, ``#rrggbb`` or ``[r, g, b]``."""

from __future__ import annotations

import re
from collections.abc import Mapping

__all__ = ["COLORS", "parse_color"]

COLORS: Mapping[str, tuple[int, int, int]] = {
    "off": (0, 0, 0),
    "black": (0, 0, 0),
    "white": (255, 255, 255),
    "warm_white": (255, 180, 100),
    "red": (255, 0, 0),
    "green": (0, 255, 0),
    "blue": (0, 0, 255),
    "yellow": (255, 255, 0),
    "cyan": (0, 255, 255),
    "magenta": (255, 0, 255),
    "orange": (255, 128, 0),
    "purple": (128, 0, 255),
    "pink": (255, 96, 160),
}

_HEX = re.compile(r"^#([0-9a-fA-F]{6})$")


def parse_color(value: object) -> tuple[int, int, int]:
    """A colour -> (r, g, b); :class:`ValueError` says what is accepted."""
    if value is False:  # false for a colour: off (YAML 1.2 reads off as text anyway)
        return COLORS["off"]
    if isinstance(value, str):
        name = value.strip().lower().replace(" ", "_").replace("-", "_")
        if name in COLORS:
            return COLORS[name]
        match = _HEX.match(value.strip())
        if match:
            raw = int(match[1], 16)
            return (raw >> 16) & 0xFF, (raw >> 8) & 0xFF, raw & 0xFF
        raise ValueError(
            f"unknown colour {value!r}: use \"#rrggbb\", [r, g, b] or one of {', '.join(COLORS)}"
        )
    if (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c <= 255 for c in value)
    ):
        return value[0], value[1], value[2]
    raise ValueError(f"a colour [r, g, b] has three whole numbers 0..255, not {value!r}")
