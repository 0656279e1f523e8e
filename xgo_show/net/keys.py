"""The Zenoh key expressions of xgo-show, all under one namespace (default ``xgo-show``).

====================================  ========================================================
key                                   what
====================================  ========================================================
``NS/relay/NAME/alive``               liveliness token of a running relay
``NS/relay/NAME/info``                queryable: the relay's description (robots, holder)
``NS/relay/NAME/cmd``                 queryable: commands (see :mod:`xgo_show.net.messages`)
``NS/relay/NAME/time``                queryable: clock-sync exchanges (:mod:`xgo_show.net.timesync`)
====================================  ========================================================

A relay name is one key chunk: letters, digits, ``_``, ``-`` and ``.``.
"""

from __future__ import annotations

import re

from xgo_show.errors import NetworkError

__all__ = ["check_relay_name", "relay_key", "relay_wildcard"]

_NAME_RE = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


def check_relay_name(name: str) -> str:
    """``name`` if it can be a relay's name, else a :class:`NetworkError` saying why."""
    if not _NAME_RE.match(name):
        raise NetworkError(
            f"relay name {name!r}: use 1 to 64 letters, digits, '_', '-' or '.' (one key chunk)"
        )
    return name


def relay_key(namespace: str, relay: str, what: str) -> str:
    """``NS/relay/NAME/WHAT`` (``what``: ``alive``, ``info``, ``cmd`` or ``time``)."""
    return f"{namespace}/relay/{relay}/{what}"


def relay_wildcard(namespace: str, what: str) -> str:
    """The key expression of ``what`` for every relay: ``NS/relay/*/WHAT``."""
    return f"{namespace}/relay/*/{what}"
