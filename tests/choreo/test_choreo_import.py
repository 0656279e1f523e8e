"""Importing the schedule types or the CLI does not load the routine loader (pydantic)."""

from __future__ import annotations

import subprocess
import sys

import pytest


@pytest.mark.parametrize("module", ["xgo_show.compiler.schedule", "xgo_show.cli.main"])
def test_loader_is_imported_on_first_use_only(module: str) -> None:
    code = (
        f"import sys, {module}\n"
        "assert 'xgo_show.choreo.loader' not in sys.modules, 'loader imported'\n"
        "from xgo_show.choreo import load_show\n"
        "assert 'xgo_show.choreo.loader' in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_unknown_names_are_attribute_errors() -> None:
    import xgo_show.choreo as choreo

    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        choreo.nope  # noqa: B018
