"""A relayed performer's join (relay/performer.py) never waits past the timeout it is given:
it polls the show's end every 20 ms at most, each wait cut to what is left of the timeout.
Stated on the waits it asks for (a recording event), not by timing the join."""

from __future__ import annotations

import threading

from tests.relay.test_relay_show import Rig


class Waits(threading.Event):
    """The show's end, noting the timeout of every wait on it."""

    def __init__(self) -> None:
        super().__init__()
        self.asked: list[float | None] = []

    def wait(self, timeout: float | None = None) -> bool:
        self.asked.append(timeout)
        return super().wait(timeout)


def test_a_join_waits_no_longer_than_its_timeout_polling_every_20_ms_at_most() -> None:
    r = Rig()
    r.show.begin()
    try:
        rex = r.performers["rex"]
        rex.start(101.0)
        ended = Waits()
        r.show._ended = ended
        assert rex.join(0.005) is False  # shorter than a poll: one wait of what is left
        assert ended.asked != [] and all(w is not None and 0 < w <= 0.005 for w in ended.asked)
        ended.asked.clear()
        assert rex.join(0.1) is False
        assert len(ended.asked) >= 5 and all(w is not None and 0 < w <= 0.02
                                             for w in ended.asked)
    finally:
        r.close()
