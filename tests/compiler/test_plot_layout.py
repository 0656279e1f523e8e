"""The plot's figure read back from matplotlib on a hand-made timeline, to exact values: where
each axis sits (inches), what each says (texts, rows, alignment, sizes), the colours of the
LED strips and the cue marks, the curves' data and styles, the grid's lines and shading. No
image is compared (pixels change with matplotlib's version; these properties do not)."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import pytest
from matplotlib.colors import to_rgba

from xgo_show.compiler.plot import plot_schedule, timeline_figure
from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.compiler.timeline import Curve, Event, Lane, PerformerTimeline, Timeline
from xgo_show.errors import PlotError
from xgo_show.profiles import get_profile

REX = PerformerTimeline(
    "rex", "mini", "XGO Mini",
    lanes=(
        Lane("mm", (Curve("body_z", "mm", (0.0, 1.0, 2.0), (97.5, 100.0, 110.0), ramp=True),)),
        Lane("deg", (Curve("pitch", "deg", (0.0, 3.0, 5.0), (0.0, 5.0, -5.0), known_from=3.0),
                     Curve("roll", "deg", (0.0, 6.0), (1.0, 2.0)))),
    ),
    events=(Event(0.0, 0.5, "move", "servo 1"), Event(1.0, 4.0, "action", "wave (action 13)"),
            Event(2.0, 2.0, "setting", "gait=trot"), Event(7.9, 7.9, "setting", "pace=slow")),
    colours=(Event(0.0, 2.0, "colour", "", lane="led1", colour=(255, 0, 0)),
             Event(2.0, 4.0, "colour", "", lane="led1", colour=None),
             Event(1.0, 3.0, "colour", "", lane="led2", colour=(0, 51, 255))),
)
ARM = PerformerTimeline("arm", "xarm", "xArm", (), (), ())
DEMO = Timeline("Demo", 8.0, (REX, ARM), bars=((0.0, 1), (2.0, 2), (4.0, 3), (6.0, 4)),
                beats=(0.5, 1.0, 1.5, 2.5), sections=(("intro", 0.0, 4.0), ("verse", 4.0, 8.0)),
                tempo_text="120 bpm, 4/4")
# Heights in inches, top down: title 0.75, header 0.45, gap 0.35, two curve axes of 1.3, the
# cues' two rows (0.2 each + 0.1), two LED strips (0.18 each + 0.1), gap 0.35, the empty
# performer's 0.4, gap 0.35 and the foot's 0.5.
HEIGHT = 0.75 + 0.45 + 0.35 + 1.3 + 1.3 + 0.5 + 0.46 + 0.35 + 0.4 + 0.35 + 0.5


# Drawn afresh for each test (not once a module): mutmut maps the drawing functions to
# the tests that call them, and a module fixture is drawn in the first test only.
@pytest.fixture
def demo() -> Any:
    fig = timeline_figure(DEMO)
    yield fig
    plt.close(fig)


def _inches(fig: Any, ax: Any) -> list[float]:
    width, height = fig.get_size_inches()
    x, y, w, h = ax.get_position().bounds
    return [x * width, y * height, w * width, h * height]


def _texts(ax: Any) -> list[tuple[str, tuple[float, float], float, str]]:
    return [(t.get_text(), tuple(t.get_position()), t.get_fontsize(), t.get_ha())
            for t in ax.texts]


def test_the_axes_are_stacked_top_down_at_their_heights(demo: Any) -> None:
    assert list(demo.get_size_inches()) == pytest.approx([14.0, HEIGHT], abs=1e-9)
    # (bottom, height) of each axis in inches; all span 0.07 to 0.83 of the 14 inches.
    expected = [(5.51, 0.45), (3.86, 1.3), (2.56, 1.3), (2.06, 0.5), (1.6, 0.46), (0.85, 0.4)]
    assert len(demo.axes) == len(expected)
    for ax, (bottom, height) in zip(demo.axes, expected, strict=True):
        assert _inches(demo, ax) == pytest.approx([0.98, bottom, 10.64, height], abs=1e-9)
        assert ax.get_xlim() == (0.0, 8.0)
    # Each performer's name and title sits just above its first axis.
    titles = [(t.get_text(), t.get_position()[0], t.get_position()[1] * HEIGHT,
               t.get_fontsize(), t.get_weight(), t.get_va()) for t in demo.texts]
    assert titles[:2] == [("rex (XGO Mini)", 0.07, pytest.approx(5.21), 10.0, "bold", "bottom"),
                          ("arm (xArm)", 0.07, pytest.approx(1.30), 10.0, "bold", "bottom")]
    title = demo._suptitle
    assert title.get_text() == "Demo — 120 bpm, 4/4" and title.get_fontsize() == 12.0
    assert title.get_position() == pytest.approx((0.07, 1 - 0.1 / HEIGHT))
    assert (title.get_ha(), title.get_va()) == ("left", "top")
    # Only the last axis has the time axis' numbers and label.
    labelled = [ax.xaxis.get_tick_params()["labelbottom"] for ax in demo.axes]
    assert labelled == [False] * 5 + [True]
    assert [ax.get_xlabel() for ax in demo.axes] == [""] * 5 + ["show time (s)"]


def test_the_header_names_sections_and_numbers_bars(demo: Any) -> None:
    header = demo.axes[0]
    assert header.get_ylabel() == "bar" and header.get_ylim() == (0.0, 1.6)
    # "bar" level with the bar numbers, just left of the axis' top, written across.
    label = header.yaxis.label
    assert (label.get_fontsize(), label.get_rotation(), label.get_ha(), label.get_va()) == (
        7.0, 0.0, "right", "top")
    assert label.get_position() == (-0.005, 1.0)
    assert label.get_transform() == header.transAxes
    assert header.get_yticks().tolist() == []
    assert {side: s.get_visible() for side, s in header.spines.items()} == {
        "left": False, "right": False, "bottom": False, "top": True}
    assert _texts(header) == [(" intro", (0.0, 0.5), 8.0, "left"),
                              (" verse", (4.0, 0.5), 8.0, "left")]
    assert {(t.get_weight(), t.get_va(), t.get_gid()) for t in header.texts} == {
        ("bold", "center", "label")}  # labels: they take part in the overprint check
    # A coloured band under each section's name, at the foot of the header.
    bands = [(p.get_x(), p.get_width(), p.get_y(), p.get_height(), p.get_facecolor())
             for p in header.patches]
    assert bands == [
        (0.0, 4.0, 0.0, 0.12, pytest.approx(to_rgba("C0", 0.5))),
        (4.0, 4.0, 0.0, 0.12, pytest.approx(to_rgba("C1", 0.5))),
    ]
    assert header.get_xticks().tolist() == [0.0, 2.0, 4.0, 6.0]
    assert [t.get_text() for t in header.get_xticklabels()] == ["1", "2", "3", "4"]
    assert {t.get_fontsize() for t in header.get_xticklabels()} == {7.0}
    assert header.xaxis.get_ticks_position() == "top"


def test_bar_and_beat_lines_run_through_every_axis_and_odd_sections_are_shaded(demo: Any
                                                                              ) -> None:
    for i, ax in enumerate(demo.axes):
        beats, bars = ax.collections[-2:]
        assert [s[0][0] for s in beats.get_segments()] == [0.5, 1.0, 1.5, 2.5]
        assert beats.get_colors().tolist() == [list(to_rgba("0.85"))]
        assert beats.get_linewidths().tolist() == [0.4] and beats.get_zorder() == 0
        assert bars.get_gid() == "bar-lines"
        assert [s[0][0] for s in bars.get_segments()] == [0.0, 2.0, 4.0, 6.0]
        assert bars.get_colors().tolist() == [list(to_rgba("0.55"))]
        assert bars.get_linewidths().tolist() == [0.7]
        shades = [p for p in ax.patches if p.get_facecolor() == to_rgba("0.93")]
        if i == 0:  # the header is not shaded
            assert shades == []
        else:  # the second section (verse) is; the first is not
            assert [(p.get_x(), p.get_width(), p.get_zorder()) for p in shades] == [
                (4.0, 4.0, -1)]


def test_each_unit_has_an_axis_with_its_curves(demo: Any) -> None:
    mm, deg = demo.axes[1:3]
    assert (mm.get_ylabel(), deg.get_ylabel()) == ("mm", "deg")
    assert mm.yaxis.label.get_fontsize() == 9.0
    lines = [(ln.get_label(), ln.get_drawstyle(), ln.get_linestyle(), ln.get_linewidth(),
              list(ln.get_xdata()), list(ln.get_ydata())) for ln in deg.get_lines()]
    # pitch is known from 3 s on (solid, in steps), assumed before (dotted, its own colour).
    assert lines == [
        ("pitch", "steps-post", "-", 1.3, [3.0, 5.0], [5.0, -5.0]),
        ("_child1", "default", ":", 1.0, [0.0, 3.0], [0.0, 5.0]),
        ("roll", "steps-post", "-", 1.3, [0.0, 6.0], [1.0, 2.0]),
    ]
    pitch, assumed, roll = deg.get_lines()
    assert assumed.get_color() == pitch.get_color() != roll.get_color()
    (body_z,) = mm.get_lines()
    assert (body_z.get_drawstyle(), list(body_z.get_xdata()), list(body_z.get_ydata())) == (
        "default", [0.0, 1.0, 2.0], [97.5, 100.0, 110.0])  # a ramp: straight between points
    legend = deg.get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["pitch", "roll"]
    assert {t.get_fontsize() for t in legend.get_texts()} == {7.0}
    assert legend.get_frame_on() is False and legend._loc == 2  # upper left
    assert legend.borderaxespad == 0.0  # its top level with the axis' top
    assert tuple(legend.get_bbox_to_anchor().transformed(deg.transAxes.inverted()).p0) == \
        pytest.approx((1.005, 1.0))
    assert {t.get_fontsize() for t in deg.get_yticklabels()} == {7.0}


def test_cues_are_labelled_in_rows_with_their_marks(demo: Any) -> None:
    cues = demo.axes[3]
    assert cues.get_ylabel() == "cues" and cues.get_ylim() == (2.0, 0.0)
    assert cues.yaxis.label.get_fontsize() == 9.0 and cues.get_yticks().tolist() == []
    # "cues" written across, right of it against the axis, level with its middle.
    label = cues.yaxis.label
    assert (label.get_rotation(), label.get_ha(), label.get_va()) == (0.0, "right", "center")
    # The action's box spans its time; a setting's mark is a tick; the last label would run
    # past the end, so it ends at its time instead. The xArm move is not a cue label.
    assert _texts(cues) == [(" wave (action 13)", (1.0, 0.5), 7.0, "left"),
                            (" gait=trot", (2.0, 1.5), 7.0, "left"),
                            ("pace=slow ", (7.9, 0.5), 7.0, "right")]
    assert {t.get_va() for t in cues.texts} == {"center"}
    (box,) = [p for p in cues.patches if p.get_alpha() == 0.35]
    assert (box.get_x(), box.get_y(), box.get_width(), box.get_height()) == pytest.approx(
        (1.0, 0.1, 3.0, 0.8))
    assert box.get_facecolor() == pytest.approx(to_rgba("tab:orange", 0.35))
    assert box.get_linewidth() == 0.0
    marks = [(list(ln.get_xdata()), list(ln.get_ydata()), ln.get_marker(), ln.get_color(),
              ln.get_markersize()) for ln in cues.get_lines()]
    assert marks == [([2.0], [1.5], "|", "dimgrey", 6.0), ([7.9], [0.5], "|", "dimgrey", 6.0)]


def test_each_led_is_a_strip_of_its_colours(demo: Any) -> None:
    strips = demo.axes[4]
    assert strips.get_ylim() == (2.0, 0.0)
    assert strips.get_yticks().tolist() == [0.5, 1.5]
    assert [t.get_text() for t in strips.get_yticklabels()] == ["led1", "led2"]
    assert {t.get_fontsize() for t in strips.get_yticklabels()} == {7.0}
    led1, led2 = strips.collections[:2]
    # led1 is red for 2 s, then unknown (no bar); led2 blue-ish from 1 s to 3 s.
    assert [p.vertices[:, 0].min() for p in led1.get_paths()] == [0.0]
    assert [p.vertices[:, 0].max() for p in led1.get_paths()] == [2.0]
    assert [(p.vertices[:, 1].min(), p.vertices[:, 1].max()) for p in led1.get_paths()] == \
        [pytest.approx((0.1, 0.9))]
    assert [(p.vertices[:, 0].min(), p.vertices[:, 0].max(), p.vertices[:, 1].min())
            for p in led2.get_paths()] == [pytest.approx((1.0, 3.0, 1.1))]
    assert led1.get_facecolors().tolist() == [[1.0, 0.0, 0.0, 1.0]]
    assert led2.get_facecolors().tolist() == [pytest.approx([0.0, 0.2, 1.0, 1.0])]
    assert led1.get_linewidths().tolist() == [0.0]


def test_a_performer_without_frames_says_so(demo: Any) -> None:
    empty = demo.axes[5]
    assert empty.get_yticks().tolist() == []
    (text,) = empty.texts
    assert (text.get_text(), tuple(text.get_position()), text.get_fontsize(),
            text.get_va()) == ("no frames", (0.01, 0.5), 7.0, "center")
    assert text.get_transform() == empty.transAxes


def test_without_bars_or_sections_there_is_no_header() -> None:
    lone = Timeline("Lone", 4.0, (ARM,))
    fig = timeline_figure(lone)
    try:
        height = 0.75 + 0.4 + 0.35 * 2 + 0.5
        assert fig.get_size_inches().tolist() == pytest.approx([14.0, height])
        (ax,) = fig.axes
        # No gap above the first performer without a header: right under the title.
        assert _inches(fig, ax) == pytest.approx([0.98, height - 0.75 - 0.4, 10.64, 0.4])
        assert fig.texts[0].get_position()[1] * height == pytest.approx(height - 0.75 + 0.05)
        assert fig._suptitle.get_text() == "Lone"
        assert list(ax.collections) == []
    finally:
        plt.close(fig)
    # Bars without sections: the header's one row of room and the numbers.
    barred = Timeline("Barred", 4.0, (ARM,), bars=((0.0, 1), (2.0, 2)))
    fig = timeline_figure(barred)
    try:
        header = fig.axes[0]
        assert header.get_ylim() == (0.0, 1.6) and list(header.texts) == []
        assert [t.get_text() for t in header.get_xticklabels()] == ["1", "2"]
    finally:
        plt.close(fig)
    # Sections without bars: a header with the names and no bar numbers.
    named = Timeline("Named", 4.0, (ARM,), sections=(("a", 0.0, 2.0), ("b", 2.0, 4.0)))
    fig = timeline_figure(named)
    try:
        header = fig.axes[0]
        assert header.get_xticks().tolist() == [] and header.get_ylabel() == ""
        assert [t.get_text() for t in header.texts] == [" a", " b"]
    finally:
        plt.close(fig)


def test_section_names_that_would_overprint_take_rows() -> None:
    # Three names a tenth of a second apart in a 40 s show: each label is longer than that.
    crowded = Timeline("Crowded", 40.0, (ARM,),
                       sections=(("first", 0.0, 0.1), ("second", 0.1, 0.2), ("third", 0.2, 40.0)))
    fig = timeline_figure(crowded)
    try:
        header = fig.axes[0]
        assert [t.get_position()[1] for t in header.texts] == [0.5, 1.5, 2.5]
        assert header.get_ylim() == (0.0, 2 + 1.6)
        height = 0.75 + 0.45 + 0.2 * 2 + 0.35 + 0.4 + 0.35 + 0.5
        assert _inches(fig, header)[3] == pytest.approx(0.45 + 0.4)
        assert fig.get_size_inches().tolist() == pytest.approx([14.0, height])
    finally:
        plt.close(fig)


def test_bar_numbers_far_apart_are_each_labelled_and_close_ones_every_few() -> None:
    bars = tuple((2.0 * i, i + 1) for i in range(60))
    fig = timeline_figure(Timeline("Long", 120.0, (ARM,), bars=bars))
    try:
        labels = [t.get_text() for t in fig.axes[0].get_xticklabels()]
        assert labels == [str(n) for n in range(1, 61, 2)]  # 0.177 in a bar: every second
    finally:
        plt.close(fig)


def test_plot_schedule_writes_at_110_dpi_and_names_a_path_it_cannot_write(tmp_path: Path
                                                                          ) -> None:
    from matplotlib.image import imread

    mini = get_profile("mini")
    before = plt.get_fignums()
    schedule = Schedule("Empty", "show.yaml", (PerformerSchedule("rex", "mini", mini.link, (),
                                                                 1.0),), 50.0)
    path = plot_schedule(schedule, tmp_path / "a.png")
    assert path == tmp_path / "a.png"
    _, width = imread(path).shape[:2]
    assert width == 14 * 110
    assert plt.get_fignums() == before  # the figure is closed
    folder = tmp_path / "taken.png"
    folder.mkdir()
    with pytest.raises(PlotError) as err:
        plot_schedule(schedule, folder)
    assert str(err.value) == f"cannot write plot {folder}: Is a directory"
    assert plt.get_fignums() == before


def test_without_matplotlib_the_plot_says_how_to_get_it(monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    from xgo_show.compiler.plot import _pyplot

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(PlotError) as err:
        _pyplot()
    assert str(err.value) == ("plotting needs matplotlib: pip install 'xgo-show[plot]' (or pip "
                              "install matplotlib)")


def test_label_widths_are_measured_on_the_font_with_a_pad() -> None:
    from xgo_show.compiler.plot import _text_width

    _text_width.cache_clear()  # measured here, not remembered from another test
    assert _text_width("") == pytest.approx(4.0 / 72)  # the pad alone: 4 points
    fig = plt.figure(dpi=72)
    try:
        for text in ("wave (action 13)", "gait=trot", "W"):
            label = fig.text(0, 0, text, fontsize=7)
            fig.canvas.draw()
            points = label.get_window_extent().width  # at 72 dpi, one pixel a point
            assert _text_width(text) * 72 - 4 == pytest.approx(points, abs=2.5)
    finally:
        plt.close(fig)


def _overlaps(fig: Any) -> list[tuple[str, str]]:
    """Pairs of labels whose drawn boxes overlap, and labels outside their axes."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    labels = [t for ax in fig.axes for t in ax.texts if t.get_gid() == "label"]
    boxes = [t.get_window_extent(renderer) for t in labels]
    out = [(a.get_text(), b.get_text()) for i, (a, ba) in enumerate(zip(labels, boxes, strict=True))
           for b, bb in zip(labels[i + 1:], boxes[i + 1:], strict=True) if ba.overlaps(bb)]
    for t, box in zip(labels, boxes, strict=True):
        frame = t.axes.get_window_extent(renderer)
        if not (frame.x0 - 1 <= box.x0 and box.x1 <= frame.x1 + 1):
            out.append((t.get_text(), "outside"))
    return out


