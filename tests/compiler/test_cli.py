"""``xgo-show compile`` and ``xgo-show inspect`` through the real entry point."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from xgo_show.cli.main import main
from xgo_show.compiler import load_schedule

DATA = Path(__file__).parent / "data"


@pytest.fixture
def show_file(tmp_path: Path) -> Path:
    target = tmp_path / "small_show.yaml"
    shutil.copy(DATA / "small_show.yaml", target)
    return target


def test_compile_writes_schedule_and_prints_totals(show_file: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out.xshow.json"
    assert main(["compile", str(show_file), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "performer" in printed and "rex" in printed and "wheels" in printed
    assert f"wrote {out}" in printed
    schedule = load_schedule(out)
    assert [p.name for p in schedule.performers] == ["rex", "wheels"]


def test_compile_default_output_name(show_file: Path) -> None:
    assert main(["compile", str(show_file), "-q"]) == 0
    assert (show_file.parent / "small_show.xshow.json").is_file()


def test_inspect_frames_is_deterministic_for_yaml_and_schedule(
    show_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out.xshow.json"
    assert main(["compile", str(show_file), "-o", str(out), "-q"]) == 0
    capsys.readouterr()
    assert main(["inspect", str(out), "--frames"]) == 0
    from_file = capsys.readouterr().out
    assert main(["inspect", str(show_file), "--frames"]) == 0
    from_yaml = capsys.readouterr().out
    assert from_file == from_yaml
    lines = from_file.splitlines()
    assert any(line.split()[:3] == ["0.000000", "rex", "gait=walk"] for line in lines)
    assert any("action=13(wave)" in line for line in lines)


def test_compile_errors_are_one_clear_message(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "show: Bad\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
        "    - {move: {body_z: 120}, duration: 0.1}\n",
        encoding="utf-8",
    )
    assert main(["compile", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml:6" in err and "Traceback" not in err


def test_inspect_bad_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    junk = tmp_path / "junk.xshow.json"
    junk.write_text("{}", encoding="utf-8")
    assert main(["inspect", str(junk)]) == 2
    assert "not an xgo-show schedule" in capsys.readouterr().err


def test_an_infeasible_move_in_a_repeat_is_reported_once_with_its_count(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    show = tmp_path / "rep.yaml"
    show.write_text("show: t\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
                    "    - repeat: 300\n      cues:\n        - move: {body_z: 110}\n"
                    "          duration: 0.05\n        - move: {body_z: 80}\n"
                    "          duration: 0.05\n")
    assert main(["compile", str(show), "-o", str(tmp_path / "o.xshow.json")]) == 2
    compiled = capsys.readouterr().err.splitlines()
    assert main(["validate", str(show)]) == 1
    validated = capsys.readouterr().out.splitlines()
    for lines in (compiled, validated):
        located = [ln for ln in lines if ": error: " in ln and ln.startswith(str(show))]
        assert [ln.split(": error:")[0] for ln in located] == [f"{show}:8:11", f"{show}:10:11"]
        assert all("needs at least" in ln and "(met 300 times:" in ln for ln in located)
    assert len(compiled) == 3 and compiled[-1].endswith("2 error(s)")
