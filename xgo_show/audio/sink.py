"""Where music goes: the default audio device, or miniaudio's null device.

Both are miniaudio playback devices that pull float32 frames from a callback on miniaudio's own
thread at the device's pace. The null device plays into nothing in real time, so a show's
timing with music can be exercised (and measured) on a machine without sound, CI included.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Generator, Iterator
from typing import TYPE_CHECKING, Any, Literal

from xgo_show.audio.decode import require
from xgo_show.errors import NoAudioDevice

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    Pull = Callable[[int], npt.NDArray[np.float32]]

__all__ = ["DEVICES", "AudioSink", "NoAudioDevice", "open_sink"]

DEVICES = ("default", "null")
RATE = 48000
CHANNELS = 2
BUFFER_MS = 20


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """ALSA prints a page of C-level errors to fd 2 while probing for cards: hide them."""
    try:
        saved = os.dup(2)
    except OSError:
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


class AudioSink:
    """A running playback device. ``latency`` is the device buffer: seconds between a buffer
    handed over and its sound, which the player renders ahead by."""

    def __init__(self, device: Any, name: str, rate: int, channels: int, latency: float) -> None:
        self._device = device
        self.name = name
        self.rate = rate
        self.channels = channels
        self.latency = latency
        self._started = False

    def start(self, pull: Pull) -> None:
        """Play what ``pull(frames)`` returns (shape (frames, channels)) until :meth:`close`."""
        def generator() -> Generator[Any, int, None]:
            frames = yield b""
            while True:
                block = pull(frames)
                frames = yield block.astype("float32").tobytes()

        gen = generator()
        next(gen)
        self._device.start(gen)
        self._started = True

    def close(self) -> None:
        """Stop playing and release the device (idempotent)."""
        if self._device is None:
            return
        device, self._device = self._device, None
        if self._started:
            device.stop()
        device.close()


def open_sink(device: Literal["default", "null"] = "default") -> AudioSink:
    """Open the default output (PulseAudio, ALSA, JACK, ... whichever answers) or the null
    device. :class:`NoAudioDevice` when there is none."""
    miniaudio = require("miniaudio")
    backend = miniaudio.Backend
    if device == "null":
        backends = [backend.NULL]
    else:
        backends = [b for b in backend if b not in (backend.NULL, backend.CUSTOM)]
    try:
        with _quiet_stderr():
            dev = miniaudio.PlaybackDevice(
                output_format=miniaudio.SampleFormat.FLOAT32,
                nchannels=CHANNELS,
                sample_rate=RATE,
                buffersize_msec=BUFFER_MS,
                backends=backends,
                app_name="xgo-show",
            )
    except miniaudio.MiniaudioError as exc:
        raise NoAudioDevice(f"no audio device ({exc.args[0] if exc.args else exc})") from exc
    return AudioSink(dev, f"{dev.backend}", dev.sample_rate, dev.nchannels, BUFFER_MS / 1000.0)
