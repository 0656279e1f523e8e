"""Open a Zenoh session from Zenoh's own options, with defaults that stay on this machine.

Every command that opens a session (``relay``, ``relays``, ``run``/``dry-run`` with ``zenoh:``
performers, ``probe zenoh:...``) takes the same options through :func:`add_session_arguments`:

- ``--connect ENDPOINT`` / ``--listen ENDPOINT`` (repeatable): Zenoh endpoints such as
  ``tcp/192.168.1.20:7447``;
- ``--zenoh-config FILE``: a Zenoh configuration file (JSON5, Zenoh's own format: TLS,
  user/password, routers...);
- ``--namespace NS``: the key prefix every xgo-show key lives under (default ``xgo-show``), so
  two companies' shows on one network never see each other.

Defaults (no option, no file): peer mode, multicast scouting OFF, and one well-known loopback
port, ``tcp/127.0.0.1:7447`` (:data:`DEFAULT_HUB`). The first xgo-show process on the machine
listens on it; every later one connects to it and listens on a loopback port of its own, which
Zenoh's gossip passes on, so the processes stay connected when the first one exits. Nothing
listens beyond 127.0.0.1 and nothing is sent to the network unless asked.

Options given replace the defaults they concern: any ``--connect``/``--listen`` replaces the
default endpoints (``--listen tcp/0.0.0.0:7447`` on a relay, ``--connect tcp/RELAY:7447`` on
the conductor is a two-host set-up); ``--connect`` alone listens on a loopback port only (not
on every interface, Zenoh's own default). A ``--zenoh-config`` file is Zenoh's configuration as
written, except that xgo-show still turns multicast scouting off unless the file mentions
``multicast``, still bounds connection attempts (``connect/timeout_ms``,
``listen/timeout_ms``) unless it mentions ``timeout_ms``, and uses the default endpoints only
when neither the file (``endpoints``) nor the options name any. :func:`open_session` never
blocks for ever: a peer whose endpoints do not answer yet opens anyway and keeps retrying in
the background; a client (``mode: "client"``) that reaches no router fails after the timeout
with one line saying so.
"""

from __future__ import annotations

import argparse
import json
import re
import socket
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from xgo_show.errors import NetworkError

if TYPE_CHECKING:
    import zenoh

__all__ = [
    "DEFAULT_HUB",
    "DEFAULT_NAMESPACE",
    "DEFAULT_PORT",
    "SessionOptions",
    "add_session_arguments",
    "build_config",
    "open_session",
    "session_options",
]

DEFAULT_NAMESPACE = "xgo-show"
DEFAULT_PORT = 7447
DEFAULT_HUB = f"tcp/127.0.0.1:{DEFAULT_PORT}"
#: A process that is not the first on the machine listens here (the OS picks the port).
LOOPBACK_ANY = "tcp/127.0.0.1:0"
_NAMESPACE_RE = re.compile(r"[A-Za-z0-9_.-]+(/[A-Za-z0-9_.-]+)*")
#: Zenoh's protocols whose address is HOST:PORT (Zenoh itself refuses unknown protocols clearly)
_HOST_PORT_PROTOCOLS = frozenset({"tcp", "udp", "tls", "quic", "ws"})
_HOST_PORT_RE = re.compile(r"(\[[0-9A-Fa-f:.]+\]|[^\s:\[\]/]+):([0-9]{1,5})")
#: Zenoh's own trailer on an error: the Rust source position, not for users
_RUST_POSITION_RE = re.compile(r"\s+at /\S+\.rs:\d+\.?")
#: a config error Zenoh wraps: ``Json5Err(Message { msg: "WORDS", location: ... })``
_WRAPPED_RE = re.compile(r'Message \{ msg: "((?:[^"\\]|\\.)*)"')


