"""Child processes a test starts (serve, behave, the CLI): waiting for the first answer from
one, and for its exit.

Both fail with what the child printed, so a failure says why. A child that does not exit in
time is hung: it gets SIGABRT, and Python's faulthandler (on in every child: tests/conftest.py
sets PYTHONFAULTHANDLER) prints every thread's stack before it dies.
"""

from __future__ import annotations

import re
import signal
import subprocess
import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")

# Between two asks nobody answered: a query to a child still starting returns at once, and a
# loop without a pause takes the CPU the child needs to start (2 CPUs, shared).
ASK_PAUSE = 0.02


def first_answer(
    ask: Callable[[], T | None], proc: subprocess.Popen[str], timeout: float = 20.0
) -> T:
    """``ask()`` again until it gives something other than None; fail at once if ``proc``
    exits, and after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while (answer := ask()) is None:
        if proc.poll() is not None:
            raise AssertionError(f"{_name(proc)} exited with {proc.returncode}:\n"
                                 f"{_output(proc)}")
        if time.monotonic() > deadline:
            raise AssertionError(f"{_name(proc)} never answered in {timeout:g} s")
        time.sleep(ASK_PAUSE)
    return answer


def read_until(proc: subprocess.Popen[str], pattern: str, seen: list[str] | None = None,
               timeout: float = 20.0) -> str:
    """The first line of ``proc``'s output matching ``pattern`` (a regex); the lines read go
    to ``seen`` too. Fails with all of them if the output ends or ``timeout`` passes first
    (checked between lines)."""
    assert proc.stdout is not None
    lines = seen if seen is not None else []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        if re.search(pattern, line):
            return line
    raise AssertionError(f"no line matching {pattern!r} in:\n{''.join(lines)}")


def exited(proc: subprocess.Popen[str], timeout: float = 20.0) -> str:
    """Wait for ``proc`` to exit; return its output (stdout, with stderr if merged into it).
    A child still running after ``timeout`` seconds is hung: fail with its threads' stacks."""
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGABRT)
        try:
            out, _ = proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, _ = proc.communicate()
        raise AssertionError(f"{_name(proc)} did not exit in {timeout:g} s; its output and "
                             f"threads:\n{out or ''}") from None
    return out or ""


def _name(proc: subprocess.Popen[str]) -> str:
    args = [str(a) for a in proc.args] if isinstance(proc.args, list) else [str(proc.args)]
    return "xgo-show " + args[3] if args[1:3] == ["-m", "xgo_show"] else " ".join(args[:3])


def _output(proc: subprocess.Popen[str]) -> str:
    out, _ = proc.communicate()
    return out or ""
