"""The Zenoh key expressions of xgo-show, all under one namespace (default ``xgo-show``).

====================================  ========================================================
key                                   what
====================================  ========================================================
``NS/relay/NAME/alive``               liveliness token of a running relay
``NS/relay/NAME/info``                queryable: the relay's description (robots, holder)
``NS/relay/NAME/cmd``                 queryable: commands (see :mod:`xgo_show.net.messages`)
``NS/relay/NAME/time``                queryable: clock-sync exchanges (:mod:`xgo_show.net.timesync`)
====================================  ========================================================

A relay name is one key chunk: letters, digits, ``_``, ``-`` and ``.``. A robot behind a relay
is reached as ``zenoh:RELAY/ROBOT`` (:func:`parse_relay_url`), in ``--map`` and in a show file's
``port:`` alike.
"""

from __future__ import annotations

import re

from xgo_show.errors import NetworkError

__all__ = [
    "SCHEME",
    "check_relay_name",
    "is_relay_url",
    "parse_relay_url",
    "relay_key",
    "relay_name_chunk",
    "relay_wildcard",
]

#: The URL scheme of a robot behind a relay.
SCHEME = "zenoh"

_NAME_RE = re.compile(r"[A-Za-z0-9_.-]{1,64}")


def relay_name_chunk(text: str) -> str:
    """``text`` with each character a relay name cannot hold (anything but ASCII letters,
    digits, ``_``, ``-`` and ``.``) made a ``-``: a host name made part of a relay name."""
    return re.sub(r"[^A-Za-z0-9_.-]", "-", text)


def check_relay_name(name: str) -> str:
    """``name`` if it can be a relay's name, else a :class:`NetworkError` saying why."""
    if not _NAME_RE.fullmatch(name):
        raise NetworkError(
            f"relay name {name!r}: use 1 to 64 letters, digits, '_', '-' or '.' (one key chunk)"
        )
    return name


def is_relay_url(url: str) -> bool:
    """Whether ``url`` names a robot behind a relay (``zenoh:...``)."""
    return url.strip().partition(":")[0].lower() == SCHEME and ":" in url


def parse_relay_url(url: str, performer: str = "") -> tuple[str, str]:
    """``zenoh:RELAY/ROBOT`` -> ``(RELAY, ROBOT)``; ``zenoh:RELAY`` alone plays ``performer``
    on the relay's robot of the same name. A :class:`NetworkError` says what is wrong."""
    scheme, colon, rest = url.strip().partition(":")
    if scheme.lower() != SCHEME or not colon:
        raise NetworkError(f"{url!r} is not a zenoh:RELAY/ROBOT URL")
    relay, _, robot = rest.strip().strip("/").partition("/")
    if not relay:
        raise NetworkError(f"{url!r}: name the relay, e.g. zenoh:stage-left/{performer or 'rex'}")
    if not (robot or performer):
        raise NetworkError(f"{url!r}: name the robot too, e.g. zenoh:{relay}/rex")
    return check_relay_name(relay), check_relay_name(robot or performer)


def relay_key(namespace: str, relay: str, what: str) -> str:
    """``NS/relay/NAME/WHAT`` (``what``: ``alive``, ``info``, ``cmd`` or ``time``)."""
    return f"{namespace}/relay/{relay}/{what}"


def relay_wildcard(namespace: str, what: str) -> str:
    """The key expression of ``what`` for every relay: ``NS/relay/*/WHAT``."""
    return f"{namespace}/relay/*/{what}"