@dataclass(frozen=True)
class SessionOptions:
    """What to open: endpoints, a Zenoh config file, the namespace and the connect timeout."""

    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    config_file: str | None = None
    namespace: str = DEFAULT_NAMESPACE
    timeout: float = 2.0  # seconds: connect/timeout_ms and listen/timeout_ms
    #: endpoints connected to in addition to whatever the rules below chose (the relay child
    #: of ``xgo-show run``): they never replace the defaults
    also_connect: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not _NAMESPACE_RE.fullmatch(self.namespace):
            raise NetworkError(
                f"--namespace {self.namespace!r}: use letters, digits, '_', '-', '.' and '/' "
                "between words (no wildcards, no leading or trailing '/')"
            )
        if not self.timeout > 0:
            raise NetworkError(f"session timeout must be positive, not {self.timeout:g}")
        for option, endpoints in (("--connect", self.connect + self.also_connect),
                                  ("--listen", self.listen)):
            for endpoint in endpoints:
                _check_endpoint(option, endpoint)


def _check_endpoint(option: str, endpoint: str) -> None:
    """Refuse an endpoint whose address cannot be right, before Zenoh is asked: a peer retries
    a bad ``--connect`` in the background for ever, so the user would only see nobody come."""
    protocol, slash, rest = endpoint.partition("/")
    if not slash or not protocol or not rest:
        raise NetworkError(
            f"{option} {endpoint!r}: a Zenoh endpoint is PROTOCOL/ADDRESS, e.g. "
            f"tcp/192.168.1.20:{DEFAULT_PORT}"
        )
    if protocol not in _HOST_PORT_PROTOCOLS:
        return
    address = re.split(r"[?#]", rest, maxsplit=1)[0]
    match = _HOST_PORT_RE.fullmatch(address)
    if match is None or int(match.group(2)) > 65535:
        raise NetworkError(
            f"{option} {endpoint!r}: a {protocol} endpoint's address is HOST:PORT with a port "
            f"0-65535, e.g. {protocol}/192.168.1.20:{DEFAULT_PORT} or {protocol}/[::1]:"
            f"{DEFAULT_PORT}"
        )


def add_session_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--connect``, ``--listen``, ``--zenoh-config`` and ``--namespace`` to a command."""
    group = parser.add_argument_group(
        "Zenoh session",
        "Default: peer on this machine only (multicast scouting off; the first xgo-show "
        f"process listens on {DEFAULT_HUB}, later ones connect to it).",
    )
    group.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="Zenoh endpoint to connect to, e.g. tcp/192.168.1.20:7447 (repeatable)",
    )
    group.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="Zenoh endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)",
    )
    group.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="Zenoh configuration file (JSON5): TLS, user/password, routers, ...",
    )
    group.add_argument(
        "--namespace",
        default=DEFAULT_NAMESPACE,
        metavar="NS",
        help=f"key prefix of every xgo-show key (default {DEFAULT_NAMESPACE})",
    )


def session_options(args: argparse.Namespace) -> SessionOptions:
    """The :class:`SessionOptions` that :func:`add_session_arguments` parsed."""
    return SessionOptions(
        connect=tuple(args.connect),
        listen=tuple(args.listen),
        config_file=args.zenoh_config,
        namespace=args.namespace,
    )


def _hub_in_use() -> bool:
    """Whether something already listens on the default loopback port."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.settimeout(0.2)
        return sock.connect_ex(("127.0.0.1", DEFAULT_PORT)) == 0


def _default_endpoints() -> tuple[list[str], list[str]]:
    """(listen, connect) for a process that was given no endpoint at all."""
    if _hub_in_use():
        return [LOOPBACK_ANY], [DEFAULT_HUB]
    return [DEFAULT_HUB], []


