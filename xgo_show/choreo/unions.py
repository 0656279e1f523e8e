"""A mapping with exactly one *kind* key, as a pydantic type built from a table of kinds.

A cue (``{move: ...}``), a behaviour's trigger, condition or action: each is a mapping whose one
kind key says which model reads it. The table that maps each kind to its model is the one
list of them: :func:`tagged_union` makes the union pydantic validates against from it (each
member tagged by its kind, chosen by which key is present), so adding a kind is one line.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Annotated, Any, Union

from pydantic import BaseModel, Discriminator, Tag

__all__ = ["tagged_union"]


def tagged_union(
    table: Mapping[str, type[BaseModel]], tag: Callable[[object], str | None], *,
    suffix: str, error_type: str, message: str,
) -> Any:
    """The union of ``table``'s models, the one for kind ``k`` tagged ``k + suffix``; ``tag``
    gives a value's tag (None: no kind key, or several), and a value without one is the
    error ``error_type`` with ``message``. Typed Any: give the checker a static alias."""
    members = tuple(Annotated[cls, Tag(f"{kind}{suffix}")] for kind, cls in table.items())
    return Annotated[
        Union[members],  # noqa: UP007  (a runtime union for pydantic)
        Discriminator(tag, custom_error_type=error_type, custom_error_message=message),
    ]
