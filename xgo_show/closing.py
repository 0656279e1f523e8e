"""One way to be a context manager that closes itself: ``with thing: ...`` calls ``close()``."""

from __future__ import annotations

import threading
from types import TracebackType
from typing import Protocol, TypeVar

__all__ = ["Closing", "WorkerClosing"]

_T = TypeVar("_T", bound="Closing")


class Closing:
    """Mixin: ``__enter__`` returns the object (a subclass may open or start there first) and
    ``__exit__`` calls :meth:`close`, whatever ended the block."""

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self: _T) -> _T:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


class _Subscription(Protocol):
    def close(self) -> None: ...


class WorkerClosing(Closing):
    """Mixin for an object fed by an event subscription ``_sub`` whose worker thread
    ``_thread`` (None in virtual time) waits on ``_cond`` until ``_closed``: :meth:`close`
    stops the feed, wakes the worker to see it is closed, and joins it for at most
    ``_join_timeout`` seconds."""

    _sub: _Subscription
    _cond: threading.Condition
    _closed: bool
    _thread: threading.Thread | None
    _join_timeout = 1.0

    def close(self) -> None:
        """Stop listening and end the worker thread."""
        self._sub.close()
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join(self._join_timeout)
