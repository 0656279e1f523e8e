"""``xgo-show relay`` processes driven over Zenoh by a conductor in this process."""

from __future__ import annotations

import dataclasses
import signal
import time

import pytest

from tests.relay.conftest import claim
from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.errors import NetworkError
from xgo_show.relay.client import RelayClient
from xgo_show.wire.xgo import write_frame

LEAD = 0.3  # seconds between the start command and the start


def test_a_two_relay_show_arrives_complete_at_every_simulator(
    relays, conductor_session, walk, as_upload, until
) -> None:
    left, right = relays.start_many({"left": {"rex": "mini"},
                                     "right": {"lola": "lite", "rita": "rider"}})
    session = conductor_session(left, right)
    show = walk(0.6, rex="mini", lola="lite", rita="rider")
    clients = []
    for relay, names in ((left, ("rex",)), (right, ("lola", "rita"))):
        part = dataclasses.replace(
            show, performers=tuple(p for p in show.performers if p.name in names)
        )
        client = claim(session, relay)
        text, sha = as_upload(part)
        reply = client.upload(text, sha)
        assert reply["preflight_ok"], reply["preflight"]
        assert [row["performer"] for row in reply["preflight"]] == list(names)
        clients.append((client, sha))
    start = time.monotonic() + LEAD
    for client, sha in clients:
        client.start(sha, start + client.link.offset)
    for client, _ in clients:
        until(lambda c=client: c.command("heartbeat")["show"]["state"] == "ended", 5)
        last = client.command("heartbeat")["show"]["last"]
        assert last["completed"] and last["reason"] == "completed"
    for relay in (left, right):
        for perf in (p for p in show.performers if p.name in relay.servers):
            got = relay.received(perf.name)
            sent = [f.data for f in perf.frames]
            assert [d for d in got if d in sent] == sent  # every frame, in order, once


def test_a_second_conductor_is_refused_with_the_holders_name(relays, conductor_session) -> None:
    relay = relays.start("solo", {"rex": "mini"})
    session = conductor_session(relay)
    claim(session, relay, "alice@stage")
    with pytest.raises(NetworkError, match="held by conductor 'alice@stage'"):
        claim(session, relay, "bob@booth")
    from xgo_show.relay.client import list_relays

    (listed,) = list_relays(session, timeout=2.0)  # what `xgo-show relays` shows
    assert listed["holder"]["name"] == "alice@stage"
    other = RelayClient(session, relay.name)
    with pytest.raises(NetworkError, match="held by conductor 'alice@stage'"):
        other.command("stop", reason="bob wants it")


def test_a_schedule_with_an_unsafe_register_is_refused(
    relays, conductor_session, walk, as_upload
) -> None:
    relay = relays.start("strict", {"rex": "mini"})
    client = claim(conductor_session(relay), relay)
    show = walk(0.3, rex="mini")
    rex = show.performers[0]
    zero = ScheduledFrame(0.2, write_frame(0x21, b"\x01"))  # servo_zero: unsafe
    bad = dataclasses.replace(rex, frames=(*rex.frames[:2], zero))
    text, sha = as_upload(dataclasses.replace(show, performers=(bad,)))
    with pytest.raises(NetworkError, match=r"servo_zero.*without --allow-unsafe"):
        client.upload(text, sha)
    with pytest.raises(NetworkError, match="SHA-256"):
        client.upload(text, "0" * 64)
    with pytest.raises(NetworkError, match="not a robot of this relay"):
        text, sha = as_upload(walk(0.3, max="mini"))
        client.upload(text, sha)
    assert relay.proc.poll() is None  # refused, not crashed
    assert relay.received("rex")[-1] != zero.data


def test_timed_commands_that_would_act_late_are_refused(
    relays, conductor_session, walk, as_upload
) -> None:
    # A host that starts or pauses late plays on another frame than the others for the rest
    # of the show: the relay refuses, and the conductor's failure policy decides.
    relay = relays.start("punctual", {"rex": "mini"})
    client = claim(conductor_session(relay), relay)
    show = walk(2.0, rex="mini")
    text, sha = as_upload(show)
    client.upload(text, sha)
    with pytest.raises(NetworkError, match=r"the robots need 50 ms to be ready"):
        client.start(sha, time.monotonic() + client.link.offset + 0.01)
    sent = {f.data for f in show.performers[0].frames}
    assert not sent & set(relay.received("rex"))  # nothing moved (pre-flight only read)
    client.start(sha, time.monotonic() + client.link.offset + LEAD)
    with pytest.raises(NetworkError, match=r"pause: its time passed \d+\.\d ms before it arrived"):
        client.command("pause", at=time.monotonic() + client.link.offset - 0.05)
    assert client.command("stop", reason="test over")["stops"] == {"rex": True}


def test_malformed_commands_get_an_error_reply(relays, conductor_session) -> None:
    from xgo_show.net import messages as msg

    relay = relays.start("picky", {"rex": "mini"})
    session = conductor_session(relay)
    claim(session, relay)
    for payload in (b"\x00garbage", b'{"v": 1, "op": "start"}', b"{" * 70_000):
        replies = []
        for _ in range(3):
            replies = [
                r.ok
                for r in session.get("xgo-show/relay/picky/cmd", payload=payload, timeout=2)
                if r.ok
            ]
            if replies:
                break
        reply = msg.decode_reply(replies[0].payload.to_bytes())
        assert not reply.ok and reply.error
    assert relay.proc.poll() is None


@pytest.mark.parametrize("policy", ["stop", "continue"])
def test_a_silent_conductor_gets_the_link_loss_policy(
    relays, conductor_session, walk, as_upload, until, policy: str
) -> None:
    relay = relays.start("watched", {"rex": "mini"})
    client = claim(conductor_session(relay), relay)
    show = walk(1.5, rex="mini")
    text, sha = as_upload(show)
    client.upload(text, sha, link_loss=policy, watchdog_ms=300)
    client.start(sha, time.monotonic() + LEAD + client.link.offset)
    time.sleep(LEAD + 0.3)
    client.stop_heartbeat()
    silent_from = time.monotonic()
    if policy == "stop":
        stopped = until(lambda: relay.stop_times("rex"), 2.0)
        assert stopped - silent_from < 0.3 + 0.1  # watchdog + one check + the stop frames
        assert len(relay.received("rex")) < len(show.performers[0].frames) + 5
    else:
        time.sleep(1.5)
        assert not relay.stop_times("rex")
        sent = [f.data for f in show.performers[0].frames]
        assert [d for d in relay.received("rex") if d in sent] == sent


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGSTOP])
def test_a_killed_or_frozen_relay_is_noticed_within_the_watchdog(
    relays, conductor_session, walk, as_upload, until, sig: int
) -> None:
    relay = relays.start("fragile", {"rex": "mini"})
    client = claim(conductor_session(relay), relay, beat=False)
    lost: list[float] = []
    client.start_heartbeat(
        period=0.05, watchdog=0.3, on_lost=lambda s: lost.append(time.monotonic())
    )
    time.sleep(0.2)
    assert not lost
    relay.kill(sig)
    killed = time.monotonic()
    until(lambda: bool(lost), 2.0)
    # The last answer heard came up to a period (plus its own delay) before the signal.
    assert 0.3 - 2 * 0.05 < lost[0] - killed < 0.3 + 0.15
    client.stop_heartbeat()
