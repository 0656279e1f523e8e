"""Serve a simulated robot on a real pseudo-terminal, so any serial client can talk to it.

:class:`PtyServer` opens a pty pair, puts the slave side in raw mode (no echo, no line
discipline) and runs one thread that moves bytes between the master side and the robot:
``robot.receive(data, now)`` for every chunk a client writes and ``robot.poll(now)`` several
hundred times a second for replies and time-driven output (Rider feedback). Clients open
:attr:`PtyServer.path` like a USB serial port (``serial.Serial(path, 115200)``).

The server keeps its own slave file descriptor open for its whole life: the master then never
sees end-of-file or EIO when a client closes, and clients may close and reopen the path any
number of times. Output written while no client is attached waits in the terminal's queue; if
the queue is full the excess is dropped (counted in :attr:`PtyServer.dropped_bytes`), as a
robot's UART would drop bytes nobody reads.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import struct
import termios
import threading
import time
import tty
from pathlib import Path
from typing import IO, Any

from xgo_show.closing import Closing
from xgo_show.errors import TransportError
from xgo_show.fdwait import ReadableWaiter
from xgo_show.sim.base import SimulatedRobot

__all__ = ["PtyServer"]

_POLL_INTERVAL = 0.002  # seconds between robot polls when the line is quiet
_CHUNK = 4096


class PtyServer(Closing):
    """Serve ``robot`` on a new pseudo-terminal (context manager, or :meth:`start`/:meth:`close`).

    ``record``: optional path of a JSON-lines file that gets one line per frame the robot
    receives: ``{"t": monotonic seconds, "hex": "550009…" (the whole frame), "accepted": bool,
    "reason": str}``. Use :attr:`lock` (or :meth:`snapshot`) to inspect the robot while the
    server runs.
    """

    def __init__(self, robot: SimulatedRobot, *, record: str | os.PathLike[str] | None = None):
        self.robot = robot
        self.lock = threading.RLock()
        self.dropped_bytes = 0
        self._record_path = Path(record) if record is not None else None
        self._record: IO[str] | None = None
        self._recorded = 0
        self._master = -1
        self._slave = -1
        self._path = ""
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self._loops = 0  # serving-loop iterations done (settle() waits for one more)
        #: a robot gone offline (cable pulled, powered off): what clients write is dropped
        #: (counted in ``dropped_bytes``) and nothing is sent back, until it is set False again
        self.offline = False

    @property
    def path(self) -> str:
        """The slave device path clients open (e.g. ``/dev/pts/3``)."""
        if not self._path:
            raise TransportError("the pseudo-terminal server is not started")
        return self._path

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> PtyServer:
        """Open the pty and start serving; returns ``self``."""
        if self._thread is not None:
            raise TransportError("the pseudo-terminal server is already started")
        if self._record_path is not None:
            try:
                self._record = self._record_path.open("w", encoding="utf-8")
            except OSError as exc:
                raise TransportError(f"cannot write the record file: {exc}") from exc
        try:
            self._master, self._slave = os.openpty()
            tty.setraw(self._slave, termios.TCSANOW)
            self._path = os.ttyname(self._slave)
            os.set_blocking(self._master, False)
        except OSError as exc:
            self._release()
            raise TransportError(f"cannot open a pseudo-terminal: {exc}") from exc
        self._stop.clear()
        self._thread = threading.Thread(target=self._serve, name="xgo-show pty", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the thread, close the pty and the record file. Safe to call twice."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        with self.lock:
            self._write_records()
        self._release()

    def snapshot(self) -> dict[str, Any]:
        """``robot.snapshot()`` taken under the lock, plus ``dropped_bytes``."""
        with self.lock:
            snap = self.robot.snapshot()
        snap["dropped_bytes"] = self.dropped_bytes
        return snap

    def settle(self, timeout: float = 1.0) -> bool:
        """Wait until the robot has taken in every byte written to the pty so far.

        Returns False if that did not happen within ``timeout`` seconds (a dead server).
        """
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and self.running:
            if self._unread() == 0:
                # The loop may hold bytes it read but has not handed to the robot yet: once a
                # whole further iteration has run, it has.
                seen = self._loops
                while self._loops < seen + 2 and time.monotonic() < deadline and self.running:
                    time.sleep(0.001)
                if self._unread() == 0:
                    return True
            time.sleep(0.001)
        return False

    def _unread(self) -> int:
        """Bytes written by clients that the serving thread has not read yet."""
        try:
            buf = fcntl.ioctl(self._master, termios.FIONREAD, b"\0\0\0\0")
        except OSError:
            return 0
        return int(struct.unpack("i", buf)[0])

    @property
    def error(self) -> BaseException | None:
        """The exception that stopped the serving thread, if any."""
        return self._error

    def __enter__(self) -> PtyServer:
        return self.start()

    # ------------------------------------------------------------------ thread
    def _serve(self) -> None:
        try:
            waiter = ReadableWaiter(self._master)  # poll: no FD_SETSIZE limit, unlike select
            while not self._stop.is_set():
                ready = waiter.wait(_POLL_INTERVAL)
                data = b""
                if ready:
                    try:
                        data = os.read(self._master, _CHUNK)
                    except BlockingIOError:
                        data = b""
                    except OSError as exc:
                        if exc.errno != errno.EIO:  # EIO: no slave open (cannot happen here)
                            raise
                now = time.monotonic()
                if self.offline:
                    self.dropped_bytes += len(data)
                    self._loops += 1
                    continue
                with self.lock:
                    if data:
                        self.robot.receive(data, now)
                        self._write_records()
                    out = self.robot.poll(now)
                if out:
                    self._send(out)
                self._loops += 1
        except BaseException as exc:  # keep the cause for close()/tests; never die silently
            self._error = exc
            raise

    def _send(self, out: bytes) -> None:
        view = memoryview(out)
        while view:
            try:
                n = os.write(self._master, view)
            except BlockingIOError:
                self.dropped_bytes += len(view)
                return
            view = view[n:]

    def _write_records(self) -> None:
        if self._record is None:
            return
        frames = self.robot.received
        for frame in frames[self._recorded :]:
            line = {
                "t": frame.t,
                "hex": frame.data.hex(),
                "accepted": frame.accepted,
                "reason": frame.reason,
            }
            self._record.write(json.dumps(line) + "\n")
        self._recorded = len(frames)
        self._record.flush()

    def _release(self) -> None:
        """Close the pty's file descriptors and the record file (each only once)."""
        for fd in (self._master, self._slave):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = -1
        if self._record is not None:
            self._record.close()
            self._record = None
