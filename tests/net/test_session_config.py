"""What a Zenoh session is opened with (net/session.py), in this process and without opening
one: the options' defaults and refusals, the command-line options, every rule of
:func:`build_config` (defaults on loopback, options and files replacing them, multicast and
timeouts, the relay child's extra endpoints) and :func:`open_session`'s retry and one-line
errors over a recording ``zenoh.open``. test_session.py opens real sessions."""

from __future__ import annotations

import argparse
import json
import math
import socket
from pathlib import Path
from typing import Any

import pytest
import zenoh

from tests.loopback import free_port
from xgo_show.errors import NetworkError
from xgo_show.net import session as zs
from xgo_show.net.session import (
    DEFAULT_HUB,
    DEFAULT_NAMESPACE,
    DEFAULT_PORT,
    LOOPBACK_ANY,
    SessionOptions,
    add_session_arguments,
    build_config,
    open_session,
    session_options,
)


def get(config: zenoh.Config, key: str) -> Any:
    return json.loads(config.get_json(key))


def test_the_defaults_are_the_loopback_hub_and_the_xgo_show_namespace() -> None:
    assert (DEFAULT_NAMESPACE, DEFAULT_PORT, DEFAULT_HUB, LOOPBACK_ANY) == (
        "xgo-show", 7447, "tcp/127.0.0.1:7447", "tcp/127.0.0.1:0")
    opts = SessionOptions()
    assert (opts.connect, opts.listen, opts.config_file, opts.namespace, opts.timeout,
            opts.also_connect) == ((), (), None, "xgo-show", 2.0, ())


@pytest.mark.parametrize("namespace", ["acme", "acme/show-1", "a.b_c/d/e"])
def test_a_namespace_is_words_between_slashes(namespace: str) -> None:
    assert SessionOptions(namespace=namespace).namespace == namespace


@pytest.mark.parametrize("namespace", ["", "a/*", "/a", "a/", "a//b", "a b", "acme\n", "**"])
def test_any_other_namespace_is_refused_saying_what_it_may_hold(namespace: str) -> None:
    with pytest.raises(NetworkError) as info:
        SessionOptions(namespace=namespace)
    assert str(info.value) == (f"--namespace {namespace!r}: use letters, digits, '_', '-', '.' "
                               "and '/' between words (no wildcards, no leading or trailing '/')")


@pytest.mark.parametrize(("timeout", "shown"), [(0.0, "0"), (-1.5, "-1.5"), (math.nan, "nan")])
def test_a_timeout_must_be_positive(timeout: float, shown: str) -> None:
    with pytest.raises(NetworkError) as info:
        SessionOptions(timeout=timeout)
    assert str(info.value) == f"session timeout must be positive, not {shown}"
    assert SessionOptions(timeout=0.001).timeout == 0.001


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="xgo-show relay")
    add_session_arguments(p)
    return p


def test_the_command_line_options_default_to_nothing_given() -> None:
    opts = session_options(parser().parse_args([]))
    assert opts == SessionOptions()


def test_the_command_line_options_are_repeatable_and_reach_the_session_options() -> None:
    args = parser().parse_args(["--connect", "tcp/10.0.0.2:7447", "--connect", "tcp/10.0.0.3:7447",
                                "--listen", "tcp/0.0.0.0:7448", "--zenoh-config", "z.json5",
                                "--namespace", "acme/a"])
    assert session_options(args) == SessionOptions(
        connect=("tcp/10.0.0.2:7447", "tcp/10.0.0.3:7447"), listen=("tcp/0.0.0.0:7448",),
        config_file="z.json5", namespace="acme/a")


