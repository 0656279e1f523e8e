"""Decode a sound file (WAV, FLAC, MP3, OGG Vorbis) into float samples with miniaudio.

miniaudio (the pyminiaudio binding of the single-file C library of the same name) is used for
decoding *and* playback: one wheel with no system library to install, dr_wav/dr_flac/dr_mp3 and
stb_vorbis built in, device back-ends (ALSA, PulseAudio, JACK, ...) loaded at run time, and a
null back-end that plays into nothing at the device's pace (what the tests use).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from xgo_show.errors import AudioError, FileAccessError
from xgo_show.files import file_problem

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

__all__ = ["AUDIO_EXTRA_HINT", "Audio", "decode", "require"]

AUDIO_EXTRA_HINT = "install the audio extra: pip install 'xgo-show[audio]'"


def require(module: str) -> Any:
    """Import an ``[audio]`` dependency, or fail with one line saying how to install it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise AudioError(f"{module} is not installed: {AUDIO_EXTRA_HINT}") from exc


@dataclass(frozen=True)
class Audio:
    """Decoded sound: ``samples`` has shape (frames, channels), float32 in -1..1."""

    samples: npt.NDArray[np.float32]
    sample_rate: int

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return len(self.samples) / self.sample_rate

    def mono(self) -> npt.NDArray[np.float32]:
        """The channels averaged into one."""
        mixed: npt.NDArray[np.float32] = self.samples.mean(axis=1, dtype="float32")
        return mixed


def decode(
    path: str | Path, *, channels: int | None = None, sample_rate: int | None = None
) -> Audio:
    """Decode ``path`` whole (at its own rate and channel count unless given).

    A missing, unreadable or undecodable file is an :class:`XgoShowError` naming it.
    """
    np = require("numpy")
    miniaudio = require("miniaudio")
    name = str(path)
    problem = file_problem(name)  # a pipe or a device is refused, not read
    if problem is not None:
        what = "no such sound file" if problem == "no such file" else problem
        raise FileAccessError(f"{name}: {what}")
    try:
        info = miniaudio.get_file_info(name)
        nch = channels or info.nchannels
        rate = sample_rate or info.sample_rate
        sound = miniaudio.decode_file(
            name, output_format=miniaudio.SampleFormat.FLOAT32, nchannels=nch, sample_rate=rate
        )
    except (miniaudio.MiniaudioError, OSError) as exc:
        raise AudioError(
            f"{name}: cannot decode it as WAV, FLAC, MP3 or OGG Vorbis ({exc})"
        ) from exc
    data = np.frombuffer(sound.samples, dtype=np.float32).reshape(-1, nch)
    return Audio(data, rate)
