"""Relays as the behave tests' recording sessions answer them (tests/relay/recording.py): hall
(dog1, a Mini; dog2, a Lite) and yard (rio, a Rider), each with a clock of its own."""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from typing import Any

from tests.relay.recording import Answer, Query, answer

AHEAD = {"hall": 100.0, "yard": -50.0}  # each relay's clock against this process's


class Relays:
    """Answers as relays hall (dog1, a Mini; dog2, a Lite) and yard (rio, a Rider) would:
    each with its clock ``AHEAD``, refusing the ops in ``refuse``, silent once ``silent``;
    heartbeats answered with ``status`` (once, then an empty one)."""

    def __init__(self) -> None:
        self.robots: dict[str, list[dict[str, Any]]] = {
            "hall": [{"name": "dog1", "model": "mini"}, {"name": "dog2", "model": "lite"}],
            "yard": [{"name": "rio", "model": "rider"}],
        }
        self.refuse: dict[tuple[str, str], str] = {}
        self.silent: set[str] = set()
        self.status: dict[str, dict[str, Any]] = {}
        self.described: dict[str, dict[str, Any]] = {}  # a description given as is
        self.lock = threading.Lock()

    def __call__(self, q: Query) -> Sequence[Answer]:
        relay = q.key.split("/")[2]
        if relay in self.silent:
            return []
        now = time.monotonic() + AHEAD[relay]
        if (relay, q.op) in self.refuse:
            return [answer(q, relay=relay, relay_time=now, error=self.refuse[(relay, q.op)])]
        if q.op == "hello":
            description = self.described.get(relay,
                                             {"relay": relay, "robots": self.robots[relay]})
            return [answer(q, relay=relay, relay_time=now, description=description)]
        if q.op == "heartbeat":
            with self.lock:
                show = self.status.pop(relay, {})
            return [answer(q, relay=relay, relay_time=now, show=show)]
        return [answer(q, relay=relay, relay_time=now)]
