"""``xgo-show schema`` prints and writes the schemas the repository ships (the same bytes)."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.cli.main import main

ROOT = Path(__file__).resolve().parents[2]


def test_schema_prints_the_shipped_schemas(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema"]) == 0
    assert capsys.readouterr().out == (ROOT / "schemas" / "choreography.schema.json").read_text()
    assert main(["schema", "--part"]) == 0
    part = (ROOT / "schemas" / "choreography-part.schema.json").read_text()
    assert capsys.readouterr().out == part


def test_schema_writes_both_into_a_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["schema", "--write", str(tmp_path / "out")]) == 0
    for name in ("choreography.schema.json", "choreography-part.schema.json"):
        assert (tmp_path / "out" / name).read_text() == (ROOT / "schemas" / name).read_text()
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["schema", "--write", str(blocker)]) == 2
    err = capsys.readouterr().err.strip()
    assert "cannot write the schemas into" in err and "\n" not in err
