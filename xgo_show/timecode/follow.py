"""``run``/``dry-run --follow``: the sound desk drives the show (OSC cues or MTC chase).

``osc:[HOST:]PORT`` listens for OSC cues (see :mod:`.osc`): the show waits for ``/go``, then
``/pause``, ``/resume``, ``/seek``, ``/bar`` and ``/stop`` steer it, ``/trigger NAME`` fires a
trigger. ``mtc:PORT`` chases MIDI timecode from the MIDI input PORT (see :mod:`.chase`; needs
python-rtmidi): the show starts when the timecode locks and holds or stops on a jump or
dropout, as ``--chase-policy`` says.

A show whose sections wait for triggers follows OSC cues through its
:class:`~xgo_show.control.director.Director` (set :attr:`Follow.director`): the desk starts,
pauses, resumes and seeks the show, the triggers release its waits (a ``/resume`` cannot
release one: it is refused with the reason). Such a show cannot chase MTC (see
:func:`xgo_show.control.rehearsal.check_triggers`).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, TextIO

from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import TimecodeError, UsageError
from xgo_show.runtime.clock import Clock
from xgo_show.timecode.chase import Chaser, ChaseSettings, Policy
from xgo_show.timecode.osc import Command, OscServer, parse_spec

__all__ = ["Follow", "parse_timecode"]

LEAD = 0.1  # s between a cue and the robots acting on it


def parse_timecode(text: str) -> float:
    """``HH:MM:SS:FF`` (at 30 fps) or seconds -> seconds."""
    parts = text.split(":")
    try:
        if len(parts) == 4:
            h, m, s, f = (int(p) for p in parts)
            if not (0 <= m < 60 and 0 <= s < 60 and 0 <= f < 30 and h >= 0):
                raise ValueError
            return 3600 * h + 60 * m + s + f / 30.0
        if len(parts) == 1 and float(text) >= 0:
            return float(text)
    except ValueError:
        pass
    raise UsageError(f"--timecode-origin {text!r}: give HH:MM:SS:FF or seconds")


class Follow:
    """Waits for the desk's start, then relays its cues to the show runner."""

    def __init__(
        self,
        spec: str,
        schedule: Schedule,
        *,
        clock: Clock,
        out: TextIO,
        offset: float = 0.0,
        policy: Policy = "hold",
        origin: float = 0.0,
    ) -> None:
        self.schedule = schedule
        self.clock = clock
        self.out = out
        self.offset = offset
        self.runner: Any = None
        self.director: Any = None  # a show with waits: cues go through its director
        self._start: tuple[float, float] | None = None
        self._started = threading.Event()
        self._stopped: str | None = None
        self._closers: list[Callable[[], None]] = []
        kind, _, where = spec.partition(":")
        if kind == "osc":
            server = OscServer(self._on_osc, *parse_spec(spec))
            self._closers.append(server.close)
            self.note = f"listening for OSC cues on {server.host}:{server.port} (/go starts)"
        elif kind == "mtc" and where:
            self.chaser = Chaser(self, ChaseSettings(policy=policy, origin=origin),
                                 schedule.duration, now=clock.now)
            self._open_mtc(where)
            self.note = f"chasing MTC on MIDI input {where!r} ({policy} on a jump or dropout)"
        else:
            raise UsageError(f"--follow {spec!r}: write osc:[HOST:]PORT or mtc:MIDI-PORT")

    # ------------------------------------------------------------------ inputs

    def _open_mtc(self, port: str) -> None:
        from xgo_show.audio.decode import require
        from xgo_show.timecode.mtc import MtcDecoder

        mido = require("mido")
        decoder = MtcDecoder()

        def on_message(msg: Any) -> None:
            arrived = self.clock.now()
            for pos in decoder.feed(bytes(msg.bytes())):
                self.chaser.position(pos.seconds, arrived, locate=pos.full)

        try:
            midi_in = mido.open_input(port, callback=on_message)
        except (ImportError, OSError, RuntimeError) as exc:
            raise TimecodeError(f"cannot open MIDI input {port!r} for MTC ({exc}); MIDI ports "
                               "need python-rtmidi: pip install python-rtmidi") from exc
        ticking = threading.Event()

        def tick() -> None:
            while not ticking.wait(0.05):
                self.chaser.tick()

        ticker = threading.Thread(target=tick, name="mtc-tick", daemon=True)
        ticker.start()
        self._closers += [midi_in.close, ticking.set]

    def _on_osc(self, command: Command | str) -> None:
        if isinstance(command, str):
            print(f"osc: {command}", file=self.out, flush=True)
            return
        now = self.clock.now()
        kind, value = command.kind, command.value
        if kind == "go" and not self._started.is_set():
            self.start(self.offset if value is None else value, now + LEAD)
        elif self.runner is None or not self._started.is_set():
            print(f"osc: /{kind} before /go: ignored", file=self.out, flush=True)
        elif kind == "stop":
            self.stop("OSC /stop")
        elif kind == "trigger":
            self.trigger(str(command.name))
        elif kind == "pause":
            self.pause(now + LEAD)
        elif kind in ("resume", "go"):
            if value is not None:
                self.seek(value, now + LEAD)
            self.resume(now + LEAD)
        elif kind in ("seek", "bar"):
            self.seek(self._show_time(kind, value), now + LEAD)

    def _show_time(self, kind: str, value: float | None) -> float:
        assert value is not None
        if kind == "seek":
            return value
        tempo = self.schedule.tempo()
        if tempo is None:
            print("osc: /bar needs a show with a tempo", file=self.out, flush=True)
            return self.runner.snapshot().show_time if self.runner else 0.0
        return tempo.position(int(value))

    # ------------------------------------------------------------------ the chase target

    def start(self, offset: float, at: float) -> None:
        """The desk says go: the show starts at clock time ``at`` from ``offset``."""
        self._start = (min(max(0.0, offset), self.schedule.duration), at)
        self._started.set()

    def pause(self, at: float) -> None:
        if self.director is not None:
            self._direct("pause", lambda: self.director.pause(at=at))
        elif self.runner is not None:
            self.runner.pause(at=at)

    def resume(self, at: float) -> None:
        if self.director is not None:
            self._direct("resume", lambda: self.director.resume(at=at))
        elif self.runner is not None:
            self.runner.resume(at=at)

    def seek(self, show_time: float, at: float) -> None:
        show_time = min(max(0.0, show_time), self.schedule.duration)
        if self.director is not None:
            self._direct("seek", lambda: self.director.seek(show_time, at=at))
        elif self.runner is not None:
            self.runner.seek(show_time, at=at)

    def trigger(self, name: str) -> None:
        """The desk fires trigger ``name``: through the director, as a Zenoh trigger."""
        if self.director is None:
            print(f"osc: /trigger {name} refused: this show waits for no trigger",
                  file=self.out, flush=True)
        else:
            self._direct(f"trigger {name}", lambda: self.director.trigger(name))

    def _direct(self, what: str, command: Callable[[], None]) -> None:
        """A cue through the director: one line saying why, if it refuses it."""
        from xgo_show.errors import ControlError

        try:
            command()
        except ControlError as exc:
            print(f"osc: /{what} refused: {exc}", file=self.out, flush=True)

    def stop(self, reason: str) -> None:
        self._stopped = reason
        if self.runner is not None:
            self.runner.stop(reason)
        self._started.set()

    # ------------------------------------------------------------------ the CLI's side

    def wait_for_start(self) -> tuple[float, float | None]:
        """Block until the desk starts the show: (show time, clock time). Ctrl-C ends it."""
        while not self._started.wait(0.1):
            pass
        if self._stopped is not None or self._start is None:
            raise TimecodeError(f"the show never started: {self._stopped}")
        return self._start

    def close(self) -> None:
        for close in self._closers:
            close()
        self._closers = []