def build_config(opts: SessionOptions, *, hub_taken: bool | None = None) -> zenoh.Config:
    """The :class:`zenoh.Config` for ``opts`` (see the module's docstring for the rules).

    ``hub_taken`` overrides the check of whether the default port is in use (None: check).
    """
    import zenoh

    text = ""
    config: zenoh.Config
    if opts.config_file is not None:
        path = Path(opts.config_file)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise NetworkError(f"--zenoh-config {path}: {exc.strerror or exc}") from exc
        try:
            config = zenoh.Config.from_json5(text)
        except zenoh.ZError as exc:
            words = _RUST_POSITION_RE.sub("", str(exc)).strip()  # a parse error's lines kept
            raise NetworkError(f"--zenoh-config {path}: not a valid Zenoh config: {words}") from exc
    else:
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
    if "multicast" not in text:
        config.insert_json5("scouting/multicast/enabled", "false")
    if "timeout_ms" not in text:
        ms = str(int(opts.timeout * 1000))
        config.insert_json5("connect/timeout_ms", ms)
        config.insert_json5("listen/timeout_ms", ms)
    listen, connect = list(opts.listen), list(opts.connect)
    if not listen and not connect and "endpoints" not in text:
        if hub_taken is None:
            listen, connect = _default_endpoints()
        else:
            listen, connect = ([LOOPBACK_ANY], [DEFAULT_HUB]) if hub_taken else ([DEFAULT_HUB], [])
        config.insert_json5("listen/endpoints", json.dumps(listen))
        config.insert_json5("connect/endpoints", json.dumps(connect))
    else:
        if connect and not listen and "endpoints" not in text:
            listen = [LOOPBACK_ANY]  # Zenoh's own default would listen on every interface
        try:
            if listen:
                config.insert_json5("listen/endpoints", json.dumps(listen))
            if connect:
                config.insert_json5("connect/endpoints", json.dumps(connect))
        except zenoh.ZError as exc:
            raise NetworkError(
                f"bad Zenoh endpoint in {listen + connect}: {_first_line(exc)}"
            ) from exc
    if opts.also_connect:
        chosen = json.loads(config.get_json("connect/endpoints"))
        extra = [e for e in opts.also_connect if e not in chosen]
        config.insert_json5("connect/endpoints", json.dumps([*chosen, *extra]))
    return config


def open_session(opts: SessionOptions) -> zenoh.Session:
    """Open a Zenoh session for ``opts``; a :class:`NetworkError` (one line) if it cannot."""
    import zenoh

    defaults = not opts.listen and not opts.connect and opts.config_file is None
    config = build_config(opts)
    try:
        return zenoh.open(config)
    except zenoh.ZError as exc:
        if defaults:
            # Two processes started at once may both have found the default port free: the
            # one that lost the race joins the other.
            try:
                return zenoh.open(build_config(opts, hub_taken=True))
            except zenoh.ZError:
                pass
        reason = _first_line(exc)
        if reason == "deadline has elapsed":
            # Zenoh retried a listen (or a client's connect) until the timeout and kept only
            # that; one attempt with no retries says what failed (an address in use, a port
            # refused). If that attempt works after all, the session is as good as any.
            try:
                return zenoh.open(_without_retries(config))
            except zenoh.ZError as again:
                reason = f"{_first_line(again)} (retried until the timeout)"
        raise NetworkError(f"cannot open the Zenoh session: {reason}") from exc


def _without_retries(config: zenoh.Config) -> zenoh.Config:
    for key in ("connect/timeout_ms", "listen/timeout_ms"):
        config.insert_json5(key, "0")
    return config


def _first_line(exc: BaseException) -> str:
    """Zenoh's error in one line of words: the message inside a wrapped JSON5 error, without
    the Rust source position Zenoh puts after each nested message (" at /root/...rs:388.")."""
    text = str(exc)
    wrapped = _WRAPPED_RE.search(text)
    if wrapped is not None:
        text = wrapped.group(1).replace('\\"', '"')
    lines = _RUST_POSITION_RE.sub("", text).strip().splitlines()
    return lines[0] if lines else type(exc).__name__
