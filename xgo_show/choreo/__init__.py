"""Choreography: the routine language, its loader and its checks.

:func:`load_show` turns a YAML routine into a :class:`~xgo_show.choreo.resolved.ResolvedShow`
(raising :class:`~xgo_show.errors.ChoreographyError` with every problem found);
:func:`validate_file` also runs the compiler and returns all diagnostics;
:func:`xgo_show.choreo.schema.choreography_json_schema` gives the JSON schema for editors.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from xgo_show.choreo.loader import check_file, load_show, validate_file

__all__ = ["check_file", "load_show", "validate_file"]


def __getattr__(name: str) -> Any:
    # Imported on first use: the loader pulls in pydantic and the routine model (~0.15 s),
    # which commands that only need, say, xgo_show.choreo.timebase should not pay for.
    if name in __all__:
        from xgo_show.choreo import loader

        return getattr(loader, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
