"""Simulated robots that speak the real byte protocols, and a pseudo-terminal server for them.

:func:`create_robot` builds the simulator for a model name ("mini", "lite", "rider", "xarm");
:class:`~xgo_show.sim.pty_server.PtyServer` serves one on a real pseudo-terminal.
"""

from __future__ import annotations

from typing import Any

from xgo_show.profiles import get_profile
from xgo_show.sim.base import ReceivedFrame, SimulatedRobot
from xgo_show.sim.pty_server import PtyServer
from xgo_show.sim.xgo_robot import XgoRobot

__all__ = ["PtyServer", "ReceivedFrame", "SimulatedRobot", "XgoRobot", "create_robot"]


def create_robot(model: str, **options: Any) -> SimulatedRobot:
    """A simulated robot for ``model``; ``options`` go to the robot class.

    XGO models take :class:`XgoRobot` options (``battery``, ``drain_per_minute``, ``seed``,
    ``firmware``, …). An unknown model raises the profile error that lists the valid ones.
    """
    profile = get_profile(model)
    return XgoRobot(profile, **options)
