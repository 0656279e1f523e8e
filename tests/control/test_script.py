"""Trigger scripts: read with file:line:col errors, played by dry-run (virtual and real time)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from xgo_show.cli.main import main
from xgo_show.control.script import load_script, trigger_script_json_schema
from xgo_show.errors import ChoreographyError

ROOT = Path(__file__).resolve().parents[2]
CURTAIN = ROOT / "choreographies" / "curtain_call.yaml"
REHEARSAL = ROOT / "rehearsals" / "curtain_call.yaml"


def write(tmp_path: Path, text: str, name: str = "script.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_the_bundled_rehearsal_reads() -> None:
    script = load_script(REHEARSAL)
    assert [(c.trigger, c.at, c.after) for c in script.triggers] == [
        ("go", None, 1.5), ("encore", None, 0.5)
    ]


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        ("triggers:\n  - {trigger: go}\n", ":2:5:", "give one of 'at'"),
        ("triggers:\n  - {trigger: go, at: 1, after: 2}\n", ":2:5:", "give one of 'at'"),
        ("triggers:\n  - {trigger: go, at: -1}\n", ":2:23:", "-1 s is too small: give 0 s or more"),
        ("triggers:\n  - {triger: go, at: 1}\n", ":2:6:", "triger"),
        ("triggers: []\n", ":1:11:", "at least 1"),
        ("- {trigger: go, at: 1}\n", ":1:1:", "mapping"),
    ],
)
def test_a_bad_script_is_reported_at_its_place(
    tmp_path: Path, text: str, where: str, message: str
) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ChoreographyError) as info:
        load_script(path)
    lines = str(info.value).splitlines()
    assert lines[0] == f"{path}: not a trigger script:"
    assert any(line.startswith(f"{path}{where}") and message in line for line in lines[1:]), lines
    assert len(lines) == 1 + len(info.value.diagnostics) > 1


def test_every_problem_of_a_script_is_reported_on_its_own_line(tmp_path: Path) -> None:
    path = write(tmp_path, "triggers:\n  - {trigger: go}\n  - {trigger: '9', at: -1}\n")
    with pytest.raises(ChoreographyError) as info:
        load_script(path)
    lines = str(info.value).splitlines()[1:]
    assert len(lines) == len(info.value.diagnostics) >= 3
    assert all(line.startswith(f"{path}:") for line in lines), lines


def test_the_committed_schema_is_current() -> None:
    committed = json.loads((ROOT / "schemas" / "trigger-script.schema.json").read_text())
    assert committed == trigger_script_json_schema(), (
        "regenerate: python -m xgo_show.control.script > schemas/trigger-script.schema.json"
    )


def test_dry_run_fast_plays_the_script(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["dry-run", str(CURTAIN), "--fast", "--triggers", str(REHEARSAL)]) == 0
    out = capsys.readouterr().out
    # The script's timing, kept in virtual time: 'go' 1.5 s into the hold at bow (4 s),
    # 'encore' 0.5 s into the hold at encore (8 s of show, 9.5 s with the first hold).
    assert "trigger 'go' at 5.500 s: released section 'bow'" in out
    assert "trigger 'encore' at 10.000 s: released section 'encore'" in out
    assert "show completed" in out


def test_dry_run_fast_takes_the_timeout_of_a_wait_the_script_skips(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    script = write(tmp_path, "triggers:\n  - {trigger: go, after: 0}\n")
    log = tmp_path / "run.jsonl"
    assert main(["dry-run", str(CURTAIN), "--fast", "--triggers", str(script),
                 "--log", str(log)]) == 0
    assert "show completed" in capsys.readouterr().out


def test_a_show_that_waits_needs_a_script_and_a_script_needs_its_triggers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["dry-run", str(CURTAIN), "--fast"]) == 2
    err = capsys.readouterr().err
    assert "waits for trigger(s) go, encore: rehearse it with --triggers" in err
    typo = write(tmp_path, "triggers:\n  - {trigger: goo, after: 0}\n")
    assert main(["dry-run", str(CURTAIN), "--fast", "--triggers", str(typo)]) == 2
    assert "no trigger named goo; its triggers: go, encore" in capsys.readouterr().err
    hello = ROOT / "choreographies" / "hello_mini.yaml"
    assert main(["dry-run", str(hello), "--fast", "--triggers", str(REHEARSAL)]) == 2
    assert "no section of this show waits for a trigger" in capsys.readouterr().err


def test_a_wait_without_timeout_and_no_trigger_ends_in_a_safe_stop(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    script = write(tmp_path, "triggers:\n  - {trigger: encore, after: 0}\n")
    assert main(["dry-run", str(CURTAIN), "--fast", "--triggers", str(script)]) == 2
    captured = capsys.readouterr()
    assert "no trigger 'go' came for section 'bow'" in captured.out + captured.err
