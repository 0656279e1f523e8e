"""Wire codecs: pure functions and streaming decoders, no I/O and no clock."""
