"""Run ``xgo-show`` commands in this one process on many files, each under a time limit, in a
process with a memory cap: a JSON line per call (exit code, output, what escaped main, seconds
of wall clock and of CPU).

The limit is on CPU time (what a command costs, whatever else the shared machine runs), with a
far longer wall-clock alarm for a call that blocks without computing (a named pipe)."""

from __future__ import annotations

import contextlib
import io
import json
import resource
import signal
import sys
import time
import traceback
from types import FrameType

MEMORY_CAP = 2 * 1024**3  # bytes of address space for the whole process
CALL_LIMIT = 10  # seconds of CPU per command
HANG_LIMIT = 120  # seconds of wall clock per command: blocked, not busy


class _Timeout(BaseException):
    pass


def _alarm(signum: int, frame: FrameType | None) -> None:
    raise _Timeout


def main() -> None:
    from xgo_show.cli.main import main as xgo_show

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
    signal.signal(signal.SIGALRM, _alarm)
    signal.signal(signal.SIGPROF, _alarm)
    for line in sys.stdin:
        argv = json.loads(line)
        out, err = io.StringIO(), io.StringIO()
        escaped = ""
        code: int | None = None
        started, cpu = time.monotonic(), time.process_time()
        signal.setitimer(signal.ITIMER_PROF, CALL_LIMIT)
        signal.alarm(HANG_LIMIT)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = xgo_show(argv)
        except _Timeout:
            escaped = f"timeout ({CALL_LIMIT} s of CPU or {HANG_LIMIT} s of wall clock)"
        except BaseException:  # a traceback: what the test is looking for
            escaped = traceback.format_exc()
        finally:
            signal.alarm(0)
            signal.setitimer(signal.ITIMER_PROF, 0)
        print(json.dumps({"argv": argv, "code": code, "out": out.getvalue(),
                          "err": err.getvalue(), "escaped": escaped,
                          "seconds": time.monotonic() - started,
                          "cpu_seconds": time.process_time() - cpu}), flush=True)


if __name__ == "__main__":
    main()
