"""The recording half of the test performers: every timed command a runner gives is kept, in
order, as a tuple (its name, then its arguments), for a test to compare."""

from __future__ import annotations

from typing import Any


class RecordsCommands:
    """Keeps each pause, resume, seek and abort in :attr:`calls`; a test performer adds the
    calls whose answers it chooses (lead time, start, safe stop)."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, ...]] = []

    def pause(self, *, at: float | None = None) -> None:
        self.calls.append(("pause", at))

    def resume(self, *, at: float | None = None) -> None:
        self.calls.append(("resume", at))

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        self.calls.append(("seek", show_time, at))

    def abort(self) -> None:
        self.calls.append(("abort",))
