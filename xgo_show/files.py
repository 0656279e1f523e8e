"""Read the files users hand us (routines, parts, schedules) without trusting them.

A path may name a named pipe (reading blocks forever), a device such as ``/dev/zero`` (reading
never ends), a symlink loop, a directory or a file far larger than any show. Only regular files
are read, opened without blocking and checked *after* opening (the file that is read is the
file that was checked), and never more than a stated number of bytes.
"""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path

from xgo_show.errors import FileAccessError

__all__ = [
    "MAX_ROUTINE_BYTES",
    "MAX_SCHEDULE_BYTES",
    "file_problem",
    "read_bytes_file",
    "read_head",
    "read_text_file",
]

#: A routine, and all the parts it includes together: the largest bundled routine is some
#: 10 KB, and ten minutes of ten robots moving without a pause (benchmarks/compile_speed.py)
#: 290 KB. Validating a MiB of the densest YAML (moves of eight registers) costs about 2 s
#: of CPU on this 2-CPU machine, all checks and the compiler's included
#: (benchmarks/validate_worst.py): 1 MiB for the routine and 1 MiB for its parts keep
#: validating anything under 5 s with a margin for a loaded machine (2 MiB took 3.9 s alone).
MAX_ROUTINE_BYTES = 1024 * 1024
#: A compiled schedule: an hour of five robots at 50 Hz is about 100 MB of JSON.
MAX_SCHEDULE_BYTES = 256 * 1024 * 1024

_KINDS = (
    (stat.S_ISDIR, "is a directory"),
    (stat.S_ISFIFO, "is a named pipe, not a regular file"),
    (stat.S_ISCHR, "is a character device, not a regular file"),
    (stat.S_ISBLK, "is a block device, not a regular file"),
    (stat.S_ISSOCK, "is a socket, not a regular file"),
)


def _open_regular(path: Path, limit: int) -> tuple[int, int]:
    """An open descriptor of ``path`` (a regular file of at most ``limit`` bytes) and its size."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise FileAccessError("no such file") from None
    except IsADirectoryError:
        raise FileAccessError("is a directory") from None
    except OSError as exc:  # ELOOP (a symlink loop), EACCES, ENXIO (a socket), ...
        raise FileAccessError(f"cannot read: {exc.strerror or exc}") from exc
    except ValueError as exc:  # a NUL character in the path
        raise FileAccessError(f"cannot read: {exc}") from exc
    try:
        info = os.fstat(fd)
        for test, reason in _KINDS:
            if test(info.st_mode):
                raise FileAccessError(reason)
        if not stat.S_ISREG(info.st_mode):
            raise FileAccessError("is not a regular file")
        if info.st_size > limit:
            raise FileAccessError(
                f"is {info.st_size:,} bytes; the limit is {limit:,} (is this the right file?)"
            )
    except BaseException:
        os.close(fd)
        raise
    return fd, info.st_size


def _read(fd: int, limit: int) -> bytes:
    """At most ``limit + 1`` bytes (one more than allowed shows the file grew past it)."""
    chunks: list[bytes] = []
    total = 0
    while total <= limit:
        chunk = os.read(fd, min(1 << 20, limit + 1 - total))
        if not chunk:
            break
        chunks.append(chunk)
        total += len(chunk)
    return b"".join(chunks)


def file_problem(path: str | Path) -> str | None:
    """Why ``path`` cannot be read as a file (``no such file``, ``is a named pipe, not a
    regular file``, ...), or None when it is a readable regular file. Never blocks."""
    try:
        fd, _ = _open_regular(Path(path), 1 << 62)
    except FileAccessError as exc:
        return str(exc)
    os.close(fd)
    return None


def read_head(path: str | Path, size: int) -> bytes:
    """The first ``size`` bytes of a regular file; ``b""`` for anything else (no blocking)."""
    try:
        fd, _ = _open_regular(Path(path), 1 << 62)
    except FileAccessError:
        return b""
    try:
        return os.read(fd, size)
    except OSError:
        return b""
    finally:
        os.close(fd)


def read_bytes_file(path: str | Path, *, limit: int) -> bytes:
    """The bytes of the regular file ``path``; :class:`FileAccessError` when it is not one,
    cannot be read or has more than ``limit`` bytes."""
    fd, _ = _open_regular(Path(path), limit)
    try:
        data = _read(fd, limit)
    except OSError as exc:
        raise FileAccessError(f"cannot read: {exc.strerror or exc}") from exc
    finally:
        os.close(fd)
    if len(data) > limit:
        raise FileAccessError(f"is larger than the limit of {limit:,} bytes")
    return data


def read_text_file(path: str | Path, *, limit: int) -> str:
    """The UTF-8 text of the regular file ``path`` of at most ``limit`` bytes.

    Raises :class:`FileAccessError` with a short reason (``no such file``, ``is a named pipe,
    not a regular file``, ...); for bytes that are not UTF-8 its ``line`` and ``column`` say
    where the first one is.
    """
    data = read_bytes_file(path, limit=limit)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        # YAML's line breaks: an old Mac file ends its lines with a bare CR.
        lines = re.split(rb"\r\n|\r|\n", data[: exc.start])
        line = len(lines)
        column = len(lines[-1].decode("utf-8", "replace")) + 1
        raise FileAccessError(
            f"not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})",
            line=line, column=column,
        ) from exc
