"""Reading user files: only regular files, never blocking, never more than a cap."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.errors import FileAccessError
from xgo_show.files import file_problem, read_head, read_text_file


def test_reads_a_regular_file(tmp_path: Path) -> None:
    path = tmp_path / "a.yaml"
    path.write_text("show: é\n", encoding="utf-8")
    assert read_text_file(path, limit=100) == "show: é\n"
    assert file_problem(path) is None


def test_a_named_pipe_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    started = time.monotonic()
    with pytest.raises(FileAccessError, match="named pipe"):
        read_text_file(fifo, limit=100)
    assert file_problem(fifo) == "is a named pipe, not a regular file"
    assert read_head(fifo, 10) == b""
    assert time.monotonic() - started < 2


@pytest.mark.parametrize(("path", "reason"), [
    ("/dev/zero", "character device"),
    ("/dev/null", "character device"),
    ("/", "is a directory"),
    ("/nonexistent/x.yaml", "no such file"),
    ("bad\0name", "cannot read"),
])
def test_devices_directories_and_missing_files_are_refused(path: str, reason: str) -> None:
    with pytest.raises(FileAccessError, match=reason):
        read_text_file(path, limit=100)
    assert reason in (file_problem(path) or "")


def test_a_symlink_loop_is_refused(tmp_path: Path) -> None:
    loop = tmp_path / "loop.yaml"
    loop.symlink_to(loop)
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.symlink_to(b)
    b.symlink_to(a)
    for path in (loop, a):
        with pytest.raises(FileAccessError, match="symbolic links"):
            read_text_file(path, limit=100)


@pytest.mark.parametrize("size", [101, 1000, 10**6])
def test_a_file_over_the_cap_is_refused_before_reading(tmp_path: Path, size: int) -> None:
    path = tmp_path / "big.yaml"
    with path.open("wb") as fh:
        fh.truncate(size)  # sparse: the size is what counts
    with pytest.raises(FileAccessError, match="limit is 100"):
        read_text_file(path, limit=100)
    assert len(read_text_file(path, limit=size)) == size


@settings(max_examples=60, deadline=None)
@given(lines=st.lists(st.text(st.characters(blacklist_categories=("Cs",),
                                            blacklist_characters="\n\r"), max_size=8),
                      min_size=1, max_size=6),
       bad=st.sampled_from([b"\xff", b"\xc3", b"\xed\xa0\x80", b"\x80"]),
       newline=st.sampled_from(["\n", "\r\n", "\r"]))
def test_a_byte_that_is_not_utf8_is_located(tmp_path_factory: pytest.TempPathFactory,
                                             lines: list[str], bad: bytes, newline: str) -> None:
    """At its line and column, whatever the line breaks (an old Mac file has bare CRs)."""
    path = tmp_path_factory.mktemp("u") / "x.yaml"
    head = newline.join(lines)
    path.write_bytes(head.encode("utf-8") + bad + b"\n")
    with pytest.raises(FileAccessError, match="not UTF-8") as info:
        read_text_file(path, limit=10_000)
    assert info.value.line == len(lines)
    assert info.value.column == len(lines[-1]) + 1
