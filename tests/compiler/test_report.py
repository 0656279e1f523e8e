"""report.py: the totals table and the transcript of a schedule made by hand (the golden test
covers a compiled show): which warnings are a performer's, times to the microsecond, column
alignment, the order of frames at the same microsecond, and the empty schedule.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from xgo_show.compiler.report import PerformerTotals, totals, totals_table, transcript
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.diagnostics import Diagnostic
from xgo_show.profiles.model import Link

LINK = Link(10_000, 0.001)  # 1 ms a byte


def _labels(data: bytes) -> str:
    return f"n={len(data)}"


def _frame(t: float, data: bytes) -> ScheduledFrame:
    return ScheduledFrame(t, data, labels=_labels)


def _schedule() -> Schedule:
    rex = PerformerSchedule("rex", "mini", LINK, (
        _frame(0.0, b"\x01\x02"), _frame(0.010001, b"\x03"), _frame(0.010001, b"\x04\x05\x06")),
        end=0.02)
    long_name = PerformerSchedule("wheels-long", "rider", LINK, (
        _frame(0.010001, b"\xaa"), _frame(12.5, b"\xbb" * 10)), end=20.0)
    warnings = tuple(Diagnostic("warning", "w", None, path) for path in (
        "tracks.rex", "tracks.rex[2].to.body_z", "tracks.rex.limits",
        "tracks.rexa[0]",  # another performer whose name starts with rex's
        "tracks.wheels-long[1]", "music", "tracks",
    ))
    return Schedule("s", "s.yaml", (rex, long_name), 50.0, warnings=warnings)


def test_totals_per_performer() -> None:
    # Link use: the bytes' wire time (1 ms each here) over the part's duration.
    got = totals(_schedule())
    assert [t.link_use for t in got] == pytest.approx([0.006 / 0.02, 0.011 / 20.0])
    assert [replace(t, link_use=0.0) for t in got] == [
        PerformerTotals("rex", "mini", 3, 6, 0.0, 0.02, 3),
        PerformerTotals("wheels-long", "rider", 2, 11, 0.0, 20.0, 1),
    ]


def test_totals_table_columns_are_aligned_names_left_numbers_right() -> None:
    assert totals_table(_schedule()) == (
        "performer    model  frames  bytes  link use  duration  warnings\n"
        "rex          mini        3      6    30.0 %   0.020 s         3\n"
        "wheels-long  rider       2     11     0.1 %  20.000 s         1\n"
    )


def test_transcript_in_time_order_then_performer_then_schedule_order() -> None:
    assert transcript(_schedule()) == (
        "    0.000000  rex          n=2  [01 02]\n"
        "    0.010001  rex          n=1  [03]\n"
        "    0.010001  rex          n=3  [04 05 06]\n"
        "    0.010001  wheels-long  n=1  [aa]\n"
        "   12.500000  wheels-long  n=10  [bb bb bb bb bb bb bb bb bb bb]\n"
    )


def test_an_empty_schedule_has_an_empty_transcript_and_a_header_only_table() -> None:
    empty = Schedule("s", "s.yaml", (), 50.0)
    assert transcript(empty) == ""
    assert totals_table(empty) == "performer  model  frames  bytes  link use  duration  warnings\n"
