"""Limits every loader applies, to routines and schedules alike (one home for each number).

They bound what a file can make xgo-show do: how long a show lasts, how many robots it drives.
"""

from __future__ import annotations

__all__ = ["MAX_PERFORMERS", "MAX_SHOW_SECONDS"]

#: Performers one show may drive. Each needs its own port, a few threads and (in a dry-run) a
#: pseudo-terminal pair; the rigs xgo-show is made for have a handful of robots. The limit also
#: keeps every descriptor of a run below select()'s 1024, which pyserial still uses.
MAX_PERFORMERS = 64
#: The longest show, seconds: longer is a typo (or a show to split).
MAX_SHOW_SECONDS = 3600.0
