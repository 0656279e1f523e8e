"""plot_schedule draws a PNG (matplotlib is a test dependency)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.image import imread

from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show, plot_schedule


def test_plot_writes_a_png(make_show, o, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    schedule = compile_show(make_show({
        "rex": ("mini", [
            SetCue(0.0, o("g"), {"gait": "walk"}),
            MotionCue(0.2, o("m"), {"body_z": 110.0, "pitch": 10.0}),
            ActionCue(2.0, o("a"), 23, "dance", 6.0),
        ]),
        "wheels": ("rider", [FadeCue(0.0, o("f"), "led1", (0, 200, 40), 1.0)]),
        "arm": ("xarm", [ArmCue(0.5, o("r"), {1: 500, 2: 300}, 1.0)]),
    }))
    path = plot_schedule(schedule, tmp_path / "show.png")
    assert path.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    # Each performer's panel (a third of the height) has coloured lines: the axes, titles and
    # grid alone are grey (the same schedule without frames gives no coloured pixel).
    image = imread(path)[:, :, :3]
    coloured = np.abs(image - image.mean(axis=2, keepdims=True)).max(axis=2) > 0.1
    assert all(band.sum() > 1000 for band in np.array_split(coloured, 3))
