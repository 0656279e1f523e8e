"""The same routine compiles to the same bytes in any process: no set or dict order, hash seed,
or cache state leaks into the schedule (labels included)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# Shows that exercise fades, LEDs, phrases, includes, actions and several models.
SHOWS = ["rider_led_show.yaml", "mixed_five.yaml"]


def _compile(show: Path, out: Path, seed: str) -> bytes:
    subprocess.run(
        [sys.executable, "-m", "xgo_show", "compile", str(show), "-o", str(out)],
        check=True, capture_output=True, text=True, cwd=ROOT,
        env={"PYTHONHASHSEED": seed, "PATH": "/usr/bin:/bin"},
    )
    return out.read_bytes()


@pytest.mark.parametrize("name", SHOWS)
def test_compiled_file_is_identical_across_hash_seeds(name: str, tmp_path: Path) -> None:
    show = ROOT / "choreographies" / name
    first = _compile(show, tmp_path / "a.xshow.json", "1")
    second = _compile(show, tmp_path / "b.xshow.json", "999")
    assert first == second
