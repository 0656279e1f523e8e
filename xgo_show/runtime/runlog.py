"""The run log: one JSON object per line, everything a show run did and when.

Record kinds (``"kind"``):

- ``"event"``: ``event`` is one of ``preflight``, ``start``, ``pause``, ``resume``, ``fault``,
  ``safe_stop``, ``end`` (plus free fields such as ``performer`` and ``reason``);
- ``"frame"``: one frame sent: ``performer``, ``send`` (``frame`` = scheduled, ``reach`` =
  catch-up for a mid-show start or resume, ``read`` = telemetry request, ``rest`` and
  ``stop`` = stop frames), ``index`` into the schedule, ``planned`` and ``actual`` send times in
  seconds from the show start (``planned`` is null for frames the schedule does not hold),
  ``bytes`` (hex);
- ``"telemetry"``: ``performer``, ``name``, ``value``, ``t``;
- ``"sim"``: final state of a simulated robot (``dry-run`` and ``run --sim``).

Every record carries ``mono``, the monotonic time it was written. Writes are thread-safe and
buffered; events flush so that what led to a fault is on disk even if the process then dies.
"""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from types import TracebackType
from typing import IO, Any

from xgo_show.errors import XgoShowError

__all__ = ["RunLog", "read_log"]


class RunLog:
    """A thread-safe JSON-lines writer. ``RunLog(None)`` keeps records in memory only."""

    def __init__(self, path: str | Path | None = None, *, keep: bool = True) -> None:
        self.path = Path(path) if path is not None else None
        self._lock = threading.Lock()
        self._file: IO[str] | None = None
        self.records: list[dict[str, Any]] = []
        self._keep = keep
        if self.path is not None:
            try:
                self._file = self.path.open("w", encoding="utf-8")
            except OSError as exc:
                raise XgoShowError(f"cannot write the run log {self.path}: {exc}") from exc

    def write(self, kind: str, *, flush: bool = False, **fields: Any) -> None:
        """Append one record."""
        record: dict[str, Any] = {"kind": kind, "mono": round(time.monotonic(), 6), **fields}
        line = json.dumps(record, default=str)
        with self._lock:
            if self._keep:
                self.records.append(record)
            if self._file is not None:
                self._file.write(line + "\n")
                if flush:
                    self._file.flush()

    def event(self, event: str, **fields: Any) -> None:
        """Append an event record and flush it to disk."""
        self.write("event", flush=True, event=event, **fields)

    def events(self, name: str | None = None) -> list[dict[str, Any]]:
        """The event records kept in memory, optionally only those named ``name``."""
        with self._lock:
            return [
                r
                for r in self.records
                if r["kind"] == "event" and (name is None or r["event"] == name)
            ]

    def close(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None

    def __enter__(self) -> RunLog:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def read_log(path: str | Path) -> list[dict[str, Any]]:
    """Read a run log back (one dict per line)."""
    with Path(path).open(encoding="utf-8") as fh:
        return [json.loads(line) for line in fh if line.strip()]
