"""The routine shown in README.md is valid and compiles (the README must not rot)."""

from __future__ import annotations

import re
from pathlib import Path

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_routine_validates_and_compiles(tmp_path: Path) -> None:
    blocks = re.findall(r"```yaml\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    assert blocks, "README.md shows no yaml routine"
    for i, block in enumerate(blocks):
        path = tmp_path / f"readme_{i}.yaml"
        path.write_text(block, encoding="utf-8")
        schedule = compile_show(load_show(path))
        assert schedule.performers and schedule.performers[0].frames
