"""``xgo-show validate``: every problem on its own line, a summary, exit status 1 on errors."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from xgo_show.cli.main import main
from xgo_show.diagnostics import MAX_EACH_KIND

from .conftest import WriteFn

GOOD = """
show: ok
performers:
  rex: {model: mini}
tracks:
  rex: [{action: stand_up}]
"""


def test_clean_file_exits_zero(write: WriteFn, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(GOOD)
    assert main(["validate", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"{path}: ok: 0 error(s), 0 warning(s)" in out


def test_errors_are_listed_and_exit_one(write: WriteFn, capsys: pytest.CaptureFixture[str]) -> None:
    bad = write("""
show: bad
performers:
  rex: {model: mini}
tracks:
  rex:
    - {move: {body_z: 500}, duration: 1}
    - {action: stand_upp}
""", "bad.yaml")
    good = write(GOOD, "good.yaml")
    assert main(["validate", str(bad), str(good)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"{bad}:6:23: error: tracks.rex[0].move.body_z: body_z = 500 mm")
    assert lines[1].startswith(f"{bad}:7:16: error: tracks.rex[1].action: ")
    assert lines[2] == f"{bad}: FAILED: 2 error(s), 0 warning(s)"
    assert lines[3] == f"{good}: ok: 0 error(s), 0 warning(s)"


def test_warnings_are_shown_but_do_not_fail(
    write: WriteFn, capsys: pytest.CaptureFixture[str]
) -> None:
    two = GOOD.replace("  rex: {model: mini}", "  rex: {model: mini}\n  idle: {model: lite}")
    path = write(two)
    assert main(["validate", str(path)]) == 0
    out = capsys.readouterr().out
    assert "warning: performers.idle: performer 'idle' has no track" in out
    assert main(["validate", "--quiet", str(path)]) == 0
    assert capsys.readouterr().out.splitlines() == [f"{path}: ok: 0 error(s), 1 warning(s)"]


def test_missing_file_and_directory_are_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["validate", str(tmp_path / "nope.yaml"), str(tmp_path)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out == [
        f"{tmp_path / 'nope.yaml'}:1:1: error: no such file",
        f"{tmp_path / 'nope.yaml'}: FAILED: 1 error(s), 0 warning(s)",
        f"{tmp_path}:1:1: error: is a directory",
        f"{tmp_path}: FAILED: 1 error(s), 0 warning(s)",
    ]


def test_syntax_error_is_reported_not_raised(
    write: WriteFn, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write("show: [\n")
    assert main(["validate", str(path)]) == 1
    assert "YAML syntax" in capsys.readouterr().out


def test_help_mentions_exit_status(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["validate", "--help"])
    assert "Exits 1" in capsys.readouterr().out


def test_a_part_included_twice_says_which_include(
    write: WriteFn, capsys: pytest.CaptureFixture[str]
) -> None:
    part = write("- {move: {pitch: 5}, duration: 1}\n- {move: {pitch: 99}, duration: 1}\n",
                 "parts/wave.yaml")
    show = write("""
show: two
performers:
  rex: {model: mini}
  ace: {model: mini}
tracks:
  rex: [{include: parts/wave.yaml}]
  ace: [{rest: 1}, {include: parts/wave.yaml}]
""")
    assert main(["validate", str(show)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[:1] == [
        f"{part}:2:18: error: tracks.rex[0] -> include parts/wave.yaml [1].move.pitch, "
        "tracks.ace[1] -> include parts/wave.yaml [1].move.pitch: "
        "pitch = 99 deg is out of range [-22, 22] deg (met 2 times: this text is used again "
        "by a repeat, phrase, include or alias)",
    ]  # the same place once, first in track order, naming the other include


_LINE = (r"^{name}:\d+:\d+: (?:error|warning): .+$"
         r"|^{name}: (?:ok|FAILED): \d+ error\(s\), \d+ warning\(s\)$")


def test_every_line_is_a_diagnostic_or_a_summary_whatever_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Missing files, directories, pipes, devices, symlink loops, binary and empty files: each
    is FILE:1:1: error: ... (or at the bad byte) and the file's summary line."""
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    loop = tmp_path / "loop.yaml"
    loop.symlink_to(loop)
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(bytes(range(256)) * 4)
    empty = tmp_path / "empty.yaml"
    empty.write_bytes(b"")
    files = [tmp_path / "nope.yaml", tmp_path, fifo, Path("/dev/zero"), loop, binary, empty]
    assert main(["validate", *map(str, files)]) == 1
    lines = capsys.readouterr().out.splitlines()
    for path in files:
        name = re.escape(str(path))
        mine = [ln for ln in lines if ln.startswith(f"{path}:")]
        assert len(mine) == 2, (path, lines)
        assert all(re.match(_LINE.format(name=name), ln) for ln in mine), mine
        assert mine[1] == f"{path}: FAILED: 1 error(s), 0 warning(s)"
    assert len(lines) == 2 * len(files)


def test_thousands_of_one_mistake_are_listed_twenty_times_and_counted(
    write: WriteFn, capsys: pytest.CaptureFixture[str]
) -> None:
    regs = "".join(f"        reg_{i}: 1\n" for i in range(3000))
    path = write(f"show: t\nperformers:\n  rex: {{model: mini}}\ntracks:\n  rex:\n"
                 f"    - set:\n{regs}    - {{move: {{body_z: 500}}, duration: 1}}\n")
    assert main(["validate", str(path)]) == 1
    lines = capsys.readouterr().out.splitlines()
    unknown = [ln for ln in lines if "has no register" in ln]
    assert len(unknown) == MAX_EACH_KIND + 1
    assert unknown[-1].endswith(f"(and {3000 - MAX_EACH_KIND - 1:,} more like it, not listed)")
    assert any("body_z = 500 mm is out of range" in ln for ln in lines)  # another kind
    assert lines[-1] == f"{path}: FAILED: 3001 error(s), 0 warning(s)"
