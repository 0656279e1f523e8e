"""Helpers for compiler tests: hand-made resolved shows (no YAML loader involved)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from xgo_show.choreo.resolved import Cue, ResolvedShow, ResolvedTrack
from xgo_show.diagnostics import Origin

ShowFactory = Callable[..., ResolvedShow]


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
