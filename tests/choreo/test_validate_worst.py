"""The worst-case routines of benchmarks/validate_worst.py are refused or accepted as documented.

Each case is built at (or just past) a limit of docs/limits.md and validated in this process;
the cases taking seconds (1 MiB of moves, in one file or in parts, the full planner at the
sample limit, 1 MiB of errors, aliases to the value limit) are left to the benchmark, which
prints the same verdict with its figures.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from xgo_show.choreo import validate_file

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import validate_worst

SLOW = {"dense_max", "parts_max", "dense_full_planner", "errors_max", "aliases_1m"}


def test_every_case_names_a_documented_outcome() -> None:
    names = [c.name for c in validate_worst.CASES]
    assert len(names) == len(set(names)) >= 10
    assert set(names) > SLOW
    limits = (Path(__file__).resolve().parents[2] / "docs" / "limits.md").read_text()
    assert "benchmarks/validate_worst.py" in limits


@pytest.mark.parametrize("case", [c for c in validate_worst.CASES if c.name not in SLOW],
                         ids=lambda c: c.name)
def test_case_is_refused_or_accepted_as_documented(case: validate_worst.Case,
                                                   tmp_path: Path) -> None:
    path = case.build(tmp_path)
    diags = validate_file(path)
    errors = [d for d in diags if d.is_error]
    if case.refused is None:
        assert not errors, errors[:3]
    else:
        assert errors and case.refused in errors[0].format(), errors[:3]
