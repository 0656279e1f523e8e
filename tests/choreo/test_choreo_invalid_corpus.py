"""The invalid-routine corpus: each file names the error it must produce, and where.

Every ``invalid/*.yaml`` starts with one or more ``# expect: [FILE:]LINE:COL error: SUBSTRING``
lines. The check runs the full validation (loader, semantic checks and, where available, the
compiler) and asserts, for each line, an error with that position whose message contains the
substring: a file expecting several errors proves that one problem hides no other. ``FILE``
(relative to invalid/) is given when the error belongs to an included file.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from xgo_show.choreo import validate_file

CORPUS = Path(__file__).parent / "invalid"
_EXPECT = re.compile(
    r"^# expect: (?:(?P<file>[\w./-]+):)?(?P<line>\d+):(?P<col>\d+) error: (?P<msg>.+)$"
)
FILES = sorted(CORPUS.glob("*.yaml"))


def test_corpus_is_large_enough() -> None:
    assert len(FILES) >= 30


def _expectations(path: Path) -> list[re.Match[str]]:
    found = []
    for line in path.read_text(encoding="utf-8").split("\n"):
        if not line.startswith("# expect:"):
            break
        match = _EXPECT.match(line)
        assert match, f"{path.name}: bad header line {line!r}"
        found.append(match)
    assert found, f"{path.name}: first line must be '# expect: LINE:COL error: text'"
    return found


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_invalid_routine_reports_expected_error(path: Path) -> None:
    diags = validate_file(path)
    for match in _expectations(path):
        file = (CORPUS / match["file"]).resolve() if match["file"] else path.resolve()
        want = (int(match["line"]), int(match["col"]), match["msg"])
        found = [
            (d.origin.line, d.origin.column, d.message)
            for d in diags
            if d.is_error and d.origin is not None and Path(d.origin.file).resolve() == file
        ]
        assert any(
            (line, col) == want[:2] and want[2] in msg for line, col, msg in found
        ), f"expected {want} in {[d.format() for d in diags]}"
