"""``xgo-show beats SONG``: find the beats of a recording and write a tempo map for a routine.

The map (``tempo:`` entries, one per bar where the tempo moves, merged where it holds) starts at
the recording's first downbeat, which the routine gives as the music's ``offset``; the command
prints both lines to put in the routine. Needs the ``[audio]`` extra.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from xgo_show.errors import AudioError, FileAccessError, UsageError

__all__ = ["add_parser", "render", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``beats`` subcommand on the CLI's subparsers."""
    parser = sub.add_parser(
        "beats",
        help="estimate tempo and beats of a song and write a tempo map",
        description=(
            "Decode SONG (WAV, FLAC, MP3 or OGG), track its beats and bars and write a tempo "
            "map that a routine includes with 'tempo: {file: FILE}', so bars and beats land on "
            "the recording's own beats. Bar 1 beat 1 is the first downbeat: give it to the "
            "routine as 'music: {file: SONG, offset: SECONDS}' (both lines are printed). "
            "Needs the audio extra: pip install 'xgo-show[audio]'."
        ),
        epilog=(
            "example:\n"
            "  xgo-show beats song.ogg -o song.tempo.yaml\n"
            "  xgo-show beats song.flac --beats-per-bar 3 --first-bar-at 1.25"
        ),
    )
    parser.add_argument("song", metavar="SONG", help="sound file (WAV, FLAC, MP3, OGG)")
    parser.add_argument(
        "-o", "--output", metavar="FILE", help="write the tempo map here (default: print it)"
    )
    parser.add_argument(
        "--beats-per-bar", type=int, default=4, metavar="N", help="the meter (default 4)"
    )
    parser.add_argument(
        "--first-bar-at",
        type=float,
        metavar="SECONDS",
        help="the beat nearest this time starts bar 1 (default: the loudest beat phase)",
    )
    parser.add_argument(
        "--tolerance-ms",
        type=float,
        default=3.0,
        metavar="MS",
        help="one tempo entry covers bars while it meets every beat within this (default 3)",
    )
    parser.set_defaults(func=run)


def render(song: str, map_name: str, analysis: Any, entries: list[Any]) -> str:
    """The tempo-map file: comments saying how to use it, then ``tempo:``."""
    per_bar = analysis.beats_per_bar
    bpms = [e.bpm for e in entries]
    lines = [
        f"# Tempo map of {song}, by xgo-show beats: {len(analysis.beats)} beats, "
        f"{len(analysis.downbeats)} downbeats, {min(bpms):g}-{max(bpms):g} bpm, "
        f"{per_bar} beats a bar.",
        f"# Bar 1 beat 1 is {analysis.offset:.3f} s into the recording. In the routine:",
        f"#   music: {{file: {song}, offset: {analysis.offset:.3f}}}",
        f"#   tempo: {{file: {map_name}}}",
        "tempo:",
    ]
    for i, entry in enumerate(entries):
        meter = f", beats_per_bar: {per_bar}" if i == 0 else ""
        lines.append(f"  - {{bar: {entry.bar}, bpm: {entry.bpm:g}{meter}}}")
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    from xgo_show.audio.beats import analyse, tempo_map
    from xgo_show.audio.decode import decode

    if not 1 <= args.beats_per_bar <= 64:
        raise UsageError(f"--beats-per-bar must be 1..64, not {args.beats_per_bar}")
    if not args.tolerance_ms > 0:
        raise UsageError(f"--tolerance-ms must be positive, not {args.tolerance_ms:g}")
    audio = decode(args.song)
    try:
        analysis = analyse(audio.mono(), audio.sample_rate, args.beats_per_bar, args.first_bar_at)
        entries = tempo_map(analysis, args.tolerance_ms / 1000.0)
    except ValueError as exc:
        raise AudioError(f"{args.song}: {exc}") from exc
    song = args.song
    map_name = args.output or f"{Path(song).stem}.tempo.yaml"
    if args.output:
        # Name the song relative to the map, as the routine beside it would.
        try:
            song = str(Path(args.song).resolve().relative_to(Path(args.output).resolve().parent))
        except ValueError:
            song = str(Path(args.song).resolve())
        map_name = Path(args.output).name
    text = render(song, map_name, analysis, entries)
    if args.output:
        try:
            Path(args.output).write_text(text, encoding="utf-8")
        except OSError as exc:
            raise FileAccessError(f"cannot write {args.output}: {exc.strerror or exc}") from exc
        notes = text.split("\ntempo:", 1)[0].splitlines()
        print("\n".join(line.removeprefix("# ") for line in notes), file=sys.stderr)
        print(f"wrote {args.output} ({len(entries)} tempo entries)", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
