"""Getting a show's soundtrack ready to play: device, decoding, the performer for the launch.

``run`` and ``dry-run`` call :func:`prepare`; it never stops a show for want of sound: no audio
device (a server, CI) or no ``[audio]`` extra is a warning and the show runs silent. A sound
file that is there but cannot be decoded is an error before anything moves (``--no-music``
runs without it).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import UsageError, XgoShowError

__all__ = ["Prepared", "parse_latency", "prepare"]


@dataclass(frozen=True)
class Prepared:
    """What :func:`prepare` decided: a performer builder for the launch (or None) and the
    line to print about it (or "")."""

    build: Callable[[Any], Mapping[str, Any]] | None
    note: str
    name: str = "music"
    close: Callable[[], None] = lambda: None  # release the device (the player also does)


def music_name(schedule: Schedule) -> str:
    """The soundtrack's performer name: ``music``, unless a robot already has it."""
    taken = {p.name for p in schedule.performers}
    return next(n for n in ("music", "soundtrack", "music-track") if n not in taken)


def prepare(
    schedule: Schedule, *, enabled: bool = True, fast: bool = False, device: str = "default"
) -> Prepared:
    """Open the device and decode the show's music for playing on the show clock."""
    music = schedule.music
    if music is None:
        return Prepared(None, "")
    if not enabled:
        return Prepared(None, f"music: {music.file} not played (--no-music)")
    if fast:
        return Prepared(None, f"music: {music.file} not played with --fast")
    from xgo_show.audio.decode import decode
    from xgo_show.audio.player import music_performer
    from xgo_show.audio.sink import NoAudioDevice, open_sink

    path = music.path
    if not Path(path).is_file():  # a schedule moved with its music: look beside its source
        path = str(Path(schedule.source).parent / music.file)
    try:
        sink = open_sink("null" if device == "null" else "default")
    except NoAudioDevice as exc:
        return Prepared(None, f"warning: music: {exc}: the show runs silent (--no-music to "
                              "say so)")
    except XgoShowError as exc:  # the [audio] extra is not installed
        return Prepared(None, f"warning: music: {exc}: the show runs silent")
    try:
        audio = decode(path, channels=sink.channels, sample_rate=sink.rate)
    except XgoShowError:
        sink.close()
        raise
    name = music_name(schedule)
    build = music_performer(
        audio.samples, sink, offset=music.offset, until=schedule.duration, name=name,
        label=Path(music.file).name,
    )
    where = f"{sink.name} device" if device != "null" else "null device (no sound)"
    note = (f"music: {music.file} from {music.offset:+.3f} s, on the {where}, "
            f"{sink.latency * 1000:.0f} ms buffer")
    return Prepared(build, note, name, sink.close)


def parse_latency(items: Sequence[str], names: Sequence[str]) -> dict[str, float]:
    """``NAME=MS`` options -> {name: seconds}; ``names`` are the performers (music included)."""
    out: dict[str, float] = {}
    for item in items:
        name, eq, value = item.partition("=")
        try:
            ms = float(value)
        except ValueError:
            ms = float("nan")
        if not eq or not name or not (-1000.0 <= ms <= 1000.0):
            raise UsageError(
                f"--latency {item!r}: write NAME=MS with MS from -1000 to 1000, e.g. music=40"
            )
        if name not in names:
            raise UsageError(f"--latency {item!r}: no output {name!r}; outputs: "
                               f"{', '.join(names)}")
        out[name] = ms / 1000.0
    return out
