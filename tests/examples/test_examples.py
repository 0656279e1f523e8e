"""Every bundled routine validates cleanly, and every example script runs.

Routines: each file in choreographies/ loads, passes every check and compiles (through
:func:`validate_file`, as ``xgo-show validate`` does), with no warning other than the Rider's
hand-timed actions; the content claims in their headers (durations, the mirror duet) hold.
Examples: each script in examples/ runs as a user would run it (a subprocess, short arguments).
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from xgo_show.choreo import load_show, validate_file
from xgo_show.choreo.resolved import MotionCue, ResolvedTrack, SetCue
from xgo_show.compiler import compile_show, load_schedule

ROOT = Path(__file__).resolve().parents[2]
ROUTINES_DIR = ROOT / "choreographies"
EXAMPLES_DIR = ROOT / "examples"
ROUTINES = sorted(ROUTINES_DIR.glob("*.yaml"))

# The one warning a clean routine may carry: Rider actions have no documented run time.
ALLOWED_WARNING = "as given by hand (the documents give no duration)"

# Show durations the routines' headers promise, in seconds (low, high).
DURATIONS = {
    "curtain_call.yaml": (15.0, 18.0),
    "hello_mini.yaml": (12.0, 25.0),
    "duet_mini_lite_mirror.yaml": (55.0, 65.0),
    "rider_led_show.yaml": (55.0, 65.0),
    "mini_arm_gripper.yaml": (40.0, 60.0),
    "mixed_five.yaml": (165.0, 195.0),
    "solo_mini_120bpm.yaml": (55.0, 65.0),
    "xarm_hello.yaml": (20.0, 30.0),
}


def test_the_bundled_routines_are_all_there() -> None:
    assert {p.name for p in ROUTINES} >= set(DURATIONS)


@pytest.mark.parametrize("path", ROUTINES, ids=lambda p: p.name)
def test_routine_validates_without_errors(path: Path) -> None:
    diagnostics = validate_file(path)
    errors = [d.format() for d in diagnostics if d.is_error]
    assert errors == []
    unexpected = [d.format() for d in diagnostics if ALLOWED_WARNING not in d.message]
    assert unexpected == []


@pytest.mark.parametrize("path", ROUTINES, ids=lambda p: p.name)
def test_routine_lasts_what_its_header_says(path: Path) -> None:
    if path.name not in DURATIONS:
        pytest.skip("no duration claimed")
    low, high = DURATIONS[path.name]
    duration = compile_show(load_show(path)).duration
    assert low <= duration <= high


def test_every_part_is_used_by_a_routine() -> None:
    texts = [p.read_text(encoding="utf-8") for p in ROUTINES_DIR.rglob("*.yaml")]
    for part in sorted((ROUTINES_DIR / "parts").glob("*.yaml")):
        users = [t for t in texts if part.name in t]
        assert users, f"{part.name} is included by no routine"


def test_rider_show_warns_once_per_hand_timed_action() -> None:
    warnings = [d for d in validate_file(ROUTINES_DIR / "rider_led_show.yaml") if not d.is_error]
    assert len(warnings) == 5
    assert all(ALLOWED_WARNING in d.message for d in warnings)


# -- the mirror duet --------------------------------------------------------------------------

# Registers the Lite plays negated: lateral position, roll, yaw and the sideways/turning speeds.
MIRRORED = frozenset({"body_y", "roll", "yaw", "vy", "vyaw"})


def _values(track: ResolvedTrack) -> list[tuple[float, dict[str, object]]]:
    out: list[tuple[float, dict[str, object]]] = []
    for cue in track.cues:
        if isinstance(cue, MotionCue):
            out.append((cue.start, dict(cue.targets)))
        elif isinstance(cue, SetCue):
            out.append((cue.start, dict(cue.values)))
    return out


def test_the_lite_mirrors_the_mini_in_the_duet() -> None:
    show = load_show(ROUTINES_DIR / "duet_mini_lite_mirror.yaml")
    mini, lite = (next(t for t in show.tracks if t.model == m) for m in ("mini", "lite"))
    mini_values, lite_values = _values(mini), _values(lite)
    assert len(mini_values) == len(lite_values)
    mirrored = 0
    for (t_mini, a), (t_lite, b) in zip(mini_values, lite_values, strict=True):
        assert math.isclose(t_mini, t_lite, abs_tol=1e-9)
        assert a.keys() == b.keys()
        for name in a.keys() & MIRRORED:
            assert a[name] == -b[name]  # type: ignore[operator]
            mirrored += a[name] != 0
    assert mirrored > 20  # the duet really moves sideways, not just forward


# -- example scripts --------------------------------------------------------------------------

# Script -> (arguments, text its output must contain); "{tmp}" is a fresh directory.
# Short runs: a few seconds each.
EXAMPLES: dict[str, tuple[list[str], str]] = {
    # Only zenoh: loads, starts, fires 'go' at a serve --sim it starts as a separate process.
    "zenoh_control.py": (
        ["--serve", "--namespace", "test-example", "--show",
         str(ROUTINES_DIR / "curtain_call.yaml")],
        "trigger 'go': released section 'bow'",
    ),
    "load_and_validate.py": (
        [str(ROUTINES_DIR / "rider_led_show.yaml")], "0 error(s), 5 warning(s)"
    ),
    "compile_and_inspect.py": (
        [str(ROUTINES_DIR / "duet_mini_lite_mirror.yaml"), "--frames", "3",
         "--out", "{tmp}/duet.xshow.json"],
        "read back identical",
    ),
    "build_show_in_python.py": (
        ["--circles", "1", "--frames", "0", "--save", "{tmp}/built.xshow.json"],
        "Circles and colours",
    ),
    # The mixed show's finale only (from 150 s), to stay short: every robot kind plays.
    "dry_run_api.py": (
        [str(ROUTINES_DIR / "mixed_five.yaml"), "--start", "150"], "show completed"
    ),
    "drive_sim.py": (["--pace", "0.02"], "the robot received 11 frames"),
}


def _check_compile_and_inspect(out: str, tmp: Path) -> None:
    assert "first 3 of" in out
    schedule = load_schedule(tmp / "duet.xshow.json")
    assert [p.name for p in schedule.performers] == ["mira", "lumo"]


def _check_build_show_in_python(out: str, tmp: Path) -> None:
    schedule = load_schedule(tmp / "built.xshow.json")
    assert {p.model for p in schedule.performers} == {"mini", "rider"}
    assert all(p.frames for p in schedule.performers)


def _check_dry_run_api(out: str, tmp: Path) -> None:
    for name in ("ace", "bo", "lu", "rio", "maestro"):  # every robot of the mixed show played
        assert f"\n{name} (" in out and f"\n  {name} (" in out  # the report and its robot
    assert out.count(" 0 rejected;") == 5
    assert out.count("actions run: wave (action 13)") == 3  # the three dogs
    assert "circular_shake (action 6)" in out
    assert "rio: move body_z" in out  # the event listener printed the cues as they started


CHECKS = {
    "compile_and_inspect.py": _check_compile_and_inspect,
    "build_show_in_python.py": _check_build_show_in_python,
    "dry_run_api.py": _check_dry_run_api,
}


def _run(script: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(EXAMPLES_DIR / script), *args],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
        check=False,
    )


def test_every_example_script_is_exercised() -> None:
    assert {p.name for p in EXAMPLES_DIR.glob("*.py")} == set(EXAMPLES)


@pytest.mark.parametrize("script", sorted(EXAMPLES))
def test_example_runs(script: str, tmp_path: Path) -> None:
    args, expected = EXAMPLES[script]
    proc = _run(script, *(a.replace("{tmp}", str(tmp_path)) for a in args))
    assert proc.returncode == 0, proc.stderr
    assert expected in proc.stdout
    assert "Traceback" not in proc.stderr
    if script in CHECKS:
        CHECKS[script](proc.stdout, tmp_path)


def test_load_and_validate_reports_a_broken_routine(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "show: bad\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
        "    - {move: {body_z: 200}, duration: 1}\n",
        encoding="utf-8",
    )
    proc = _run("load_and_validate.py", str(bad))
    assert proc.returncode == 1
    assert "bad.yaml:6:" in proc.stdout
    assert "body_z" in proc.stdout
    assert "1 error(s)" in proc.stdout
