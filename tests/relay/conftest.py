"""What the relay tests share beyond the relay processes themselves (``relays`` and
``conductor_session`` are in tests/conftest.py, for the control and behave tests too): a
holder's claim on a relay, a walking show, its upload text."""

from __future__ import annotations

import time
from collections.abc import Callable

import pytest
import zenoh

from tests.conftest import wait_until
from tests.loopback import free_port
from tests.relay.processes import RelayProcess
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import NetworkError
from xgo_show.profiles import get_profile
from xgo_show.relay.client import RelayClient, new_conductor
from xgo_show.relay.validate import schedule_digest


@pytest.fixture
def unused_port() -> int:
    return free_port()


def claim(
    session: zenoh.Session,
    relay: RelayProcess,
    name: str = "tester",
    *,
    beat: bool = True,
) -> RelayClient:
    """Hold ``relay`` as conductor ``name`` (heartbeats every 50 ms unless ``beat`` is false)."""
    client = RelayClient(session, relay.name, conductor=new_conductor(name))
    deadline = time.monotonic() + 5
    while True:
        try:
            client.hello()
            if beat:
                client.start_heartbeat(period=0.05, watchdog=0.3)
            return client
        except NetworkError as exc:
            # Unanswered: the session may still be connecting. A refusal is final.
            if "did not answer" not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def upload_text(schedule: Schedule) -> tuple[str, str]:
    text = schedule_to_bytes(schedule).decode("ascii")
    return text, schedule_digest(text)


@pytest.fixture
def as_upload() -> Callable[[Schedule], tuple[str, str]]:
    return upload_text


def wait_for(predicate: Callable[[], object], timeout: float = 5.0) -> float:
    """Poll until ``predicate()``; return the monotonic time it first held."""
    return wait_until(predicate, timeout)


@pytest.fixture
def until() -> Callable[..., float]:
    return wait_for


def walk_schedule(seconds: float = 1.0, **models: str) -> Schedule:
    """Each performer (name=model) walks forward at once, then sways body_z every 50 ms."""
    from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame
    from xgo_show.wire.xgo import write_frame

    parts = []
    for name, model in models.items():
        profile = get_profile(model)
        vx, body_z = profile.register("vx"), profile.register("body_z")
        wt = profile.write_type
        frames = [ScheduledFrame(0.0, write_frame(vx.address, vx.encode_value(0.1), write_type=wt))]
        frames += [
            ScheduledFrame(
                i * 0.05, write_frame(body_z.address, bytes((0x60 + i % 16,)), write_type=wt)
            )
            for i in range(1, int(seconds / 0.05))
        ]
        parts.append(PerformerSchedule(name, model, profile.link, tuple(frames), end=seconds))
    return Schedule("relay test", "test.yaml", tuple(parts), 20.0)


@pytest.fixture
def walk() -> Callable[..., Schedule]:
    return walk_schedule
