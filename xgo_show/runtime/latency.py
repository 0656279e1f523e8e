"""Per-output latency: a performer whose output lags acts that much earlier.

A USB-serial adapter, a radio link or a sound card delays what a performer sends by a roughly
fixed time. :class:`Early` wraps any :class:`~xgo_show.runtime.performer.Performer` and moves
every clock time it is given (start, pause, resume, seek) earlier by ``seconds``, so what comes
out of that output lines up with the others. Show times are unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult
    from xgo_show.runtime.performer import Performer

__all__ = ["Early"]


class Early:
    """``inner``, acting ``seconds`` earlier than told (a :class:`Performer` itself)."""

    def __init__(self, inner: Performer, seconds: float) -> None:
        self.inner = inner
        self.seconds = seconds

    def _at(self, at: float | None) -> float | None:
        return None if at is None else at - self.seconds

    @property
    def name(self) -> str:
        return self.inner.name

    @property
    def model(self) -> str:
        return self.inner.model

    @property
    def state(self) -> ExecutorState:
        return self.inner.state

    @property
    def done(self) -> bool:
        return self.inner.done

    @property
    def fault(self) -> str | None:
        return self.inner.fault

    @property
    def progress(self) -> Progress:
        return self.inner.progress

    @property
    def stop_result(self) -> SafeStopResult | None:
        return self.inner.stop_result

    @property
    def readings(self) -> Mapping[str, float]:
        return self.inner.readings

    def lead_time(self, offset: float) -> float:
        """The inner performer's lead, plus the time it starts early."""
        return self.inner.lead_time(offset) + max(0.0, self.seconds)

    def start(self, start_at: float, *, offset: float = 0.0) -> None:
        self.inner.start(start_at - self.seconds, offset=offset)

    def pause(self, *, at: float | None = None) -> None:
        self.inner.pause(at=self._at(at))

    def resume(self, *, at: float | None = None) -> None:
        self.inner.resume(at=self._at(at))

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        self.inner.seek(show_time, at=self._at(at))

    def abort(self) -> None:
        self.inner.abort()

    def safe_stop(self, reason: str, *, timeout: float = 0.1) -> SafeStopResult:
        return self.inner.safe_stop(reason, timeout=timeout)

    def join(self, timeout: float | None = None) -> bool:
        return self.inner.join(timeout)

    def close(self) -> None:
        self.inner.close()
