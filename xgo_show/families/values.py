"""Small values the family hooks return: a stop frame, a telemetry request.

Their own module (not :mod:`~xgo_show.families.base`), so that asking for a family, as
``xgo-show probe`` does, does not build them.
"""

from __future__ import annotations

from dataclasses import dataclass

from xgo_show.profiles.model import Register

__all__ = ["StopFrame", "TelemetryItem"]


@dataclass(frozen=True)
class StopFrame:
    """One frame of a stop sequence and what it does (for the report)."""

    data: bytes
    label: str


@dataclass(frozen=True)
class TelemetryItem:
    """One read request and the fields its reply carries.

    ``address`` is the first register read (XGO) or the command number (xArm, whose replies
    carry no register fields: ``fields`` is empty). ``reply_bytes`` is the reply's length where
    the robot must not receive a frame while it answers (the executor leaves room for it).
    """

    name: str
    address: int
    fields: tuple[Register, ...]
    request: bytes
    reply_bytes: int = 0

    @property
    def count(self) -> int:
        return sum(f.size for f in self.fields)
