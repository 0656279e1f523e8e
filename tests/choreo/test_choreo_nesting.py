"""A generated chain of includes is refused at the include that passes the limit, not at 1:1."""

from __future__ import annotations

from pathlib import Path

import pytest

from xgo_show.choreo import validate_file
from xgo_show.choreo.resolve import MAX_NESTING


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
