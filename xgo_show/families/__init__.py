"""Robot families: one object per byte protocol, asked by every layer instead of branching.

:func:`get_family` takes a family name or a :class:`~xgo_show.profiles.model.Profile` and
returns its :class:`RobotFamily` (decoder, client, simulator, planner, stop and rest frames,
telemetry, pre-flight, state reconstruction). Built in: ``xgo``
(:mod:`xgo_show.families.xgo`: Mini, Lite, Rider) and ``xarm`` (:mod:`xgo_show.families.xarm`).
A new robot is a profile naming a new family plus one :func:`register_family` call. The values
some hooks return are in :mod:`xgo_show.families.values`.
"""

from __future__ import annotations

from xgo_show.families.base import Remerge, RobotFamily
from xgo_show.families.registry import (
    family_names,
    get_family,
    register_family,
    unregister_family,
)

__all__ = [
    "Remerge",
    "RobotFamily",
    "family_names",
    "get_family",
    "register_family",
    "unregister_family",
]
