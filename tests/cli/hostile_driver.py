"""Run ``xgo-show`` commands in this one process on many files, each under a time limit, in a
process with a memory cap: a JSON line per call (exit code, output, what escaped main)."""

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
CALL_LIMIT = 10  # seconds per command


class _Timeout(BaseException):
    pass


def _alarm(signum: int, frame: FrameType | None) -> None:
    raise _Timeout


def main() -> None:
    from xgo_show.cli.main import main as xgo_show

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
    signal.signal(signal.SIGALRM, _alarm)
    for line in sys.stdin:
        argv = json.loads(line)
        out, err = io.StringIO(), io.StringIO()
        escaped = ""
        code: int | None = None
        started = time.monotonic()
        signal.alarm(CALL_LIMIT)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = xgo_show(argv)
        except _Timeout:
            escaped = f"timeout after {CALL_LIMIT} s"
        except BaseException:  # a traceback: what the test is looking for
            escaped = traceback.format_exc()
        finally:
            signal.alarm(0)
        print(json.dumps({"argv": argv, "code": code, "out": out.getvalue(),
                          "err": err.getvalue(), "escaped": escaped,
                          "seconds": time.monotonic() - started}), flush=True)


if __name__ == "__main__":
    main()
