"""Every command on every hostile file: exit code 2 (validate: 1, as documented), one located
error per problem, no traceback, within a time limit and a memory cap.

The routines are in ``hostile/`` (each names the ``LINE:COL`` and text of the error it must
produce); a named pipe and a symlink loop are made here, and the hand-edited schedules are
typed :class:`Schedule` objects saved with :func:`save_schedule`, so they follow the schedule
file format whatever its encoding. All calls run in one child process
(``hostile_driver.py``): a CPU-time limit bounds each call (and a longer wall-clock alarm one
that blocks), an address-space limit the memory.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from xgo_show.choreo.resolved import ActionCue, MotionCue, ResolvedShow, ResolvedTrack, SetCue
from xgo_show.compiler import compile_show, save_schedule
from xgo_show.compiler.schedule import Schedule
from xgo_show.diagnostics import Origin

HERE = Path(__file__).parent
CORPUS = HERE / "hostile"
ROUTINES = sorted(CORPUS.glob("*.yaml"))
_EXPECT = re.compile(r"^# expect: (\d+):(\d+) (.+)$")
_RAW_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f\x9b]")


def _schedule() -> Schedule:
    o = Origin("show.yaml", 3, 5, "rex: cue")
    show = ResolvedShow("t", "show.yaml", (ResolvedTrack("rex", "mini", (
        SetCue(0.0, o, {"gait": "walk"}),
        MotionCue(0.5, o, {"body_z": 90.0}, duration=1.0),
        ActionCue(2.0, o, 23, "dance", 6.0),
    )),), bpm=120.0)
    return compile_show(show)


def _perf(s: Schedule, **changes: Any) -> Schedule:
    return dataclasses.replace(s, performers=(dataclasses.replace(s.performers[0], **changes),))


SCHEDULES: dict[str, Callable[[Schedule], Schedule]] = {
    "negative_tempo": lambda s: dataclasses.replace(s, bpm=-120.0),
    "zero_tempo": lambda s: dataclasses.replace(s, bpm=0.0),
    "zero_beats_per_bar": lambda s: dataclasses.replace(s, beats_per_bar=0),
    "nan_rate": lambda s: dataclasses.replace(s, control_rate=math.nan),
    "end_before_frames": lambda s: _perf(s, end=0.25),
    "duplicate_performer": lambda s: dataclasses.replace(s, performers=s.performers * 2),
    "escape_in_name": lambda s: dataclasses.replace(s, name="\x1b[31mshow"),
    "repeated_tempo_bar": lambda s: dataclasses.replace(
        s, tempo_map=((1, 120.0, 4), (1, 90.0, 4))),
    "too_many_performers": lambda s: dataclasses.replace(s, performers=tuple(
        dataclasses.replace(s.performers[0], name=f"r{i}") for i in range(65))),
}


# Paths that are not a routine at all, named to every command: each is one located error.
ODD = ["missing.yaml", "folder.yaml", "pipe.yaml", "loop.yaml", "binary.yaml", "/dev/zero"]


def _corpus(tmp: Path) -> tuple[list[Path], list[Path], list[Path]]:
    folder = tmp / "hostile"
    shutil.copytree(CORPUS, folder)
    os.mkfifo(folder / "pipe.yaml")
    (folder / "loop.yaml").symlink_to(folder / "loop.yaml")
    (folder / "folder.yaml").mkdir()
    (folder / "binary.yaml").write_bytes(bytes(range(256)))
    routines = [folder / p.name for p in ROUTINES]
    base = _schedule()
    schedules = [save_schedule(change(base), folder / f"{name}.xshow.json")
                 for name, change in SCHEDULES.items()]
    return routines, schedules, [folder / name for name in ODD]


COMMANDS: dict[str, list[str]] = {
    "validate": ["validate", "{file}"],
    "compile": ["compile", "{file}", "-o", "{out}"],
    "inspect": ["inspect", "{file}", "--frames"],
    "run": ["run", "{file}"],
    "dry-run": ["dry-run", "{file}", "--fast"],
}


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, str], dict[str, Any]]:
    tmp = tmp_path_factory.mktemp("hostile")
    routines, schedules, odd = _corpus(tmp)
    calls = []
    for path in [*routines, *schedules, *odd]:
        for command, args in COMMANDS.items():
            out = str(tmp / f"{path.stem}.{command}.xshow.json")
            calls.append([a.format(file=path, out=out) for a in args])
    proc = subprocess.run(
        [sys.executable, str(HERE / "hostile_driver.py")],
        input="".join(json.dumps(c) + "\n" for c in calls), capture_output=True, text=True,
        timeout=600, check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    found = {}
    for line in proc.stdout.splitlines():
        row = json.loads(line)
        found[(Path(row["argv"][1]).name, row["argv"][0])] = row
    assert len(found) == len(calls)
    return found


def _expectations(path: Path) -> list[tuple[int, int, str]]:
    out = []
    for line in path.read_text(encoding="utf-8", errors="replace").split("\n"):
        match = _EXPECT.match(line)
        if not match:
            break
        out.append((int(match[1]), int(match[2]), match[3]))
    return out


def test_every_routine_names_its_error() -> None:
    assert len(ROUTINES) >= 20
    for path in ROUTINES:
        assert _expectations(path), f"{path.name}: first line must be '# expect: L:C text'"


def _check_common(row: dict[str, Any]) -> str:
    assert row["escaped"] == "", row["escaped"]
    text = row["out"] + row["err"]
    assert "Traceback" not in text
    assert not _RAW_CONTROL.search(text), repr(text[:300])
    assert row["cpu_seconds"] < 10  # of CPU: the wall clock depends on the machine's load
    return str(text)


@pytest.mark.parametrize("command", list(COMMANDS))
@pytest.mark.parametrize("path", ROUTINES, ids=lambda p: p.stem)
def test_hostile_routine(results: dict[tuple[str, str], dict[str, Any]], path: Path,
                         command: str) -> None:
    row = results[(path.name, command)]
    text = _check_common(row)
    assert row["code"] == (1 if command == "validate" else 2), text
    name = re.escape(row["argv"][1])
    line_ok = re.compile(rf"^(?:{name}:\d+:\d+: (?:error|warning): .+|xgo-show: error: .+|"
                         rf"{name}: (?:FAILED|ok): .+|\S+:\d+:\d+: (?:error|warning): .+)$")
    lines = [ln for ln in text.splitlines() if ln]
    assert lines and all(line_ok.match(ln) for ln in lines), text
    for line, col, what in _expectations(path):
        assert any(ln.startswith(f"{row['argv'][1]}:{line}:{col}: error: ") and what in ln
                   for ln in lines), f"{line}:{col} {what!r} not in:\n{text}"


@pytest.mark.parametrize("command", list(COMMANDS))
@pytest.mark.parametrize("name", list(SCHEDULES))
def test_hand_edited_schedule(results: dict[tuple[str, str], dict[str, Any]], name: str,
                              command: str) -> None:
    row = results[(f"{name}.xshow.json", command)]
    text = _check_common(row)
    lines = [ln for ln in text.splitlines() if ln]
    if command == "validate":  # documented: exit 1, "FILE:1:1: error: is a compiled schedule"
        path = row["argv"][1]
        assert row["code"] == 1 and lines[0].startswith(f"{path}:1:1: error: ") and (
            "compiled schedule" in lines[0]), text
        assert lines[1:] == [f"{path}: FAILED: 1 error(s), 0 warning(s)"], text
        return
    assert row["code"] == 2, text
    assert len(lines) == 1 and lines[0].startswith("xgo-show: error: "), text


@pytest.mark.parametrize("command", list(COMMANDS))
@pytest.mark.parametrize("name", ODD)
def test_a_path_that_is_no_routine(results: dict[tuple[str, str], dict[str, Any]], name: str,
                                   command: str) -> None:
    row = results[(Path(name).name, command)]
    text = _check_common(row)
    lines = [ln for ln in text.splitlines() if ln]
    path = row["argv"][1]
    if command == "validate":  # a diagnostic at the file's start (or its bad byte), a summary
        assert row["code"] == 1, text
        assert re.match(rf"^{re.escape(path)}:\d+:\d+: error: \S", lines[0]), text
        assert lines[1:] == [f"{path}: FAILED: 1 error(s), 0 warning(s)"], text
        return
    assert row["code"] == 2, text
    assert lines[-1].startswith("xgo-show: error: ") and path in text, text
