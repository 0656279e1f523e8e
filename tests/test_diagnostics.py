"""Diagnostics: one line each, and each distinct problem once with a count."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from xgo_show.diagnostics import Diagnostic, Origin, at_most_each_kind, once_each


def _at(line: int, message: str, path: str = "tracks.rex") -> Diagnostic:
    return Diagnostic("error", message, Origin("a.yaml", line, 5, "rex: move"), path)


def test_the_same_problem_at_one_place_is_one_diagnostic_with_its_count() -> None:
    found = once_each([_at(8, "needs at least 0.59 s, given 0.05 s"),
                       _at(8, "needs at least 0.66 s, given 0.05 s"),
                       _at(8, "needs at least 0.59 s, given 0.05 s")])
    assert [d.message for d in found] == [
        "needs at least 0.59 s, given 0.05 s (met 3 times: this text is used again by a "
        "repeat, phrase, include or alias; the first is shown)"]


def test_identical_messages_say_only_the_count() -> None:
    [d] = once_each([_at(8, "no register 'x'", "tracks.rex[0]"), _at(8, "no register 'x'"),
                     *[_at(8, "no register 'x'", "tracks.max[2]")] * 2])
    assert d.message == ("no register 'x' (met 4 times: this text is used again by a repeat, "
                         "phrase, include or alias)")
    assert d.path == "tracks.rex[0], tracks.rex, tracks.max[2]"  # every way it was reached


def test_different_places_kinds_or_whole_numbers_stay_apart() -> None:
    diags = [_at(8, "driven by the cue at line 8"), _at(8, "driven by the cue at line 10"),
             _at(9, "driven by the cue at line 8"),
             Diagnostic("warning", "driven by the cue at line 8", _at(8, "").origin,
                        "tracks.rex")]
    assert once_each(diags) == diags


@given(st.lists(st.tuples(st.integers(1, 3), st.sampled_from(["a", "b"]),
                          st.floats(0, 10, allow_nan=False)), max_size=30))
def test_once_each_keeps_first_order_and_loses_no_place(
        raw: list[tuple[int, str, float]]) -> None:
    diags = [_at(line, f"{kind} at {t:.3f} s") for line, kind, t in raw]
    found = once_each(diags)
    keys = [(d.origin, d.message.split(" at ")[0]) for d in diags]
    assert [(d.origin, d.message.split(" at ")[0]) for d in found] == list(dict.fromkeys(keys))
    assert sum(int(d.message.split("met ")[1].split()[0]) if "(met" in d.message else 1
               for d in found) == len(diags)
    assert once_each(found) == found  # applying it again changes nothing


def test_at_most_each_kind_keeps_the_first_and_counts_the_rest() -> None:
    found = at_most_each_kind(
        [_at(i, f"the Mini has no register 'reg_{i}'; did you mean 'x{i}'?") for i in range(50)]
        + [_at(99, "body_z = 500 mm is out of range")], limit=5)
    assert [d.origin.line for d in found if d.origin] == [0, 1, 2, 3, 4, 5, 99]
    assert found[5].unlisted == 44 and found[5].count == 45
    assert found[5].message.endswith("(and 44 more like it, not listed)")
    assert sum(d.count for d in found) == 51


@given(st.lists(st.sampled_from(["no register 'a'", "no register 'b_c'", "value 3.5 too big",
                                 "value 7 too big", "unknown phrase 'p'"]), max_size=60),
       st.integers(1, 10))
def test_at_most_each_kind_never_loses_a_count(messages: list[str], limit: int) -> None:
    diags = [_at(i + 1, m) for i, m in enumerate(messages)]
    found = at_most_each_kind(diags, limit=limit)
    assert sum(d.count for d in found) == len(diags)
    assert len(found) <= 3 * (limit + 1)
