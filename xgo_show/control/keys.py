"""The key expressions of the show-control API, all under one namespace (default ``xgo-show``).

=================================  ===========================================================
key                                what
=================================  ===========================================================
``NS/control/COMMAND``             queryable: ``load``, ``start``, ``stop``, ``pause``,
                                   ``resume``, ``seek``, ``panic`` (a reply, or an error reply)
``NS/status``                      queryable: what is loaded, state, show time, robots
``NS/trigger/NAME``                put (fire and forget) or get (with a reply): a trigger
``NS/event/KIND``                  published by the show: ``state``, ``cue``, ``wait``,
                                   ``trigger``, ``fault``, ``progress``, ``warning``
``NS/event/telemetry/ROBOT``       published: one robot's latest readings, about once a second
=================================  ===========================================================

docs/zenoh-api.md describes every payload.
"""

from __future__ import annotations

import re

from xgo_show.errors import UsageError

__all__ = [
    "COMMANDS",
    "EVENT_KINDS",
    "check_trigger_name",
    "control_key",
    "event_key",
    "is_trigger_name",
    "status_key",
    "telemetry_key",
    "trigger_key",
]

COMMANDS = ("load", "start", "stop", "pause", "resume", "seek", "panic")
EVENT_KINDS = ("state", "cue", "wait", "trigger", "fault", "progress", "warning", "telemetry")
_CHUNK = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]{0,63}$")


def control_key(ns: str, command: str = "*") -> str:
    """``NS/control/COMMAND`` (``*``: every command, for the server's queryable)."""
    return f"{ns}/control/{command}"


def status_key(ns: str) -> str:
    return f"{ns}/status"


def trigger_key(ns: str, name: str = "*") -> str:
    """``NS/trigger/NAME`` (``*``: every trigger, for the server's subscriber)."""
    return f"{ns}/trigger/{name}"


def event_key(ns: str, kind: str = "**") -> str:
    """``NS/event/KIND`` (``**``: every event, for a listener)."""
    return f"{ns}/event/{kind}"


def telemetry_key(ns: str, robot: str = "*") -> str:
    return f"{ns}/event/telemetry/{robot}"


def is_trigger_name(name: str) -> bool:
    """Whether ``name`` can be a trigger's name (one key chunk, like the language's names)."""
    return _CHUNK.fullmatch(name) is not None


def check_trigger_name(name: str) -> str:
    """``name`` if it can be a trigger's name (see :func:`is_trigger_name`)."""
    if not is_trigger_name(name):
        raise UsageError(
            f"trigger name {name!r}: use letters, digits, '_' and '-', starting with a letter "
            "or '_' (at most 64)"
        )
    return name