def test_section_names_are_measured_as_drawn_bold_and_never_overprint() -> None:
    # A section a little longer than its name at the cue labels' size, shorter than the name
    # as drawn (bold, a point larger, after a space): the next name takes the next row.
    from xgo_show.compiler.plot import _text_width

    name = "Wobbly Wombat Waltz"
    seconds_per_inch = 100.0 / (14 * 0.76)
    plain = _text_width(name) * seconds_per_inch
    drawn = _text_width(f" {name}", 8.0, "bold") * seconds_per_inch
    assert drawn > 1.25 * plain
    for length, row in ((1.1 * plain, 1.5), (0.97 * drawn, 1.5), (1.01 * drawn, 0.5)):
        fig = timeline_figure(Timeline("T", 100.0, (ARM,), sections=(
            (name, 0.0, length), ("Second", length, 100.0))))
        try:
            assert [t.get_position()[1] for t in fig.axes[0].texts] == [0.5, row], length
            assert _overlaps(fig) == []
        finally:
            plt.close(fig)


def test_a_section_name_past_the_end_ends_at_its_start() -> None:
    # The last section, 2 s of 300: its name would run past the end of the axes. Ending at
    # its start, it lies over the verse's band: a row of its own.
    fig = timeline_figure(Timeline("T", 300.0, (ARM,), sections=(
        ("verse", 0.0, 298.0), ("outro", 298.0, 300.0))))
    try:
        assert _texts(fig.axes[0]) == [(" verse", (0.0, 0.5), 8.0, "left"),
                                       ("outro ", (298.0, 1.5), 8.0, "right")]
        assert _overlaps(fig) == []
    finally:
        plt.close(fig)


