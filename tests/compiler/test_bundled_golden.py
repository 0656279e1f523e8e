"""The bundled routines compile to the very bytes they did: a guard for the compiler's speed work.

Each routine in ``choreographies/`` (and a slice of the compile_speed benchmark show, and the
show ``examples/build_show_in_python.py`` builds) is loaded, validated and compiled; the
SHA-256 of its schedule file and of ``validate``'s findings must match the digests recorded in
``golden/bundled.sha256``. A faster compiler that changes one byte on the wire, or one
diagnostic, fails here.

Regenerate only deliberately, after checking why the bytes changed:
    XGO_SHOW_REGEN_GOLDEN=1 pytest tests/compiler/test_bundled_golden.py
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
from pathlib import Path

import pytest

from xgo_show.choreo.loader import load_show, validate_file
from xgo_show.compiler import compile_show
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule

REPO = Path(__file__).resolve().parents[2]
HERE = Path(__file__).parent
GOLDEN = HERE / "golden" / "bundled.sha256"
ROUTINES = [*sorted((REPO / "choreographies").glob("*.yaml")), HERE / "data" / "bench_slice.yaml"]


def _digest(schedule: Schedule, findings: str) -> str:
    h = hashlib.sha256(schedule_to_bytes(schedule))
    h.update(findings.encode())
    return h.hexdigest()


def _routine(path: Path) -> str:
    """Digest of one routine's schedule and findings, named by its path from the repository
    (the schedule records the path it was loaded from)."""
    rel = path.relative_to(REPO)
    findings = "\n".join(d.format() for d in validate_file(rel))
    return _digest(compile_show(load_show(rel)), findings)


def _example() -> str:
    spec = importlib.util.spec_from_file_location(
        "build_show_in_python", REPO / "examples" / "build_show_in_python.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return _digest(compile_show(module.build(2)), "")


def test_bundled_routines_compile_to_recorded_bytes(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(REPO)
    actual = {str(p.relative_to(REPO)): _routine(p) for p in ROUTINES}
    actual["examples/build_show_in_python.py"] = _example()
    text = "".join(f"{digest}  {name}\n" for name, digest in actual.items())
    if os.environ.get("XGO_SHOW_REGEN_GOLDEN"):
        GOLDEN.write_text(text, encoding="utf-8")
    assert text == GOLDEN.read_text(encoding="utf-8")
