"""The unit a model's number is written in, so that messages say ranges in it."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Unit"]


@dataclass(frozen=True, slots=True)
class Unit:
    """Metadata for ``Annotated[float, Field(ge=1, le=1000), Unit("ms")]``: pydantic ignores
    it; a value out of range is reported as "0 ms is too small: give 1 to 1000 ms"."""

    symbol: str
