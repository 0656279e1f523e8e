"""OSC cues (a sound desk, QLab, TouchOSC) -> show commands, and a UDP server for them.

Commands (each address may carry a prefix, ``/xgo/go`` as well as ``/go``):

==================  ==========================================================
``/go``             start the show (from ``--start``/``--start-bar``, or 0)
``/go f``           start at show time ``f`` seconds
``/pause``          hold every robot at rest (``/go`` or ``/resume`` goes on)
``/resume``         go on from where the pause left the show
``/seek f``         go to show time ``f`` (catch-up moves, never a jump)
``/bar i``          go to bar ``i`` (needs the show's tempo)
``/stop``           safe-stop every robot
``/trigger s``      fire trigger ``s`` (releases the wait of a section that waits
                    for it, as a Zenoh trigger does)
==================  ==========================================================

:func:`parse_packet` is pure (bytes in, commands or a reason out); python-osc decodes the OSC
encoding itself, bundles included.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from xgo_show.audio.decode import require
from xgo_show.control.keys import is_trigger_name

__all__ = ["COMMANDS", "Command", "OscServer", "parse_command", "parse_packet", "parse_spec"]

COMMANDS = ("go", "pause", "resume", "seek", "bar", "stop", "trigger")


@dataclass(frozen=True)
class Command:
    """``kind`` (one of :data:`COMMANDS`) and its value: seconds for go/seek, a bar for bar;
    ``name``: the trigger's, for trigger."""

    kind: str
    value: float | None = None
    name: str | None = None


def _number(args: list[Any]) -> float | None:
    if len(args) != 1 or isinstance(args[0], bool) or not isinstance(args[0], (int, float)):
        return None
    value = float(args[0])
    return value if value == value and abs(value) != float("inf") else None


def parse_command(address: str, args: list[Any], prefix: str = "") -> Command | str:
    """One OSC message -> a :class:`Command`, or why it is not one (a one-line reason)."""
    if prefix and address.startswith(prefix + "/"):
        address = address[len(prefix):]
    kind = address.rsplit("/", 1)[-1] if address.startswith("/") else ""
    if kind not in COMMANDS or address != "/" + kind:
        return f"unknown OSC address {address!r}; known: " + ", ".join("/" + c for c in COMMANDS)
    if kind in ("pause", "resume", "stop"):
        return Command(kind) if not args else f"/{kind} takes no arguments"
    if kind == "go" and not args:
        return Command("go")
    if kind == "trigger":
        if len(args) != 1 or not isinstance(args[0], str) or not is_trigger_name(args[0]):
            return f"/trigger takes one trigger name (letters, digits, _ and -), not {args!r}"
        return Command("trigger", name=args[0])
    value = _number(args)
    if value is None or value < 0:
        return f"/{kind} takes one number >= 0, not {args!r}"
    if kind == "bar" and (value != int(value) or value < 1):
        return f"/bar takes a bar number (1, 2, ...), not {args[0]!r}"
    return Command(kind, value)


def parse_spec(spec: str, option: str = "--follow") -> tuple[str, int]:
    """``osc:[HOST:]PORT`` -> (host, port); host 127.0.0.1 when not given. Raises
    :class:`~xgo_show.errors.UsageError` naming ``option`` for anything else."""
    from xgo_show.errors import UsageError

    kind, _, where = spec.partition(":")
    host, _, port = where.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        number = -1
    if kind != "osc" or not 0 <= number <= 65535:
        raise UsageError(f"{option} {spec!r}: write osc:[HOST:]PORT, e.g. osc:9000")
    return host or "127.0.0.1", number


def parse_packet(data: bytes, prefix: str = "") -> list[Command | str]:
    """A UDP datagram (a message or a bundle) -> its commands (or reasons), in order."""
    packet_mod = require("pythonosc.osc_packet")
    try:
        packet = packet_mod.OscPacket(data)
    except (packet_mod.ParseError, UnicodeDecodeError) as exc:
        # pythonosc lets a non-UTF-8 address escape as UnicodeDecodeError (b"/\x80\0\0").
        return [f"not an OSC packet ({exc})"]
    return [parse_command(m.message.address, list(m.message.params), prefix)
            for m in packet.messages]


class OscServer:
    """Listens for OSC on UDP ``host:port`` (port 0: any free one, see :attr:`port`) and hands
    each command (or the reason a message is not one) to ``on_command`` on its own thread."""

    def __init__(
        self,
        on_command: Callable[[Command | str], None],
        host: str = "127.0.0.1",
        port: int = 0,
        prefix: str = "",
    ) -> None:
        import socketserver

        self._on_command = on_command
        self._prefix = prefix
        outer = self

        class Handler(socketserver.BaseRequestHandler):
            def handle(self) -> None:
                data = self.request[0]
                for command in parse_packet(data, outer._prefix):
                    outer._on_command(command)

        try:
            self._server = socketserver.UDPServer((host, port), Handler)
        except OSError as exc:
            from xgo_show.errors import TimecodeError

            raise TimecodeError(f"cannot listen for OSC on {host}:{port}: {exc.strerror}") from exc
        address = self._server.server_address
        self.host: str = str(address[0])
        self.port: int = int(address[1])
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={
            "poll_interval": 0.05}, name="osc-server", daemon=True)
        self._thread.start()

    @property
    def native_id(self) -> int | None:
        """The kernel id of the thread that hands the commands on (to raise its priority)."""
        return self._thread.native_id

    def close(self) -> None:
        """Stop listening (idempotent)."""
        if self._thread.is_alive():
            self._server.shutdown()
            self._thread.join(1.0)
        self._server.server_close()
