"""The committed JSON schema is current, and every shipped routine points editors at it."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from xgo_show.choreo import load_show
from xgo_show.choreo.model import PerformerModel
from xgo_show.choreo.schema import choreography_json_schema
from xgo_show.profiles import MODELS

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = ROOT / "schemas" / "choreography.schema.json"
ROUTINES = sorted((ROOT / "choreographies").rglob("*.yaml"))


def test_committed_schema_is_current() -> None:
    committed = json.loads(SCHEMA.read_text(encoding="utf-8"))
    assert committed == choreography_json_schema(), (
        "regenerate: python -m xgo_show.choreo.schema > schemas/choreography.schema.json"
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
def test_routine_starts_with_schema_modeline(path: Path) -> None:
    first = path.read_text(encoding="utf-8").split("\n", 1)[0]
    rel = Path(os.path.relpath(SCHEMA, path.parent)).as_posix()
    assert first == f"# yaml-language-server: $schema={rel}"


@pytest.mark.parametrize("path", [p for p in ROUTINES if "parts" not in p.parts],
                         ids=lambda p: p.name)
def test_routine_loads(path: Path) -> None:
    load_show(path)
