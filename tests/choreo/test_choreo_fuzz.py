"""Random YAML-ish input never raises anything but ChoreographyError."""

from __future__ import annotations

import string
from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.choreo import load_show
from xgo_show.choreo.model import CUE_KINDS
from xgo_show.errors import ChoreographyError

KEYS = [*CUE_KINDS, "at", "after", "duration", "beats", "bars", "interrupt", "limits", "fade",
        "with", "cues", "pitch", "body_z", "vx", "led1", "all", "x", "z", "bar", "beat", "1"]
scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-300, 300), st.floats(allow_nan=True),
    st.sampled_from(["2.3", "$p", "-$p", "red", "#00ff00", "stand_up", "walk", "", "1:2"]),
    st.text(string.printable, max_size=8),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.dictionaries(st.sampled_from(KEYS), inner, max_size=4),
    ),
    max_leaves=20,
)
cue_lists = st.lists(st.dictionaries(st.sampled_from(KEYS), values, max_size=4), max_size=5)


def check(path: Path, text: str) -> None:
    path.write_text(text, encoding="utf-8")
    try:
        load_show(path)
    except ChoreographyError as exc:
        assert exc.diagnostics, "an error must carry diagnostics"


FUZZ = settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


@FUZZ
@given(cues=cue_lists, tempo=st.sampled_from([None, {"bpm": 120}, [{"bar": 1, "bpm": 90}]]),
       model=st.sampled_from(["mini", "lite", "rider", "xarm", "dog"]))
def test_structured_garbage(tmp_path: Path, cues: object, tempo: object, model: str) -> None:
    doc = {"show": "fuzz", "performers": {"p": {"model": model, "arm": True}},
           "phrases": {"ph": {"params": {"p": 5}, "cues": [{"move": {"pitch": "$p"}}]}},
           "tracks": {"p": cues}}
    if tempo is not None:
        doc["tempo"] = tempo
    check(tmp_path / "fuzz.yaml", yaml.safe_dump(doc))


@FUZZ
@given(text=st.text(alphabet=string.printable + "{}[]:-&*!|>'\"%@`\u00e9", max_size=200))
def test_raw_text(tmp_path: Path, text: str) -> None:
    check(tmp_path / "raw.yaml", text)
