"""MIDI timecode (MTC) bytes -> positions in seconds.

Quarter-frame messages (``F1 0nnn dddd``) carry the time in eight pieces, two frames' worth;
a full-frame SysEx (``F0 7F dev 01 01 hr mn sc fr F7``) carries it whole (a DAW sends it when it
locates). mido parses the bytes into messages; :class:`MtcDecoder` assembles the pieces.

Timing. The time in a cycle of eight quarter frames is the frame at which piece 0 was sent; when
piece 7 arrives seven quarter frames have passed, so the position then is that time plus 7/4
frame. From then on every quarter frame is a quarter frame later (8.3 ms at 30 fps, 10 ms at
25, 10.4 ms at 24): that is the resolution of the positions it gives. A piece out of order
(tape rewinding, a lost byte) drops the partial cycle, and the next full cycle locates anew.
"""

from __future__ import annotations

from dataclasses import dataclass

from xgo_show.audio.decode import require

__all__ = ["RATES", "MtcDecoder", "Position", "full_frame", "quarter_frames"]

#: frame rates by the two rate bits (29.97 is drop-frame: frames are counted as 30 a second)
RATES = (24.0, 25.0, 29.97, 30.0)


@dataclass(frozen=True)
class Position:
    """Timecode ``seconds`` at the moment its last byte arrived; ``full`` for a SysEx locate."""

    seconds: float
    fps: float
    full: bool = False


def _seconds(hours: int, minutes: int, seconds: int, frames: float, rate_code: int) -> float:
    fps = RATES[rate_code]
    if rate_code == 2:  # drop-frame: frame numbers 0 and 1 are skipped each minute but every 10th
        total_minutes = 60 * hours + minutes
        dropped = 2 * (total_minutes - total_minutes // 10)
        count = (3600 * hours + 60 * minutes + seconds) * 30 + frames - dropped
        return count / fps
    return 3600 * hours + 60 * minutes + seconds + frames / fps


class MtcDecoder:
    """Feed MIDI bytes; get :class:`Position` s (one per quarter frame once a cycle is whole)."""

    def __init__(self) -> None:
        self._parser = require("mido").Parser()
        self._pieces: list[int | None] = [None] * 8
        self._expect = 0
        self._last: Position | None = None

    def feed(self, data: bytes) -> list[Position]:
        """The positions the bytes complete, in order (none for stray or partial messages)."""
        self._parser.feed(data)
        out: list[Position] = []
        for msg in self._parser:
            if msg.type == "quarter_frame":
                pos = self._quarter(msg.frame_type, msg.frame_value)
            elif msg.type == "sysex":
                pos = self._sysex(tuple(msg.data))
            else:
                pos = None
            if pos is not None:
                out.append(pos)
        return out

    def _quarter(self, piece: int, value: int) -> Position | None:
        if piece != self._expect:
            # Out of order: start collecting again from this piece if it is piece 0.
            self._pieces = [None] * 8
            self._last = None
            if piece != 0:
                self._expect = 0
                return None
        self._pieces[piece] = value
        self._expect = (piece + 1) % 8
        if piece == 7 and all(p is not None for p in self._pieces):
            p = [v or 0 for v in self._pieces]
            rate_code = (p[7] >> 1) & 0x3
            frames = p[0] | (p[1] << 4)
            seconds = p[2] | (p[3] << 4)
            minutes = p[4] | (p[5] << 4)
            hours = p[6] | ((p[7] & 0x1) << 4)
            fps = RATES[rate_code]
            t = _seconds(hours, minutes, seconds, frames, rate_code) + 7 / (4 * fps)
            self._last = Position(t, fps)
            return self._last
        if self._last is not None:
            self._last = Position(self._last.seconds + 1 / (4 * self._last.fps), self._last.fps)
            return self._last
        return None

    def _sysex(self, data: tuple[int, ...]) -> Position | None:
        if len(data) != 8 or data[0] != 0x7F or data[2:4] != (0x01, 0x01):
            return None
        hr, mn, sc, fr = data[4:8]
        rate_code = (hr >> 5) & 0x3
        self._pieces = [None] * 8
        self._expect = 0
        self._last = None
        return Position(_seconds(hr & 0x1F, mn, sc, fr, rate_code), RATES[rate_code], full=True)


def _fields(seconds: float, rate_code: int) -> tuple[int, int, int, int]:
    fps = RATES[rate_code]
    if rate_code == 2:
        count = round(seconds * fps)
        per_10 = 17982  # frames in ten drop-frame minutes
        tens, rest = divmod(count, per_10)
        extra = 0 if rest < 2 else 2 * ((rest - 2) // 1798)
        count += 18 * tens + extra
        frames, secs = count % 30, count // 30
    else:
        total = round(seconds * fps)
        frames, secs = total % round(fps), total // round(fps)
    return secs // 3600, secs // 60 % 60, secs % 60, frames


def quarter_frames(seconds: float, rate_code: int = 3) -> bytes:
    """The eight quarter-frame messages (16 bytes) a sender emits for ``seconds``: what the
    tests and the benchmark send (a DAW's MTC generator does the same)."""
    hours, minutes, secs, frames = _fields(seconds, rate_code)
    values = [
        frames & 0xF, frames >> 4, secs & 0xF, secs >> 4,
        minutes & 0xF, minutes >> 4, hours & 0xF, (hours >> 4) | (rate_code << 1),
    ]
    return b"".join(bytes([0xF1, (piece << 4) | v]) for piece, v in enumerate(values))


def full_frame(seconds: float, rate_code: int = 3) -> bytes:
    """A full-frame SysEx locate to ``seconds``."""
    hours, minutes, secs, frames = _fields(seconds, rate_code)
    return bytes([0xF0, 0x7F, 0x7F, 0x01, 0x01, hours | (rate_code << 5), minutes, secs,
                  frames, 0xF7])
