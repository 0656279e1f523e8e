"""A move given too little time is said in the user's unit, names its segment, and is said once
however many tracks play the phrase."""

from __future__ import annotations

from pathlib import Path

from xgo_show.choreo import validate_file

ROUTINE = """\
show: Too short
tempo: {bpm: 120}
performers:
  rex: {model: mini}
  bo: {model: mini}
phrases:
  zig:
    cues:
      - {move: {body_z: [110, 85]}, beats: 1}
tracks:
  rex:
    - {phrase: zig}
  bo:
    - {phrase: zig}
    - {move: {pitch: 20}, duration: 0.05}
"""


def test_said_in_beats_per_segment_and_once(tmp_path: Path) -> None:
    path = tmp_path / "show.yaml"
    path.write_text(ROUTINE)
    errors = [d for d in validate_file(path) if d.is_error]
    texts = [d.format() for d in errors]  # in file order
    assert len(texts) == 3, texts
    first, second, seconds = texts
    # The phrase's line, once for both tracks that play it, each segment with its target.
    assert first.startswith(f"{path}:9:9: error: tracks.rex, tracks.bo: segment 1 of 2 of the "
                            "move (to body_z 110) needs at least 0.")
    assert second.startswith(f"{path}:9:9: error: tracks.rex, tracks.bo: segment 2 of 2 of the "
                             "move (to body_z 85) needs at least 0.")
    # Beats as the user wrote them (half a beat each) and the seconds they make.
    assert " beats) under its limits" in first and "given 0.5 beats (0.25 s)" in first
    # Given in seconds: said in seconds only.
    assert seconds.endswith("but is given 0.05 s") and " beats" not in seconds.split(": error: ")[1]
