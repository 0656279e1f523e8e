"""Behaviours: declarative rules that make robots react to triggers, telemetry and time.

- :mod:`~xgo_show.behave.model`: the behaviour file (performers, routines, rules);
- :func:`load_behaviour`: load and check a file, compiling every routine it may play;
- :class:`~xgo_show.behave.engine.Engine`: decides what runs, on an injected clock;
- :mod:`~xgo_show.behave.rehearsal`: timed scripts of triggers and simulated telemetry.
"""

from __future__ import annotations

from xgo_show.behave.loader import Behaviour, check_behaviour, load_behaviour

__all__ = ["Behaviour", "check_behaviour", "load_behaviour"]
