"""Every number a routine sets has a stated range: the schema gives both bounds, docs/limits.md
names each limit, a value at a bound compiles and one just past it is one located error."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import xgo_show.limits as limits
from xgo_show.choreo import load_show, validate_file
from xgo_show.choreo.model import ShowFile
from xgo_show.compiler import compile_show

DOC = Path(__file__).parents[1] / "docs" / "limits.md"


def _numbers(node: object, path: str = "") -> list[tuple[str, dict[str, Any]]]:
    """Every number or integer node of a JSON schema, with where it is."""
    found: list[tuple[str, dict[str, Any]]] = []
    if isinstance(node, dict):
        if node.get("type") in ("number", "integer"):
            found.append((path, node))
        for key, value in node.items():
            found += _numbers(value, f"{path}/{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            found += _numbers(value, f"{path}[{i}]")
    return found


def test_every_number_in_a_routine_has_both_bounds() -> None:
    numbers = _numbers(ShowFile.model_json_schema())
    assert len(numbers) > 40
    for path, node in numbers:
        assert {"minimum", "exclusiveMinimum"} & set(node), path
        assert {"maximum", "exclusiveMaximum"} & set(node), path


def test_the_limits_page_names_every_limit() -> None:
    text = DOC.read_text(encoding="utf-8")
    for name in limits.__all__:
        assert f"`{name}`" in text or f"{name}`" in text, name
    for name in ("MAX_ROUTINE_BYTES", "MAX_SCHEDULE_BYTES", "MAX_NODES", "MAX_DEPTH",
                 "MAX_INT", "MAX_NESTING", "MAX_BLOCK_DEPTH", "MAX_CUES", "MAX_EACH_KIND",
                 "MAX_SUGGESTIONS", "MAX_SAMPLES"):
        assert name in text, name


# Each numeric setting: (where it goes, lowest, highest, smallest step past a bound).
SETTINGS: list[tuple[str, float, float]] = [
    ("settings.control_rate", limits.MIN_CONTROL_RATE, limits.MAX_CONTROL_RATE),
    ("settings.gap_ms", limits.MIN_GAP_MS, limits.MAX_GAP_MS),
    ("tempo.bpm", limits.MIN_BPM, limits.MAX_BPM),
    ("tempo.beats_per_bar", 1, limits.MAX_BEATS_PER_BAR),
    ("music.offset", limits.MIN_MUSIC_OFFSET, limits.MAX_MUSIC_OFFSET),
    ("cue.duration", 0, limits.MAX_SHOW_SECONDS),
    ("cue.beats", 0, limits.MAX_BEATS),
    ("limits.velocity", limits.MIN_LIMIT, limits.MAX_LIMIT),
    ("limits.jerk", limits.MIN_LIMIT, limits.MAX_LIMIT),
    ("repeat", 1, limits.MAX_REPEAT),
    ("rest", 0, limits.MAX_SHOW_SECONDS),
    ("periodic", 0, limits.MAX_SHOW_SECONDS),
]


def _routine(where: str, value: float) -> dict[str, Any]:
    """A valid one-robot routine with ``value`` at ``where`` (and a tempo for beats)."""
    cue: dict[str, Any] = {"move": {"body_z": 100}, "duration": 1}
    show: dict[str, Any] = {"show": "t", "tempo": {"bpm": 120},
                            "performers": {"rex": {"model": "mini"}}, "tracks": {"rex": [cue]}}
    area, _, name = where.partition(".")
    if area == "settings":
        show["settings"] = {name: value}
    elif area == "tempo":
        show["tempo"][name] = value
    elif area == "music":
        show["music"] = {"file": "a.wav", name: value}
    elif area == "cue":
        del cue["duration"]
        cue[name] = value
    elif area == "limits":
        del cue["duration"]
        cue["limits"] = {"body_z": {name: value}}
    elif area == "repeat":
        show["tracks"]["rex"] = [{"repeat": value, "cues": [{"rest": 0}]}, cue]
    elif area == "rest":
        show["tracks"]["rex"] = [{"rest": value}, cue]
    elif area == "periodic":
        show["tracks"]["rex"] = [{"periodic": {"roll": value}}, cue]
    return show


def _errors(tmp: Path, where: str, value: float) -> list[str]:
    path = tmp / "show.yaml"
    path.write_text(json.dumps(_routine(where, value)), encoding="utf-8")
    return [d.format() for d in validate_file(path) if d.is_error]


@pytest.mark.parametrize(("where", "low", "high"), SETTINGS, ids=[s[0] for s in SETTINGS])
def test_past_a_bound_is_one_error_at_its_place_with_the_range(
    tmp_path: Path, where: str, low: float, high: float
) -> None:
    name = where.rsplit(".", 1)[-1]
    for value, which in ((low - max(abs(low) * 1e-3, 1e-6), "too small"),
                         (high + max(abs(high) * 1e-3, 1), "too large")):
        if isinstance(low, int) and isinstance(high, int):
            value = int(value) if which == "too large" else int(low) - 1
        errors = _errors(tmp_path, where, value)
        assert len(errors) == 1, errors
        assert re.match(rf"^{re.escape(str(tmp_path))}/show.yaml:1:\d+: error: ", errors[0])
        assert which in errors[0] and (name in errors[0] or where in errors[0]), errors[0]


@pytest.mark.parametrize(("where", "low", "high"),
                         [s for s in SETTINGS if s[0] not in ("music.offset", "repeat")],
                         ids=[s[0] for s in SETTINGS if s[0] not in ("music.offset", "repeat")])
def test_a_value_at_a_bound_compiles(
    tmp_path: Path, where: str, low: float, high: float
) -> None:
    """At each bound the show loads and compiles (nothing overflows further in)."""
    for value in (low, high):
        path = tmp_path / "show.yaml"
        data = _routine(where, value)
        if where in ("cue.duration", "cue.beats", "rest", "periodic") and value:
            continue  # an hour-long cue compiles, but slowly: its bound is the show's length
        path.write_text(json.dumps(data), encoding="utf-8")
        errors = [d.format() for d in validate_file(path) if d.is_error]
        # A bound may still not suit this show (a second between frames does not carry 50 Hz;
        # 0.001 mm/s does not reach its target within the hour): then a located error that
        # says so, never an overflow further in.
        assert all(re.match(rf"^{re.escape(str(path))}:1:\d+: error: ", e) for e in errors)
        if not errors:
            compile_show(load_show(path))
        elif where in ("settings.control_rate", "tempo.bpm", "tempo.beats_per_bar"):
            pytest.fail(f"{where} = {value}: {errors}")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(SETTINGS), st.floats(allow_nan=True, allow_infinity=True)
       | st.integers(-(10**30), 10**30))
def test_any_number_anywhere_is_accepted_or_one_located_error(
    setting: tuple[str, float, float], value: float
) -> None:
    """Random numbers at and beyond each limit: nothing raises, and a refused value is one
    error at its line:col (JSON numbers past 2^53 and non-finite ones included)."""
    where, low, high = setting
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "show.yaml"
        text = json.dumps(_routine(where, 0.0)).replace("0.0", _json_number(value), 1)
        path.write_text(text, encoding="utf-8")
        errors = [d for d in validate_file(path) if d.is_error]
    inside = isinstance(value, (int, float)) and low <= value <= high
    if not inside:
        assert len(errors) == 1, [d.format() for d in errors]
        assert errors[0].origin is not None and errors[0].origin.line == 1


def _json_number(value: float) -> str:
    if isinstance(value, float) and value != value:
        return ".nan"
    if isinstance(value, float) and value in (float("inf"), float("-inf")):
        return ".inf" if value > 0 else "-.inf"
    return repr(value)