def test_bars_without_sections_make_a_header_of_one_row() -> None:
    fig = timeline_figure(Timeline("Barred", 4.0, (ARM,), bars=((0.0, 1), (2.0, 2))))
    try:
        assert _inches(fig, fig.axes[0])[3] == pytest.approx(0.45)
        assert fig.get_size_inches().tolist() == pytest.approx(
            [14.0, 0.75 + 0.45 + 0.35 + 0.4 + 0.35 + 0.5])
    finally:
        plt.close(fig)


def test_a_performer_with_only_curves_cues_or_leds_has_only_those_axes() -> None:
    curves = PerformerTimeline("a", "mini", "XGO Mini", REX.lanes[:1], (), ())
    cues = PerformerTimeline("b", "mini", "XGO Mini", (), REX.events[1:3], ())
    leds = PerformerTimeline("c", "rider", "XGO Rider", (), (), REX.colours)
    fig = timeline_figure(Timeline("T", 8.0, (curves, cues, leds)))
    try:
        assert [ax.get_ylabel() for ax in fig.axes] == ["mm", "cues", ""]
        assert [t.get_text() for ax in fig.axes for t in ax.texts] == [
            " wave (action 13)", " gait=trot"]  # no "no frames" anywhere
        assert [t.get_text() for t in fig.axes[2].get_yticklabels()] == ["led1", "led2"]
    finally:
        plt.close(fig)