def test_the_help_says_what_the_session_options_do(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "400")  # no line wrapped inside a word ("xgo-" "show")
    text = " ".join(parser().format_help().split())
    assert ("Zenoh session: Default: peer on this machine only (multicast scouting off; the first "
            "xgo-show process listens on tcp/127.0.0.1:7447, later ones connect to it).") in text
    for line in ("--connect ENDPOINT Zenoh endpoint to connect to, e.g. tcp/192.168.1.20:7447 "
                 "(repeatable)",
                 "--listen ENDPOINT Zenoh endpoint to listen on, e.g. tcp/0.0.0.0:7447 "
                 "(repeatable)",
                 "--zenoh-config FILE Zenoh configuration file (JSON5): TLS, user/password, "
                 "routers, ...",
                 "--namespace NS key prefix of every xgo-show key (default xgo-show)"):
        assert line in text


# --- build_config ----------------------------------------------------------------------------

def test_with_nothing_given_a_peer_listens_on_the_hub_or_joins_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    for taken, listen, connect in ((False, [DEFAULT_HUB], []),
                                   (True, [LOOPBACK_ANY], [DEFAULT_HUB])):
        monkeypatch.setattr(zs, "_hub_in_use", lambda taken=taken: taken)
        for config in (build_config(SessionOptions()),
                       build_config(SessionOptions(), hub_taken=taken)):
            assert get(config, "mode") == "peer"
            assert get(config, "scouting/multicast/enabled") is False
            assert get(config, "listen/endpoints") == listen
            assert get(config, "connect/endpoints") == connect
            assert get(config, "connect/timeout_ms") == 2000
            assert get(config, "listen/timeout_ms") == 2000


def test_hub_taken_given_is_not_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    def checked() -> bool:
        raise AssertionError("the port was checked")

    monkeypatch.setattr(zs, "_hub_in_use", checked)
    assert get(build_config(SessionOptions(), hub_taken=False), "listen/endpoints") == [DEFAULT_HUB]


