"""A wait's hold and release on the robot's link: no rest frames when the show has the robot at
rest there, a catch-up of only what the rest frames changed, and the section's first frame
first (the compiler's reach, which the executor asks at a hold)."""

from __future__ import annotations

from pathlib import Path

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show
from xgo_show.compiler.state import state_at
from xgo_show.profiles import get_profile
from xgo_show.runtime.show_runner import default_reach

WALK = """\
show: Walk then wait
performers:
  rex: {model: mini}
sections:
  - {name: a}
  - {name: b, at: 1.0, wait: {trigger: go}}
tracks:
  rex:
    - {move: {pitch: 8}, duration: 0.6}
    - {at: 0.7, set: {vx: 10}}
    - {at: 1.0, set: {body_z: 90}}
    - {at: 1.5, set: {vx: 0}}
"""

POSE = """\
show: Pose then wait
performers:
  rex: {model: mini}
sections:
  - {name: a}
  - {name: b, at: 1.0, wait: {trigger: go}}
tracks:
  rex:
    - {move: {pitch: 8}, duration: 0.6}
    - {at: 1.0, set: {body_z: 90, vx: 5}}
"""


def _reach(tmp_path: Path, text: str):  # type: ignore[no-untyped-def]
    path = tmp_path / "show.yaml"
    path.write_text(text, encoding="utf-8")
    perf = compile_show(load_show(path)).performers[0]
    return perf, default_reach(perf, get_profile(perf.model))


def test_a_robot_walking_into_a_wait_is_rested_and_its_walk_given_back(tmp_path: Path) -> None:
    _, reach = _reach(tmp_path, WALK)
    assert not reach.at_rest(1.0)  # walking: the hold must rest it
    # The walk goes on after the release: vx written back, and nothing of the posture, which
    # a hold keeps (the whole state, for a start or a seek, has it all).
    assert [label for _, label in reach.after_rest(1.0)] == ["vx=10.0mm/step"]
    whole = " ".join(label for _, label in reach(1.0))
    assert "pitch=8.0deg" in whole and "body_z=90.0mm" in whole


def test_a_robot_at_rest_holds_without_rest_frames_and_goes_on_with_its_own_frame(
    tmp_path: Path
) -> None:
    perf, reach = _reach(tmp_path, POSE)
    assert reach.at_rest(1.0)
    # vx is written at 1.0 by the section's own first frame: not by a catch-up before it.
    assert "vx" in state_at(perf, 1.0)
    assert reach.after_rest(1.0) == []
