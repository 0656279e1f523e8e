"""Helpers for compiler tests: hand-made resolved shows (no YAML loader involved)."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from hypothesis import settings

from xgo_show.choreo.resolved import Cue, ResolvedShow, ResolvedTrack
from xgo_show.diagnostics import Origin

ShowFactory = Callable[..., ResolvedShow]


def examples(n: int) -> int:
    """``n`` hypothesis examples, or a tenth of them (at least 10) under the "mutation" profile
    scripts/mutation.sh runs with: a mutant no test catches runs every test named for its
    function, each example under mutmut's tracing (the planner's fade group properties: tens of
    seconds a survivor at full count)."""
    return max(10, n // 10) if settings.get_current_profile_name() == "mutation" else n


def origin(cue: str, line: int = 1) -> Origin:
    return Origin("show.yaml", line, 5, cue)


@pytest.fixture
def make_show() -> ShowFactory:
    """``make_show({"rex": ("mini", [cues...])}, control_rate=..., ...)``."""

    def build(tracks: dict[str, tuple[str, list[Cue]]], **settings: object) -> ResolvedShow:
        resolved = tuple(
            ResolvedTrack(name, model, tuple(sorted(cues, key=lambda c: c.start)))
            for name, (model, cues) in tracks.items()
        )
        return ResolvedShow("test show", "show.yaml", resolved, **settings)  # type: ignore[arg-type]

    return build


@pytest.fixture
def o() -> Callable[..., Origin]:
    return origin
