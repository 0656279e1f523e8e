"""Golden transcript of a small show: any change to the bytes on the wire shows up as a diff.

Regenerate only deliberately, after checking the diff:
    XGO_SHOW_REGEN_GOLDEN=1 pytest tests/compiler/test_golden.py
"""

from __future__ import annotations

import os
from pathlib import Path

from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show
from xgo_show.compiler.report import totals_table, transcript

GOLDEN = Path(__file__).parent / "golden" / "small_show.txt"


def test_small_show_transcript_matches_golden(make_show, o) -> None:  # type: ignore[no-untyped-def]
    show = make_show({
        "rex": ("mini", [
            SetCue(0.0, o("setup", 2), {"gait": "walk"}),
            MotionCue(0.2, o("crouch", 3), {"body_z": 90.0, "pitch": 8.0}, duration=0.6),
            MotionCue(0.8, o("rise", 4), {"body_z": 110.0, "roll": -6.0}),
            ActionCue(2.0, o("wave", 5), 13, "wave", 7.0),
            SetCue(9.0, o("walk", 6), {"vx": 10.0}),
            SetCue(9.5, o("stop", 6), {"vx": 0.0}),
        ]),
        "wheels": ("rider", [
            FadeCue(0.0, o("glow", 8), "led1", (255, 0, 0), 0.1),
            FadeCue(0.0, o("glow", 8), "led2", (0, 0, 255), 0.1),
            MotionCue(0.3, o("lean", 9), {"roll": 8.0}, duration=0.6),
        ]),
        "arm": ("xarm", [ArmCue(0.5, o("reach", 11), {1: 500, 2: 300, 3: 700}, 1.5)]),
    })
    text = totals_table(compile_show(show)) + transcript(compile_show(show))
    if os.environ.get("XGO_SHOW_REGEN_GOLDEN"):
        GOLDEN.write_text(text, encoding="utf-8")
    assert text == GOLDEN.read_text(encoding="utf-8")
