"""A behaviour on a robot behind a relay: the relay is its own OS process, its simulated Rider
on a real pty in this process (so the test can knock it over), Zenoh on 127.0.0.1 with
multicast scouting off and explicit endpoints.

One relay for the three checks, to keep the suite lean: a fall on the relayed robot fires the
stand-up rule (its routine's first frame reaches the robot, and its end comes back as a
``routine_ended`` trigger); the greet trigger plays on the relayed robot, and an LED action
beside it; the relay killed, its robot goes offline within the watchdog time and the rule for
that fires.
"""

from __future__ import annotations

import textwrap
import threading
import time
from collections.abc import Callable
from pathlib import Path

import zenoh

from tests.conftest import wait_until
from tests.relay.processes import Relays
from xgo_show.behave import load_behaviour
from xgo_show.behave.engine import BehaviourNote
from xgo_show.behave.ports import BehaviourRunner
from xgo_show.behave.relayed import RelayAccess
from xgo_show.relay.client import new_conductor
from xgo_show.runtime.events import Event, EventBus, TelemetryRead

WATCHDOG = 0.3


def _behaviour(folder: Path, port: str) -> Path:
    (folder / "get_up.yaml").write_text(textwrap.dedent("""\
        show: get up
        performers: {rio: {model: rider}}
        tracks:
          rio: [{move: {body_z: 80}, duration: 0.6}]
        """))
    (folder / "wave.yaml").write_text(textwrap.dedent("""\
        show: wave
        performers: {rio: {model: rider}}
        tracks:
          rio: [{move: {roll: 10}, duration: 0.6}]
        """))
    (folder / "b.yaml").write_text(textwrap.dedent(f"""\
        behaviour: relayed
        performers: {{rio: {{model: rider, port: "{port}"}}}}
        routines: {{get_up: get_up.yaml, wave: wave.yaml}}
        triggers: [visitor, red]
        rules:
          - {{name: fallen, safety: true, when: [{{tilt_beyond: 60}}], do: [{{play: get_up}}]}}
          - {{name: up, when: [{{routine_ended: get_up}}], do: [{{publish: up}}]}}
          - {{name: greet, when: [{{trigger: visitor}}], do: [{{play: wave}}]}}
          - {{name: red, when: [{{trigger: red}}], do: [{{led: {{all: red}}}}]}}
          - {{name: lost, when: [{{offline: 30}}], do: [{{publish: lost}}]}}
        """))
    return folder / "b.yaml"


def test_fall_greet_and_a_killed_relay(
    tmp_path: Path, relays: Relays, conductor_session: Callable[..., zenoh.Session]
) -> None:
    relay = relays.start("hall", {"rex": "rider"})
    behaviour = load_behaviour(_behaviour(tmp_path, "zenoh:hall/rex"))
    first = {name: s.performers[0].frames[0].data for name, s in behaviour.routines.items()}
    bus = EventBus()
    seen: list[Event] = []
    bus.subscribe(seen.append, TelemetryRead, BehaviourNote)
    session = conductor_session(relay)
    access = RelayAccess({"rio": "zenoh:hall/rex"}, session, new_conductor("test"),
                         watchdog=WATCHDOG)
    runner = BehaviourRunner(behaviour, {}, events=bus, relays=access)
    thread = threading.Thread(target=runner.run, kwargs={"duration": 20.0})
    thread.start()
    server = relay.servers["rex"]

    def fired(rule: str) -> list[BehaviourNote]:
        return [e for e in list(seen) if isinstance(e, BehaviourNote) and e.rule == rule
                and e.kind == "fired"]

    try:
        # The relay's readings reach the engine between routines.
        wait_until(lambda: any(isinstance(e, TelemetryRead) and e.name == "status"
                               for e in list(seen)), timeout=10.0)
        assert first["get_up"] not in relay.received("rex")
        with server.lock:
            server.robot.fall()  # type: ignore[attr-defined]
        wait_until(lambda: first["get_up"] in relay.received("rex"), timeout=3.0)
        assert fired("fallen")
        with server.lock:
            server.robot.recover()  # type: ignore[attr-defined]
        wait_until(lambda: fired("up"), timeout=3.0)  # the relay said get_up ran to its end
        runner.trigger("visitor")
        wait_until(lambda: first["wave"] in relay.received("rex"), timeout=3.0)
        assert fired("greet") and not fired("lost")
        runner.trigger("red")  # beside the wave, as a relay command of its own
        led = behaviour.writes["red.do[0]"].performers[0].frames[0].data
        wait_until(lambda: led in relay.received("rex"), timeout=3.0)
        relay.kill()
        killed = time.monotonic()
        wait_until(lambda: fired("lost"), timeout=3.0)
        # Offline within the watchdog time (and the engine's hop), not the rule's 30 s.
        assert time.monotonic() - killed < WATCHDOG + 1.0
        assert "relay hall lost" in fired("lost")[0].text
    finally:
        runner.stop()
        thread.join(10)
    assert not thread.is_alive()
