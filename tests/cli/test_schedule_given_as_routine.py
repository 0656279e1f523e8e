"""compile and validate take routines: a compiled schedule gets one line saying what to use."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.cli.main import main

ROUTINE = Path(__file__).resolve().parents[2] / "choreographies" / "hello_mini.yaml"


@pytest.fixture
def schedule(tmp_path: Path) -> Path:
    out = tmp_path / "hello.yaml"  # a schedule under a routine's name is still a schedule
    assert main(["compile", str(ROUTINE), "-o", str(out), "-q"]) == 0
    return out


def test_compile_refuses_a_schedule_with_a_hint(
    schedule: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["compile", str(schedule), "-o", str(schedule.with_suffix(".x.json"))]) == 2
    err = capsys.readouterr().err
    assert "is a compiled schedule already: run it with 'xgo-show run'" in err
    assert err.count("\n") == 1  # one line, not the routine loader's list of errors


def test_validate_says_it_is_a_schedule(
    schedule: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["validate", str(schedule), str(ROUTINE)]) == 1
    out = capsys.readouterr().out
    assert f"{schedule}:1:1: error: is a compiled schedule already" in out
    assert "hello_mini.yaml: ok" in out
