"""A show's soundtrack, as the routine names it and the schedule carries it."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Music"]


@dataclass(frozen=True)
class Music:
    """The recording played with the show: ``file`` (as the routine wrote it, relative to the
    routine; ``path`` is where it was found) and ``offset``, the seconds into the recording
    at show time 0 (bar 1 beat 1; negative: the music starts that long after the show)."""

    file: str
    path: str
    offset: float = 0.0
