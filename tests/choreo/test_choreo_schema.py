"""The committed JSON schema is current, and every shipped routine points editors at it."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
import yaml

from xgo_show.choreo import load_show
from xgo_show.choreo.model import PerformerModel
from xgo_show.choreo.schema import choreography_json_schema, choreography_part_json_schema
from xgo_show.profiles import MODELS

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = ROOT / "schemas" / "choreography.schema.json"
PART_SCHEMA = ROOT / "schemas" / "choreography-part.schema.json"
ROUTINES = sorted((ROOT / "choreographies").rglob("*.yaml"))


def is_routine(path: Path) -> bool:
    """A routine has a top-level ``show:``; anything else under choreographies/ is a part."""
    return any(line.startswith("show:") for line in path.read_text(encoding="utf-8").splitlines())


def test_committed_schemas_are_current() -> None:
    committed = json.loads(SCHEMA.read_text(encoding="utf-8"))
    assert committed == choreography_json_schema(), (
        "regenerate: python -m xgo_show.choreo.schema > schemas/choreography.schema.json"
    )
    part = json.loads(PART_SCHEMA.read_text(encoding="utf-8"))
    assert part == choreography_part_json_schema(), (
        "regenerate: python -m xgo_show.choreo.schema --part > "
        "schemas/choreography-part.schema.json"
    )


def test_schema_lists_every_cue_kind() -> None:
    text = json.dumps(choreography_json_schema())
    for kind in ("action", "move", "set", "walk", "periodic", "led", "gripper", "arm", "pose",
                 "pose_deg", "rest", "phrase", "repeat", "include"):
        assert f'"{kind}"' in text


def test_performer_models_match_the_profiles() -> None:
    annotation = PerformerModel.model_fields["model"].annotation
    assert set(annotation.__args__) == set(MODELS)  # type: ignore[union-attr]


def test_there_are_routines() -> None:
    assert ROUTINES


@pytest.mark.parametrize("path", ROUTINES, ids=lambda p: p.name)
def test_yaml_file_starts_with_schema_modeline(path: Path) -> None:
    first = path.read_text(encoding="utf-8").split("\n", 1)[0]
    schema = SCHEMA if is_routine(path) else PART_SCHEMA
    rel = Path(os.path.relpath(schema, path.parent)).as_posix()
    want = f"# yaml-language-server: $schema={rel}"
    assert first == want, f"{path.relative_to(ROOT)}: the first line must be {want!r}"


@pytest.mark.parametrize("path", [p for p in ROUTINES if is_routine(p)], ids=lambda p: p.name)
def test_routine_loads(path: Path) -> None:
    load_show(path)


DOC = ROOT / "docs" / "choreography.md"


def _doc_routines() -> list[str]:
    text = DOC.read_text(encoding="utf-8")
    blocks = [b.split("```", 1)[0] for b in text.split("```yaml\n")[1:]]
    return [b for b in blocks if "\nshow:" in f"\n{b}" and "tracks:" in b]


def test_docs_have_complete_examples() -> None:
    assert len(_doc_routines()) >= 2


@pytest.mark.parametrize("text", _doc_routines(), ids=lambda t: t.split("show:", 1)[1][:20])
def test_doc_examples_load(tmp_path: Path, text: str) -> None:
    path = tmp_path / "example.yaml"
    path.write_text(text, encoding="utf-8")
    load_show(path)


def test_doc_complete_example_is_the_shipped_solo() -> None:
    solo = (ROOT / "choreographies" / "solo_mini_120bpm.yaml").read_text(encoding="utf-8")
    example = _doc_routines()[-1]

    def code(text: str) -> list[str]:
        return [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]

    assert code(solo) == code(example)


STRUCTURAL = ["unknown_top_field", "unknown_cue_field", "cue_two_kinds", "cue_no_kind",
              "unknown_model", "negative_time", "string_for_number", "missing_tracks"]


@pytest.mark.parametrize("path", ROUTINES, ids=lambda p: p.name)
def test_schema_accepts_shipped_files(path: Path) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    schema = choreography_json_schema() if is_routine(path) else choreography_part_json_schema()
    errors = [e.message for e in jsonschema.Draft202012Validator(schema).iter_errors(data)]
    assert errors == []


@pytest.mark.parametrize("name", STRUCTURAL)
def test_schema_rejects_structural_mistakes(name: str) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    path = Path(__file__).parent / "invalid" / f"{name}.yaml"
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert not jsonschema.Draft202012Validator(choreography_json_schema()).is_valid(data)
