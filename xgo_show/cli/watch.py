"""``--watch``: run a command again each time a routine (or a part it may include) is saved.

Polls file times rather than asking the OS for change events: a routine and its parts are a
handful of small files, a poll every 0.3 s costs nothing, and it behaves the same on every
platform and with editors that save by writing a new file and renaming it over the old one.
Ctrl-C ends the watch.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterable
from datetime import datetime
from pathlib import Path
from typing import Any

__all__ = ["add_watch_option", "snapshot", "watch"]

_SUFFIXES = (".yaml", ".yml", ".json")
_MAX_FILES = 2000  # a routine in a huge folder: watch the first ones found rather than hang
Snapshot = dict[Path, tuple[int, int]]


def add_watch_option(parser: Any, files: str) -> None:
    """Add ``--watch`` to ``parser``; ``files`` names the argument holding the routine(s)."""
    parser.add_argument(
        "--watch", action="store_true",
        help="run again each time the routine, or a YAML file beside it (a part it includes), "
        "is saved; Ctrl-C stops",
    )
    parser.set_defaults(watch_files=files)


def _watched(routines: Iterable[Path]) -> list[Path]:
    """The routines, then the YAML/JSON files in their folders and below (parts, tempo maps)."""
    found: dict[Path, None] = {p: None for p in routines}
    for folder in {p.parent for p in found}:
        try:
            for path in folder.rglob("*"):
                if len(found) >= _MAX_FILES:
                    break
                if path.suffix in _SUFFIXES and ".venv" not in path.parts:
                    found[path] = None
        except OSError:
            continue  # an unreadable folder: the routines themselves are still watched
    return list(found)


def snapshot(paths: Iterable[Path]) -> Snapshot:
    """(mtime in ns, size) of each path that exists now."""
    out: Snapshot = {}
    for path in paths:
        try:
            st = path.stat()
        except OSError:
            continue
        out[path] = (st.st_mtime_ns, st.st_size)
    return out


def watch(
    args: argparse.Namespace,
    run_once: Callable[[], int],
    *,
    poll: float = 0.3,
    sleep: Callable[[float], None] = time.sleep,
) -> int:
    """Run ``run_once`` now and after every change to the watched files, until Ctrl-C (then
    the status of the last run)."""
    names = getattr(args, args.watch_files)
    routines = [Path(n) for n in ([names] if isinstance(names, str) else names)]
    status = 0
    try:
        while True:
            status = run_once()
            paths = _watched(routines)
            before = snapshot(paths)
            print(f"-- watching {len(paths)} file(s) for changes (Ctrl-C stops)", flush=True)
            while True:
                sleep(poll)
                now = snapshot(paths)
                if now != before:
                    changed = sorted(str(p) for p in set(now) ^ set(before) | {
                        p for p in now if p in before and now[p] != before[p]})
                    stamp = datetime.now().strftime("%H:%M:%S")
                    print(f"\n-- {stamp} {', '.join(changed)} changed: running again",
                          flush=True)
                    sleep(poll)  # let an editor finish writing
                    break
    except KeyboardInterrupt:
        print("-- stopped watching", file=sys.stderr)
        return status
