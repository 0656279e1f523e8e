"""OSC cues: python-osc's own encoding in, commands out; a real UDP server on 127.0.0.1."""

from __future__ import annotations

import queue

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
from pythonosc.osc_message_builder import OscMessageBuilder
from pythonosc.udp_client import SimpleUDPClient

from xgo_show.timecode.osc import Command, OscServer, parse_command, parse_packet


def _message(address: str, *args: object) -> bytes:
    builder = OscMessageBuilder(address)
    for arg in args:
        builder.add_arg(arg)
    return bytes(builder.build().dgram)


@settings(max_examples=200, deadline=None)
@given(
    kind=st.sampled_from(["go", "seek"]),
    value=st.floats(0, 1e6, allow_nan=False, width=32),
    prefix=st.sampled_from(["", "/xgo", "/stage/left"]),
)
def test_numbers_come_through(kind: str, value: float, prefix: str) -> None:
    (cmd,) = parse_packet(_message(f"{prefix}/{kind}", value), prefix)
    assert cmd == Command(kind, pytest.approx(value))


@settings(max_examples=100, deadline=None)
@given(bar=st.integers(1, 10_000))
def test_bars_are_whole_numbers(bar: int) -> None:
    assert parse_packet(_message("/bar", bar)) == [Command("bar", bar)]
    (reason,) = parse_packet(_message("/bar", bar + 0.5))
    assert isinstance(reason, str) and "bar number" in reason


def test_plain_commands_and_what_is_refused() -> None:
    for kind in ("go", "pause", "resume", "stop"):
        assert parse_command(f"/{kind}", []) == Command(kind)
    refused = {
        ("/pause", (1,)): "takes no arguments",
        ("/seek", ()): "one number",
        ("/seek", (-1.0,)): "one number",
        ("/seek", ("ten",)): "one number",
        ("/seek", (True,)): "one number",
        ("/jump", ()): "unknown OSC address '/jump'",
        ("/go/now", ()): "unknown OSC address",
        ("go", ()): "unknown OSC address",
    }
    for (address, args), says in refused.items():
        reason = parse_command(address, list(args))
        assert isinstance(reason, str) and says in reason, (address, reason)


def test_a_bundle_gives_its_commands_in_order() -> None:
    bundle = OscBundleBuilder(IMMEDIATELY)
    for address, args in [("/seek", [12.5]), ("/go", [])]:
        msg = OscMessageBuilder(address)
        for a in args:
            msg.add_arg(a)
        bundle.add_content(msg.build())
    assert parse_packet(bytes(bundle.build().dgram)) == [Command("seek", 12.5), Command("go")]


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=96))
@example(b"/\x80\x00\x00")  # an address that is not UTF-8: pythonosc raised UnicodeDecodeError
def test_any_datagram_is_commands_or_reasons_never_an_exception(data: bytes) -> None:
    for item in parse_packet(data):
        assert isinstance(item, (Command, str))


def test_a_real_udp_server_hears_a_sound_desk() -> None:
    heard: queue.Queue[Command | str] = queue.Queue()
    server = OscServer(heard.put, "127.0.0.1", 0, prefix="/xgo")
    try:
        desk = SimpleUDPClient("127.0.0.1", server.port)
        desk.send_message("/xgo/go", [])
        desk.send_message("/xgo/seek", 30.0)
        desk.send_message("/xgo/bogus", [])
        got = [heard.get(timeout=2) for _ in range(3)]
    finally:
        server.close()
    assert got[:2] == [Command("go"), Command("seek", 30.0)]
    assert isinstance(got[2], str) and "unknown OSC address" in got[2]
