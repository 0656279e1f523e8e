"""Simulated robots that speak the real byte protocols, and a pseudo-terminal server for them.

:func:`create_robot` builds the simulator for a model name ("mini", "lite", "rider", "xarm");
:class:`~xgo_show.sim.pty_server.PtyServer` serves one on a real pseudo-terminal.
"""

from __future__ import annotations

import inspect
from typing import Any

from xgo_show.errors import ProfileError
from xgo_show.families import get_family
from xgo_show.profiles import get_profile
from xgo_show.sim.base import ReceivedFrame, SimulatedRobot
from xgo_show.sim.pty_server import PtyServer
from xgo_show.sim.xarm_robot import XarmRobot
from xgo_show.sim.xgo_robot import XgoRobot

__all__ = [
    "PtyServer",
    "ReceivedFrame",
    "SimulatedRobot",
    "XarmRobot",
    "XgoRobot",
    "create_robot",
]


def create_robot(model: str, **options: Any) -> SimulatedRobot:
    """A simulated robot for ``model``; ``options`` go to its family's simulator class.

    XGO models take :class:`XgoRobot` options (``battery``, ``drain_per_minute``, ``seed``,
    ``firmware``, …), the xArm :class:`XarmRobot` options (``battery_mv``,
    ``drain_mv_per_minute``, ``positions``). An unknown model raises the profile error that
    lists the valid ones; an unknown option raises :class:`ProfileError` naming it.
    """
    profile = get_profile(model)
    cls = get_family(profile).simulator_class()
    valid = [name for name in inspect.signature(cls).parameters if name != "profile"]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ProfileError(
            f"a simulated {profile.model} has no option {unknown[0]!r}; valid: {', '.join(valid)}"
        )
    return cls(profile, **options)
