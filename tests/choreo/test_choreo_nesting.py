"""A generated chain of includes, or of phrases playing phrases, is refused at the cue that
passes the limit, not at 1:1 when Python's recursion limit is hit."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.choreo import validate_file
from xgo_show.choreo.resolve import MAX_BLOCK_DEPTH, MAX_NESTING


@pytest.mark.parametrize("depth", [MAX_NESTING, MAX_NESTING + 1, 400])
def test_an_include_chain_is_cut_at_its_place(tmp_path: Path, depth: int) -> None:
    (tmp_path / "show.yaml").write_text("show: t\nperformers:\n  rex: {model: mini}\n"
                                        "tracks:\n  rex:\n    - {include: p0.yaml}\n")
    for i in range(depth):
        body = f"- {{include: p{i + 1}.yaml}}\n" if i < depth - 1 else "- {action: wave}\n"
        (tmp_path / f"p{i}.yaml").write_text(body)
    errors = [d for d in validate_file(tmp_path / "show.yaml") if d.is_error]
    if depth <= MAX_NESTING:
        assert errors == []
        return
    [err] = errors
    assert err.origin is not None and Path(err.origin.file).name == f"p{MAX_NESTING - 1}.yaml"
    assert (err.origin.line, err.origin.column) == (1, 13)
    assert f"includes nest more than {MAX_NESTING} deep" in err.message


def _phrase_chain(depth: int, kinds: str = "phrase") -> str:
    """A routine whose track plays p0, which plays p1, ... down to p``depth`` (a move); with
    ``kinds="mixed"`` every other link is a repeat around the next phrase."""
    out = ["show: chain", "performers: {rex: {model: mini}}", "phrases:"]
    for i in range(depth):
        call = f"{{phrase: p{i + 1}}}"
        if kinds == "mixed" and i % 2:
            call = f"{{repeat: 1, cues: [{call}]}}"
        out.append(f"  p{i}:\n    cues:\n      - {call}")
    out.append(f"  p{depth}:\n    cues:\n      - {{move: {{pitch: 5}}, duration: 1}}")
    out.append("tracks:\n  rex:\n    - phrase: p0")
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("depth", [MAX_BLOCK_DEPTH - 1, MAX_BLOCK_DEPTH, MAX_BLOCK_DEPTH + 1,
                                   250, 300, 1000, 3000])
def test_a_phrase_chain_is_cut_at_its_place(tmp_path: Path, depth: int) -> None:
    path = tmp_path / "show.yaml"
    path.write_text(_phrase_chain(depth))
    found = validate_file(path)
    if depth < MAX_BLOCK_DEPTH:  # the track's phrase is the first block: p0..p(depth) fit
        assert [d for d in found if d.is_error] == []
        return
    # Only the one error: no "nested too deeply" at 1:1, and the phrases below the cut are
    # not "never played" (they would have been).
    [err] = found
    assert err.origin is not None
    # p(N-1)'s cue plays the block past the limit: phrase p(k) is defined at line 4 + 3k.
    k = MAX_BLOCK_DEPTH - 1
    assert (err.origin.line, err.origin.column) == (4 + 3 * k + 2, 18)  # at "p{k + 1}"
    assert f"blocks nest more than {MAX_BLOCK_DEPTH} deep here" in err.message
    assert f"phrase p0 -> phrase p1 -> phrase p2 -> ... -> phrase p{k - 1} -> phrase p{k} -> " \
        f"phrase p{k + 1})" in err.message


def test_repeats_count_in_the_chain(tmp_path: Path) -> None:
    path = tmp_path / "show.yaml"
    path.write_text(_phrase_chain(MAX_BLOCK_DEPTH, "mixed"))  # twice as many blocks
    [err] = validate_file(path)
    assert "repeat -> phrase" in err.message and err.origin is not None
    assert err.origin.line > 4