def test_the_hub_is_in_use_when_something_listens_on_its_port(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        monkeypatch.setattr(zs, "DEFAULT_PORT", server.getsockname()[1])
        assert zs._hub_in_use() is True
        assert zs._default_endpoints() == ([LOOPBACK_ANY], [DEFAULT_HUB])
    monkeypatch.setattr(zs, "DEFAULT_PORT", free_port())
    assert zs._hub_in_use() is False
    assert zs._default_endpoints() == ([DEFAULT_HUB], [])


def test_the_timeout_bounds_connecting_and_listening_in_milliseconds() -> None:
    config = build_config(SessionOptions(timeout=0.3), hub_taken=False)
    assert get(config, "connect/timeout_ms") == 300
    assert get(config, "listen/timeout_ms") == 300


def test_connect_alone_listens_on_a_loopback_port_only() -> None:
    config = build_config(SessionOptions(connect=("tcp/10.0.0.2:7447",)))
    assert get(config, "connect/endpoints") == ["tcp/10.0.0.2:7447"]
    assert get(config, "listen/endpoints") == [LOOPBACK_ANY]


def test_listen_alone_connects_nowhere() -> None:
    config = build_config(SessionOptions(listen=("tcp/0.0.0.0:7448",)))
    assert get(config, "listen/endpoints") == ["tcp/0.0.0.0:7448"]
    assert get(config, "connect/endpoints") == []


def test_a_bad_endpoint_is_one_line_naming_the_endpoints() -> None:
    with pytest.raises(NetworkError) as info:
        build_config(SessionOptions(connect=("tcp/a:1?",)))
    assert str(info.value) == (
        "bad Zenoh endpoint in ['tcp/127.0.0.1:0', 'tcp/a:1?']: Endpoints must be of the form "
        "<protocol>/<address>[?<metadata>][#<config>]: tcp/a:1?")  # no Rust source position
    with pytest.raises(NetworkError, match=r"^bad Zenoh endpoint in \['tcp/a:1#'\]: Endpoints"):
        build_config(SessionOptions(listen=("tcp/a:1#",)))


@pytest.mark.parametrize("endpoint", [
    "tcp/0.0.0.0:0", "tcp/host.lan:65535", "tcp/[::1]:7447", "udp/10.0.0.2:7447?iface=lo",
    "tls/a:1#x=1", "quic/a:1", "ws/a:1", "unixsock-stream//tmp/z.sock", "serial//dev/ttyUSB0",
    "pigeon/home",  # a protocol Zenoh does not know: Zenoh says so when the session opens
])
def test_an_endpoint_that_may_be_right_is_left_to_zenoh(endpoint: str) -> None:
    opts = SessionOptions(connect=(endpoint,), listen=(endpoint,), also_connect=(endpoint,))
    assert opts.connect == opts.listen == opts.also_connect == (endpoint,)


@pytest.mark.parametrize("endpoint", ["pigeon", "tcp", "tcp/", "/a:1"])
def test_an_endpoint_is_protocol_slash_address(endpoint: str) -> None:
    for option, opts in (("--connect", {"connect": (endpoint,)}),
                         ("--connect", {"also_connect": ("tcp/a:1", endpoint)}),
                         ("--listen", {"listen": (endpoint,)})):
        with pytest.raises(NetworkError) as info:
            SessionOptions(**opts)  # type: ignore[arg-type]
        assert str(info.value) == (f"{option} {endpoint!r}: a Zenoh endpoint is "
                                   "PROTOCOL/ADDRESS, e.g. tcp/192.168.1.20:7447")


@pytest.mark.parametrize("endpoint", [
    "tcp/127.0.0.1:notaport", "tcp/127.0.0.1", "tcp/127.0.0.1:65536", "udp/:7447",
    "tls/a:123456", "quic/[::1:7447", "ws/a b:1", "tcp/a:1:2", "tcp/a:-1",
])
def test_an_ip_endpoint_needs_a_host_and_a_port_that_exists(endpoint: str) -> None:
    protocol = endpoint.split("/")[0]
    with pytest.raises(NetworkError) as info:
        SessionOptions(listen=(endpoint,))
    assert str(info.value) == (
        f"--listen {endpoint!r}: a {protocol} endpoint's address is HOST:PORT with a port "
        f"0-65535, e.g. {protocol}/192.168.1.20:7447 or {protocol}/[::1]:7447")


def write(tmp_path: Path, text: str) -> str:
    path = tmp_path / "z.json5"
    path.write_text(text, encoding="utf-8")
    return str(path)


def test_a_config_file_is_taken_as_written_but_for_multicast_and_timeouts(
    tmp_path: Path,
) -> None:
    file = write(tmp_path, '{mode: "client", connect: {endpoints: ["tcp/127.0.0.1:1"]}}')
    config = build_config(SessionOptions(config_file=file, timeout=0.5))
    assert get(config, "mode") == "client"
    assert get(config, "connect/endpoints") == ["tcp/127.0.0.1:1"]
    assert get(config, "scouting/multicast/enabled") is False
    assert get(config, "connect/timeout_ms") == 500
    # It names endpoints: the defaults are not added, the options' still are.
    assert get(config, "listen/endpoints") != [DEFAULT_HUB]
    both = build_config(SessionOptions(config_file=file, listen=("tcp/127.0.0.1:2",)))
    assert get(both, "listen/endpoints") == ["tcp/127.0.0.1:2"]
    assert get(both, "connect/endpoints") == ["tcp/127.0.0.1:1"]


def test_a_config_file_that_mentions_multicast_or_timeouts_keeps_them(tmp_path: Path) -> None:
    file = write(tmp_path, "{scouting: {multicast: {enabled: true}}, "
                           "connect: {timeout_ms: 9000}}")
    config = build_config(SessionOptions(config_file=file), hub_taken=False)
    assert get(config, "scouting/multicast/enabled") is True
    assert get(config, "connect/timeout_ms") == 9000
    assert get(config, "listen/endpoints") == [DEFAULT_HUB]  # no endpoints in it: the defaults
    assert get(config, "mode") is None  # not "peer" inserted: the file's (Zenoh's) own mode


def test_a_config_file_with_endpoints_and_connect_given_does_not_add_a_listener(
    tmp_path: Path,
) -> None:
    file = write(tmp_path, '{listen: {endpoints: ["tcp/127.0.0.1:3"]}}')
    config = build_config(SessionOptions(config_file=file, connect=("tcp/127.0.0.1:4",)))
    assert get(config, "listen/endpoints") == ["tcp/127.0.0.1:3"]
    assert get(config, "connect/endpoints") == ["tcp/127.0.0.1:4"]


def test_an_unreadable_or_invalid_config_file_is_one_line(tmp_path: Path) -> None:
    missing = tmp_path / "none.json5"
    with pytest.raises(NetworkError) as info:
        build_config(SessionOptions(config_file=str(missing)))
    assert str(info.value) == f"--zenoh-config {missing}: No such file or directory"
    bad = write(tmp_path, "{mode: ")
    with pytest.raises(NetworkError) as info:
        build_config(SessionOptions(config_file=bad))
    assert str(info.value).startswith(f"--zenoh-config {bad}: not a valid Zenoh config: ")
    wrong = write(tmp_path, '{connect: {endpoints: ["tcp/a:1?"]}}')
    with pytest.raises(NetworkError) as info:
        build_config(SessionOptions(config_file=wrong))
    assert str(info.value) == (
        f"--zenoh-config {wrong}: not a valid Zenoh config: Endpoints must be of the form "
        "<protocol>/<address>[?<metadata>][#<config>]: tcp/a:1?")


def test_also_connect_adds_endpoints_not_already_chosen() -> None:
    config = build_config(SessionOptions(also_connect=(DEFAULT_HUB, "tcp/127.0.0.1:5")),
                          hub_taken=True)
    assert get(config, "connect/endpoints") == [DEFAULT_HUB, "tcp/127.0.0.1:5"]
    config = build_config(SessionOptions(listen=("tcp/127.0.0.1:6",),
                                         also_connect=("tcp/127.0.0.1:5",)))
    assert get(config, "connect/endpoints") == ["tcp/127.0.0.1:5"]


# --- open_session over a recording zenoh.open -------------------------------------------------

class Opener:
    """``zenoh.open``: fails ``fails`` times with ``error``, then returns a session stand-in."""

    def __init__(self, fails: int, error: str = "boom\nmore at /root/.cargo/x/y.rs:388.") -> None:
        self.fails, self.error = fails, error
        self.configs: list[zenoh.Config] = []
        self.session = object()

        self.errors: list[str] = []  # the error of each failing call in turn, if given

    def __call__(self, config: zenoh.Config) -> object:
        self.configs.append(zenoh.Config.from_json5(str(config)))  # a copy: it may change after
        if len(self.configs) <= self.fails:
            errors = self.errors or [self.error]
            raise zenoh.ZError(errors[min(len(self.configs), len(errors)) - 1])
        return self.session


def test_a_session_opens_with_the_built_config(monkeypatch: pytest.MonkeyPatch) -> None:
    opener = Opener(0)
    monkeypatch.setattr(zenoh, "open", opener)
    assert open_session(SessionOptions(listen=("tcp/127.0.0.1:7",))) is opener.session
    (config,) = opener.configs
    assert get(config, "listen/endpoints") == ["tcp/127.0.0.1:7"]


def test_losing_the_race_for_the_hub_joins_it(monkeypatch: pytest.MonkeyPatch) -> None:
    opener = Opener(1)
    monkeypatch.setattr(zenoh, "open", opener)
    monkeypatch.setattr(zs, "_hub_in_use", lambda: False)
    assert open_session(SessionOptions()) is opener.session
    first, second = opener.configs
    assert get(first, "listen/endpoints") == [DEFAULT_HUB]
    assert get(second, "listen/endpoints") == [LOOPBACK_ANY]
    assert get(second, "connect/endpoints") == [DEFAULT_HUB]


def test_a_session_that_cannot_open_is_one_line_without_rusts_position(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    opener = Opener(2, "cannot bind\nmore")
    monkeypatch.setattr(zenoh, "open", opener)
    monkeypatch.setattr(zs, "_hub_in_use", lambda: False)
    with pytest.raises(NetworkError) as info:
        open_session(SessionOptions())  # both tries fail: the first error is said
    assert str(info.value) == "cannot open the Zenoh session: cannot bind"
    assert len(opener.configs) == 2
    for opts in (SessionOptions(connect=("tcp/127.0.0.1:8",)),
                 SessionOptions(listen=("tcp/127.0.0.1:8",))):
        opener = Opener(1)
        monkeypatch.setattr(zenoh, "open", opener)
        with pytest.raises(NetworkError) as info:
            open_session(opts)  # endpoints given: no second try
        assert str(info.value) == "cannot open the Zenoh session: boom"
        assert len(opener.configs) == 1


def test_a_config_files_session_is_not_tried_again(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
) -> None:
    opener = Opener(1, "no router at /root/.cargo/z.rs:12")
    monkeypatch.setattr(zenoh, "open", opener)
    with pytest.raises(NetworkError) as info:
        open_session(SessionOptions(config_file=write(tmp_path, '{mode: "client"}')))
    assert str(info.value) == "cannot open the Zenoh session: no router"
    assert len(opener.configs) == 1


def test_a_listen_retried_until_the_timeout_says_what_failed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Zenoh keeps only "deadline has elapsed" of a listen it retried: one more try without
    # retries says why (the cause Zenoh saw each time).
    opener = Opener(2, "deadline has elapsed at /root/.cargo/a.rs:9.")
    opener.errors = ["deadline has elapsed at /root/.cargo/a.rs:9.",
                     "Can not create a new TCP listener bound to tcp/127.0.0.1:9: [Address "
                     "already in use (os error 98) at /r/t.rs:61.] at /r/u.rs:338."]
    monkeypatch.setattr(zenoh, "open", opener)
    with pytest.raises(NetworkError) as info:
        open_session(SessionOptions(listen=("tcp/127.0.0.1:9",), timeout=3.0))
    assert str(info.value) == (
        "cannot open the Zenoh session: Can not create a new TCP listener bound to "
        "tcp/127.0.0.1:9: [Address already in use (os error 98)] (retried until the timeout)")
    first, second = opener.configs
    assert (get(first, "listen/timeout_ms"), get(first, "connect/timeout_ms")) == (3000, 3000)
    assert (get(second, "listen/timeout_ms"), get(second, "connect/timeout_ms")) == (0, 0)
    assert get(second, "listen/endpoints") == ["tcp/127.0.0.1:9"]
    # The try without retries works (the address came free): that session is used.
    opener = Opener(1, "deadline has elapsed")
    monkeypatch.setattr(zenoh, "open", opener)
    assert open_session(SessionOptions(listen=("tcp/127.0.0.1:9",))) is opener.session
    assert len(opener.configs) == 2
    # Any other error is said as it is, with no second try.
    opener = Opener(2, "deadline has elapsed, and more")
    monkeypatch.setattr(zenoh, "open", opener)
    with pytest.raises(NetworkError, match=r"elapsed, and more$"):
        open_session(SessionOptions(listen=("tcp/127.0.0.1:9",)))
    assert len(opener.configs) == 1


def test_a_wrapped_config_error_is_its_message() -> None:
    wrapped = ('Json5Err(Message { msg: "Endpoints must be \\"x\\": tcp/a:1? at /r/e.rs:674.", '
               "location: Some(Location { line: 1, column: 2 }) }) at /r/config.rs:86.")
    assert zs._first_line(zenoh.ZError(wrapped)) == 'Endpoints must be "x": tcp/a:1?'
    assert zs._first_line(ValueError("a [b at /x/y.rs:1.] c at /x/z.rs:2.")) == "a [b] c"


def test_an_error_without_words_is_named_by_its_type() -> None:
    assert zs._first_line(zenoh.ZError("")) == "ZError"
    assert zs._first_line(ValueError("  first\nsecond  ")) == "first"
    assert zs._first_line(ValueError("x at /a/b.rs:1")) == "x"
    assert zs._first_line(ValueError("x at /a/b.py:1")) == "x at /a/b.py:1"
