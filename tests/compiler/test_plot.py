"""The PNG plot: properties of the drawn figure a choreographer relies on (matplotlib is a test
dependency): the music grid, section names, one axis per unit, labels that never overprint,
curves from show start."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.image import imread

from xgo_show.choreo import load_show
from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show, plot_schedule
from xgo_show.compiler.plot import timeline_figure
from xgo_show.compiler.timeline import Timeline, build_timeline

ROUTINE = Path(__file__).parent / "data" / "timeline_show.yaml"


@pytest.fixture(scope="module")
def timeline() -> Timeline:
    return build_timeline(compile_show(load_show(ROUTINE)))


# Drawn afresh for each test (not once a module, as the timeline is): mutmut maps the
# drawing functions to the tests that call them, and a module fixture is drawn in the first
# test only.
@pytest.fixture
def figure(timeline: Timeline) -> Any:
    fig = timeline_figure(timeline)
    fig.canvas.draw()
    yield fig
    plt.close(fig)


def _by_label(fig: Any) -> dict[str, list[Any]]:
    axes: dict[str, list[Any]] = {}
    for ax in fig.axes:
        axes.setdefault(ax.get_ylabel(), []).append(ax)
    return axes


def test_one_axis_per_unit_named_by_its_unit(figure: Any) -> None:
    axes = _by_label(figure)
    # rex: mm (body_z) and deg (pitch); rio: m/s (vx); the arm's servos in degrees.
    assert len(axes["mm"]) == 1 and len(axes["m/s"]) == 1 and len(axes["deg"]) == 2
    legends = [[t.get_text() for t in ax.get_legend().get_texts()] for ax in axes["deg"]]
    assert legends == [["pitch"], ["1 gripper", "6 base"]]  # xArm servos by name


def test_bar_grid_and_section_names_on_top(figure: Any) -> None:
    header = _by_label(figure)["bar"][0]
    ticks = [t.get_text() for t in header.get_xticklabels()]
    assert ticks == [str(n) for n in range(1, 9)]  # 14 s at 120 bpm 4/4: bars 1..8 begin
    assert {t.get_text().strip() for t in header.texts} == {"intro", "verse"}
    verse = next(t for t in header.texts if t.get_text().strip() == "verse")
    assert verse.get_position()[0] == pytest.approx(6.0)  # bar 4
    for ax in figure.axes:  # the bar lines run through every axis, at the bar starts
        lines = next(c for c in ax.collections if c.get_gid() == "bar-lines")
        xs = sorted(round(seg[0][0], 6) for seg in lines.get_segments())
        assert xs == [0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0]


def test_labels_never_overprint(figure: Any) -> None:
    renderer = figure.canvas.get_renderer()
    labels = [t for ax in figure.axes for t in ax.texts if t.get_gid() == "label"]
    texts = {t.get_text().strip() for t in labels}
    assert {"stand_up (action 2)", "wave (action 13)", "gait=trot", "pace=slow",
            "pace=normal", "gait=walk"} <= texts
    boxes = [t.get_window_extent(renderer) for t in labels]
    for a, b in itertools.combinations(boxes, 2):
        assert not a.overlaps(b)
    for t, box in zip(labels, boxes, strict=True):  # inside its axes, left to right
        frame = t.axes.get_window_extent(renderer)
        assert frame.x0 - 1 <= box.x0 and box.x1 <= frame.x1 + 1, t.get_text()


def test_state_is_drawn_from_show_start(figure: Any) -> None:
    for unit in ("mm", "deg", "m/s"):
        for ax in _by_label(figure)[unit]:
            starts: dict[str, float] = {}  # per curve (colour): a solid or, where the value
            for line in ax.get_lines():  # is assumed (xArm before its first move), dotted line
                colour = str(line.get_color())
                starts[colour] = min(starts.get(colour, 1e9), min(line.get_xdata()))
            assert starts and set(starts.values()) == {0.0}
    body_z = _by_label(figure)["mm"][0].get_lines()[0]
    assert body_z.get_ydata()[0] == pytest.approx(97.5, abs=0.6)  # the Mini's initial height


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
    # Each performer's block has coloured lines: the axes, titles and grid alone are grey.
    image = imread(path)[:, :, :3]
    coloured = np.abs(image - image.mean(axis=2, keepdims=True)).max(axis=2) > 0.1
    assert all(band.sum() > 1000 for band in np.array_split(coloured, 3))


# -- the layout of labels and bar numbers, without drawing ------------------------------------


def test_label_rows_are_greedy_by_left_edge_and_the_first_row_free_is_taken() -> None:
    from xgo_show.compiler.plot import _rows, _text_width

    w = _text_width(" x")  # inches, as drawn (a space before it); one second an inch below
    # Three instants: the second starts where the first label ends (fits its row), the
    # third inside the second's label (a new row); a span longer than its label reaches on.
    items = [(0.0, 0.0, "x"), (w, w, "x"), (w + 0.01, w + 0.01, "x"), (5.0, 9.0, "x"),
             (8.0, 8.0, "x"), (9.0, 9.0, "x")]
    assert _rows(items, 1.0, 100.0) == [(0, False), (0, False), (1, False), (0, False),
                                        (1, False), (0, False)]
    # Given out of order: placed by left edge all the same.
    assert _rows(items[::-1], 1.0, 100.0) == [(0, False), (1, False), (0, False), (1, False),
                                              (0, False), (0, False)]
    # Two seconds an inch: the label is twice as long in seconds.
    assert _rows([(0.0, 0.0, "x"), (1.5 * w, 1.5 * w, "x")], 2.0, 100.0) == [(0, False),
                                                                             (1, False)]
    # A label that would run past the show's end ends at its start (right-aligned), and
    # takes the room left of it.
    assert _rows([(10.0 - w / 2, 10.0 - w / 2, "x"), (9.75, 9.75, "x")], 1.0, 10.0) == [
        (1, True), (0, False)]
    assert _rows([(10.0 - w, 10.0 - w, "x")], 1.0, 10.0) == [(0, False)]
    # A right-aligned label reaches only to its start: a short label just after that start
    # (ending before the show's end) shares its row.
    long = _text_width(" xxxxxxxxxx")
    assert _text_width(" ") < 0.4 * long
    assert _rows([(10.0 - 0.5 * long, 10.0 - 0.5 * long, "xxxxxxxxxx"),
                  (10.0 - 0.4 * long, 10.0 - 0.4 * long, "")], 1.0, 10.0) == [(0, True),
                                                                             (0, False)]
    assert _rows([], 1.0, 10.0) == []


def test_bar_numbers_are_labelled_every_power_of_two_bars_to_stay_apart() -> None:
    from xgo_show.compiler.plot import _label_step
    from xgo_show.compiler.timeline import Timeline

    def step(bar_seconds: float, bars: int, duration: float) -> int:
        grid = tuple((i * bar_seconds, i + 1) for i in range(bars))
        return _label_step(Timeline("t", duration, (), grid), min_inches=0.3)

    # 14 in x 0.76 of axes: 10.64 in for the show.
    assert step(2.0, 8, 14.0) == 1  # 1.52 in a bar
    assert step(2.0, 60, 120.0) == 2  # 0.177 in
    assert step(2.0, 151, 300.0) == 8  # 0.071 in: 0.142 at 2, 0.284 at 4 (< 0.3), 0.57 at 8
    assert step(2.0, 60, 211.0) == 4  # 0.1009 in: 0.3026 at 3 would do, but steps double
    assert step(2.0, 1, 2.0) == 1 and step(2.0, 0, 2.0) == 1
    # Exactly 0.3 in apart is far enough: 7.5 s bars in 266 s are 0.3 in, in 532 s 0.15.
    assert step(7.5, 35, 266.0) == 1 and step(7.5, 70, 532.0) == 2
    # Two bars are enough to measure: 0.1 s apart in 100 s is 0.0106 in, every 32nd.
    assert step(0.1, 2, 100.0) == 32
    # Bars measured from one another, not from the show's start (a pickup before bar 1).
    late = tuple((1.0 + 2.0 * i, i + 1) for i in range(60))
    assert _label_step(Timeline("t", 121.0, (), late), min_inches=0.3) == 2