def test_grid_lines_run_from_the_foot_to_the_top_of_each_axis_behind_the_rest() -> None:
    # Three sections: only the second is shaded (every other one, from the second).
    timeline = dataclasses.replace(DEMO, sections=(("a", 0.0, 2.0), ("b", 2.0, 5.0),
                                                   ("c", 5.0, 8.0)))
    fig = timeline_figure(timeline)
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        for i, ax in enumerate(fig.axes):
            frame = ax.get_window_extent(renderer)
            beats, bars = ax.collections[-2:]
            for lines in (beats, bars):
                assert lines.get_zorder() == 0
                for seg in lines.get_segments():
                    (x0, y0), (x1, y1) = lines.get_transform().transform(seg)
                    assert x0 == x1 == pytest.approx(ax.transData.transform((seg[0][0], 0))[0])
                    assert (y0, y1) == pytest.approx((frame.y0, frame.y1))
            shades = [p for p in ax.patches if p.get_facecolor() == to_rgba("0.93")]
            expected = [] if i == 0 else [(2.0, 3.0, -1, 0.0)]
            assert [(p.get_x(), p.get_width(), p.get_zorder(), p.get_linewidth())
                    for p in shades] == expected
    finally:
        plt.close(fig)


def test_the_figure_does_not_follow_the_users_matplotlibrc() -> None:
    # Sizes the layout reckons with are set, not taken from rcParams.
    import matplotlib

    rc = {"font.size": 20.0, "figure.titlesize": 30.0, "lines.markersize": 2.0,
          "legend.borderaxespad": 3.0, "patch.linewidth": 3.0, "lines.linewidth": 4.0}
    with matplotlib.rc_context(rc):
        fig = timeline_figure(DEMO)
    try:
        assert {t.get_fontsize() for t in fig.texts if t is not fig._suptitle} == {10.0}
        assert fig._suptitle.get_fontsize() == 12.0
        marks = [ln.get_markersize() for ln in fig.axes[3].get_lines()]
        assert marks == [6.0, 6.0]
        assert fig.axes[2].get_legend().borderaxespad == 0.0
    finally:
        plt.close(fig)
