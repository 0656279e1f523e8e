"""Audio for shows: decoding and beat analysis (``beats``), soundtrack playback on the show
clock (``player``), and following external time (MIDI timecode, OSC cues).

Everything here needs the ``[audio]`` extra (``pip install 'xgo-show[audio]'``): numpy and
miniaudio, imported on first use so that the rest of xgo-show runs without them.
"""
