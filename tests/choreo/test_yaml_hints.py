"""An unquoted #RRGGBB is a YAML comment: the user is told at the '#' to quote it."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from xgo_show.choreo.source import parse_yaml
from xgo_show.choreo.yaml_hints import colour_comment_hints

colours = st.text("0123456789abcdefABCDEF", min_size=6, max_size=6).map(lambda s: "#" + s)


@given(colours)
def test_an_unquoted_colour_is_found_where_it_is(colour: str) -> None:
    block = f"led:\n  led1: {colour}\n  led2: blue\n"
    flow = f"- {{led: {{led1: {colour}}}, beats: 1}}\n- [{colour}, x]\n"
    assert [(d.origin.line, d.origin.column) for d in colour_comment_hints(block, "f")  # type: ignore[union-attr]
            ] == [(2, 9)]
    found = colour_comment_hints(flow, "f")
    assert [(d.origin.line, d.origin.column) for d in found] == [(1, 16)]  # type: ignore[union-attr]
    assert f"write '{colour}' (in quotes)" in found[0].message


@given(colours)
def test_quoted_colours_and_comments_are_left_alone(colour: str) -> None:
    text = (f"a: '{colour}'\nb: \"x {colour}\"\n# {colour} is orange\n"
            f"c: 1  # see {colour}\n  {colour}\nd: {colour}x\n")
    assert colour_comment_hints(text, "f") == []


def test_the_hint_comes_before_the_parser_error_it_causes() -> None:
    _, diags = parse_yaml("tracks:\n  rex:\n    - {led: {led1: #ff8800}, duration: 1}\n", "r.yaml")
    assert [d.format() for d in diags][0] == (
        "r.yaml:3:20: error: #ff8800 without quotes starts a YAML comment, so the colour is "
        "lost: write '#ff8800' (in quotes)")
    assert "YAML syntax" in diags[1].message
