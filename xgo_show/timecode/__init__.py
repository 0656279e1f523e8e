"""Following external time: MIDI timecode (MTC) and OSC cues from a sound desk, a DAW or QLab.

:mod:`.mtc` and :mod:`.osc` turn bytes into positions and commands (pure parsers); :mod:`.chase`
decides what the show does about them (lock, follow, hold or stop on a jump or dropout) on an
injected clock. Needs the ``[timecode]`` extra (mido, python-osc).
"""
