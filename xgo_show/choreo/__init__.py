"""Choreography: the routine language, its loader and its checks.

:func:`load_show` turns a YAML routine into a :class:`~xgo_show.choreo.resolved.ResolvedShow`
(raising :class:`~xgo_show.errors.ChoreographyError` with every problem found);
:func:`validate_file` also runs the compiler and returns all diagnostics.
"""

from __future__ import annotations

from xgo_show.choreo.loader import check_file, load_show, validate_file
from xgo_show.choreo.schema import choreography_json_schema

__all__ = ["check_file", "choreography_json_schema", "load_show", "validate_file"]
