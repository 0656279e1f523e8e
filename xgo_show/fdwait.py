"""Wait until a file descriptor is readable, for any descriptor number.

``select.select`` fails ("filedescriptor out of range") for descriptors past ``FD_SETSIZE``
(1024), which a dry-run of many performers reaches (each one a pty pair and a client).
``poll`` has no such limit.
"""

from __future__ import annotations

import select

__all__ = ["ReadableWaiter"]

_EVENTS = select.POLLIN | select.POLLPRI | select.POLLERR | select.POLLHUP


class ReadableWaiter:
    """``wait(timeout)`` on one descriptor: True when it is readable (or in error, so that the
    read that follows reports it), False after ``timeout`` seconds."""

    def __init__(self, fd: int) -> None:
        self._poll = select.poll()
        self._poll.register(fd, _EVENTS)

    def wait(self, timeout: float) -> bool:
        """Whether the descriptor became readable within ``timeout`` seconds."""
        return bool(self._poll.poll(max(0.0, timeout) * 1000.0))
