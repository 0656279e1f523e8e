"""Limits every loader applies, to routines and schedules alike (one home for each number).

They bound what a file can make xgo-show do: how long a show lasts, how many robots it drives,
and the range of every number a routine or a schedule sets. A number outside its range is
refused at its place, with the range, before anything is computed from it (a control rate of
1e-300 Hz would make a sample period of 1e300 s, and an overflow deep in the compiler).
docs/limits.md lists them with the reasons; tests/test_limits.py checks that the routine's
JSON schema gives every number both bounds and that the page names each one.
"""

from __future__ import annotations

__all__ = [
    "MAX_BARS",
    "MAX_BEATS",
    "MAX_BEATS_PER_BAR",
    "MAX_BPM",
    "MAX_CONTROL_RATE",
    "MAX_GAP_MS",
    "MAX_LIMIT",
    "MAX_MUSIC_OFFSET",
    "MAX_PERFORMERS",
    "MAX_REPEAT",
    "MAX_SHOW_SECONDS",
    "MIN_BPM",
    "MIN_CONTROL_RATE",
    "MIN_GAP_MS",
    "MIN_LIMIT",
    "MIN_MUSIC_OFFSET",
]

#: Performers one show may drive. Each needs its own port, a few threads and (in a dry-run) a
#: pseudo-terminal pair; the rigs xgo-show is made for have a handful of robots. The limit also
#: keeps every descriptor of a run below select()'s 1024, which pyserial still uses.
MAX_PERFORMERS = 64
#: The longest show, seconds: longer is a typo (or a show to split). Every time and length in
#: seconds (``at``, ``after``, ``duration``, ``rest``, ``fade``, a wait's ``timeout``,
#: ``settings.end``) lies in 0..this.
MAX_SHOW_SECONDS = 3600.0

#: Trajectory samples per second (``settings.control_rate``), Hz. Below 1 Hz a move of a
#: second has no sample inside it; above 1000 Hz the frames' 1 ms resolution is passed and
#: no serial link carries them.
MIN_CONTROL_RATE = 1.0
MAX_CONTROL_RATE = 1000.0
#: Silence between frames (``settings.gap_ms``), ms: the XGO firmware needs at least 1 ms;
#: a second between frames is no longer a show.
MIN_GAP_MS = 1.0
MAX_GAP_MS = 1000.0

#: Tempo, beats per minute: 1 bpm is a beat a minute (slower is a typo for seconds); 1000
#: bpm is a beat every 60 ms, three control ticks at the default rate.
MIN_BPM = 1.0
MAX_BPM = 1000.0
#: Beats per bar: 1 (a count in ones) to 64 (no meter has more).
MAX_BEATS_PER_BAR = 64
#: Beats a length may span, and the bar number a time or a tempo entry may name: an hour at
#: the fastest tempo is 60,000 beats (60,000 bars of one beat).
MAX_BEATS = 60_000
MAX_BARS = 60_000

#: Seconds into the recording at bar 1 beat 1 (``music.offset``): negative starts the music
#: that long after the show (at most the show's length); a recording may be a day long.
MIN_MUSIC_OFFSET = -MAX_SHOW_SECONDS
MAX_MUSIC_OFFSET = 86_400.0

#: A trajectory limit (velocity, acceleration, jerk, in the register's unit per second^n):
#: what the planner (ruckig) handles without underflow or overflow.
MIN_LIMIT = 1e-3
MAX_LIMIT = 1e7

#: Times one ``repeat`` block plays its cues (the cue guard bounds what it expands to).
MAX_REPEAT = 10_000
