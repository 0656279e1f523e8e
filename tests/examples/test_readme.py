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


def test_readme_python_api_runs(tmp_path: Path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The README's Python blocks, run in order as one script on simulated robots."""
    import contextlib
    import io
    import os

    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    shows = [b for b in blocks if "load_show" in b or "Launch(" in b]
    assert len(shows) == 2, "README.md lost its show or launch example"
    monkeypatch.chdir(tmp_path)
    os.symlink(README.parent / "choreographies", tmp_path / "choreographies")
    # The same code on virtual time (every frame still sent), so the test does not wait 60 s.
    script = "\n".join(shows).replace("clock=MonotonicClock()", "clock=FakeClock()")
    script = "from xgo_show.runtime import FakeClock\n" + script
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(script, "README.md", "exec"), {})
    text = out.getvalue()
    assert (tmp_path / "duet.xshow.json").is_file()
    assert "show completed" in text
    assert "mira (mini): finished" in text and "lumo (lite): finished" in text
    assert "simulated robots at the end:" in text
