"""Zenoh session options: defaults that stay on this machine, Zenoh's own options and files."""

from __future__ import annotations

import argparse
import json
import socket
import time
from pathlib import Path

import pytest

from tests.loopback import free_port
from xgo_show.errors import NetworkError
from xgo_show.net.session import (
    DEFAULT_HUB,
    LOOPBACK_ANY,
    SessionOptions,
    add_session_arguments,
    build_config,
    open_session,
    session_options,
)


def get(config: object, key: str) -> object:
    return json.loads(config.get_json(key))  # type: ignore[attr-defined]


def test_defaults_listen_on_the_loopback_hub_or_join_it() -> None:
    first = build_config(SessionOptions(), hub_taken=False)
    assert get(first, "listen/endpoints") == [DEFAULT_HUB]
    assert get(first, "connect/endpoints") == []
    assert get(first, "scouting/multicast/enabled") is False
    later = build_config(SessionOptions(), hub_taken=True)
    assert get(later, "listen/endpoints") == [LOOPBACK_ANY]
    assert get(later, "connect/endpoints") == [DEFAULT_HUB]
    assert get(later, "connect/timeout_ms") == 2000


def test_the_options_replace_the_default_endpoints() -> None:
    parser = argparse.ArgumentParser()
    add_session_arguments(parser)
    args = parser.parse_args(
        ["--connect", "tcp/10.0.0.2:7447", "--listen", "tcp/0.0.0.0:7448", "--namespace", "acme/a"]
    )
    opts = session_options(args)
    config = build_config(opts)
    assert get(config, "connect/endpoints") == ["tcp/10.0.0.2:7447"]
    assert get(config, "listen/endpoints") == ["tcp/0.0.0.0:7448"]
    assert opts.namespace == "acme/a"


def test_a_config_file_is_used_and_multicast_stays_off_unless_it_says(tmp_path: Path) -> None:
    file = tmp_path / "z.json5"
    file.write_text('{mode: "client", connect: {endpoints: ["tcp/127.0.0.1:1"]}, // router\n}')
    config = build_config(SessionOptions(config_file=str(file)))
    assert get(config, "mode") == "client"
    assert get(config, "connect/endpoints") == ["tcp/127.0.0.1:1"]
    assert get(config, "scouting/multicast/enabled") is False
    file.write_text("{scouting: {multicast: {enabled: true}}}")
    assert get(build_config(SessionOptions(config_file=str(file))), "scouting/multicast/enabled")


@pytest.mark.parametrize(
    ("opts", "says"),
    [
        (SessionOptions(config_file="/nonexistent/z.json5"), "--zenoh-config /nonexistent"),
        (SessionOptions(connect=("carrier-pigeon/home",)), "Zenoh"),
    ],
)
def test_bad_options_are_one_line(opts: SessionOptions, says: str) -> None:
    with pytest.raises(NetworkError, match=says) as info:
        open_session(opts)
    assert "\n" not in str(info.value) and ".rs:" not in str(info.value)


def test_bad_config_file_and_namespace(tmp_path: Path) -> None:
    file = tmp_path / "z.json5"
    file.write_text("{mode: ")
    with pytest.raises(NetworkError, match="not a valid Zenoh config"):
        build_config(SessionOptions(config_file=str(file)))
    with pytest.raises(NetworkError, match="--namespace"):
        SessionOptions(namespace="a/*")


def test_a_client_that_reaches_no_router_fails_in_time(tmp_path: Path) -> None:
    file = tmp_path / "z.json5"
    file.write_text(f'{{mode: "client", connect: {{endpoints: ["tcp/127.0.0.1:{free_port()}"]}}}}')
    with pytest.raises(NetworkError, match="cannot open the Zenoh session"):
        open_session(SessionOptions(config_file=str(file), timeout=0.3))


def test_a_listen_on_a_taken_port_says_so(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(NetworkError) as info:
            open_session(SessionOptions(listen=(f"tcp/127.0.0.1:{port}",), timeout=0.3))
    assert str(info.value) == (
        f"cannot open the Zenoh session: Can not create a new TCP listener bound to "
        f"tcp/127.0.0.1:{port}: [127.0.0.1:{port}: Address already in use (os error 98)] "
        "(retried until the timeout)")


def test_two_sessions_on_explicit_loopback_endpoints_talk() -> None:
    port = free_port()
    a = open_session(SessionOptions(listen=(f"tcp/127.0.0.1:{port}",)))
    b = open_session(SessionOptions(connect=(f"tcp/127.0.0.1:{port}",)))
    try:
        a.declare_queryable("t/q", lambda q: q.reply(q.key_expr, b"pong"))
        replies: list[bytes] = []
        deadline = time.monotonic() + 5
        while not replies and time.monotonic() < deadline:
            time.sleep(0.02)  # the sessions may still be connecting
            replies = [r.ok.payload.to_bytes() for r in b.get("t/q", timeout=0.5) if r.ok]
        assert replies == [b"pong"]
    finally:
        b.close()
        a.close()
