"""A relay started by a conductor on the same host ends when its parent process dies.

Linux delivers SIGTERM to the relay the moment its parent dies (``PR_SET_PDEATHSIG``), and
SIGTERM safe-stops every robot: ``kill -9`` of ``xgo-show run`` (or the OOM killer, or a crash)
no longer leaves robots walking. Elsewhere the relay polls ``getppid()`` (within 0.2 s) and its
watchdog notices the silent conductor anyway.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

from xgo_show.errors import SetupError

__all__ = ["watch_parent"]

_PR_SET_PDEATHSIG = 1


def watch_parent(pid: int) -> bool:
    """Ask for SIGTERM when the parent dies; return whether the kernel will send it.

    Raises :class:`XgoShowError` if the parent ``pid`` is already gone (it died before the
    request took effect).
    """
    armed = False
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            armed = int(libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)) == 0
        except (OSError, AttributeError):
            armed = False
    if os.getppid() != pid:
        raise SetupError(f"the conductor (pid {pid}) is gone already")
    return armed
