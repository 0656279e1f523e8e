"""Pause the cyclic garbage collector while a schedule's frames are made.

Compiling or loading a show allocates hundreds of thousands of small objects (frames, their
bytes, tuples) and frees none of them until it returns: the cyclic collector, triggered every
few hundred allocations, would rescan them over and over for nothing (benchmarks/compile_speed.py's
show takes 2.7 s of CPU to compile with it on instead of 1.6 s; loading its file 0.56 s to make
the frames instead of 0.17 s). Nothing these make holds a reference cycle to collect.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["paused_gc"]


@contextmanager
def paused_gc() -> Iterator[None]:
    """Disable the cyclic collector inside the block; restore its state on the way out."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()
