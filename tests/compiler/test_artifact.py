"""Schedule files: round trip, determinism, and clear errors for bad files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show, load_schedule, save_schedule
from xgo_show.compiler.artifact import dumps_schedule
from xgo_show.errors import XgoShowError


@pytest.fixture
def show(make_show, o):  # type: ignore[no-untyped-def]
    return make_show({
        "rex": ("mini", [
            SetCue(0.0, o("setup", 2), {"gait": "walk", "pace": "slow"}),
            MotionCue(0.5, o("crouch", 3), {"body_z": 90.0, "pitch": 10.0}, duration=1.0),
            MotionCue(1.5, o("rise", 4), {"body_z": 110.0, "roll": 8.0}),
            ActionCue(3.5, o("dance", 5), 23, "dance", 6.0),
        ]),
        "wheels": ("rider", [FadeCue(0.0, o("glow", 7), "led1", (255, 40, 0), 0.5)]),
        "arm": ("xarm", [ArmCue(1.0, o("reach", 9), {1: 500, 2: 300}, 1.5)]),
    }, bpm=120.0)


def test_round_trip_is_exact(show, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    schedule = compile_show(show)
    path = save_schedule(schedule, tmp_path / "show.xshow.json")
    loaded = load_schedule(path)
    assert loaded == schedule
    assert save_schedule(loaded, tmp_path / "again.xshow.json").read_bytes() == path.read_bytes()


def test_compiling_twice_gives_identical_bytes(show, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    first = save_schedule(compile_show(show), tmp_path / "a.xshow.json").read_bytes()
    second = save_schedule(compile_show(show), tmp_path / "b.xshow.json").read_bytes()
    assert first == second


def test_file_is_documented_json_with_integer_times(show) -> None:  # type: ignore[no-untyped-def]
    doc = json.loads(dumps_schedule(compile_show(show)))
    assert doc["format"] == "xgo-show-schedule" and doc["version"] == 1
    rex = doc["performers"][0]
    assert rex["link"] == {"baud": 115200, "bits_per_byte": 10, "gap_us": 1000}
    frame = rex["frames"][0]
    assert frame == {"duration_us": 0, "hex": "550009000901ec00aa", "label": "gait=walk",
                     "origin": 0, "t_us": 0}
    assert doc["origins"][0] == {"column": 5, "cue": "setup", "file": "show.yaml", "line": 2}
    assert all(isinstance(f["t_us"], int) for p in doc["performers"] for f in p["frames"])


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.xshow.json"
    path.write_text(text, encoding="utf-8")
    return path


def _mutated(show, tmp_path: Path, change) -> Path:  # type: ignore[no-untyped-def]
    doc = json.loads(dumps_schedule(compile_show(show)))
    change(doc)
    return _write(tmp_path, json.dumps(doc))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.update(version=2), "version 2 was written by a newer xgo-show"),
        (lambda d: d.update(format="other"), "not an xgo-show schedule"),
        (lambda d: d.pop("performers"), "performers: missing"),
        (lambda d: d["performers"][0]["frames"][0].update(hex="5500zz"), "not hexadecimal"),
        (lambda d: d["performers"][0]["frames"][0].update(hex="550009000901ed00aa"),
         "not one valid XGO frame"),
        (lambda d: d["performers"][0]["frames"][1].update(t_us=-1), "must not be negative"),
        (lambda d: d["performers"][0]["frames"][0].update(t_us=99_000_000), "time order"),
        (lambda d: d["performers"][0].update(model="robodog"), "unknown robot model"),
        (lambda d: d["performers"][0]["frames"][0].update(origin=99), "no origin #99"),
        (lambda d: d["show"].update(control_rate="fast"), "expected int or float"),
        (lambda d: d["show"].update(battery_floor=150), "150 is not a percentage"),
        (lambda d: d["show"].update(tempo_map=[[1, 120]]), "expected \\[first bar, bpm"),
        (lambda d: d["show"].update(tempo_map=[[2, 120, 4]]), "must start at bar 1"),
    ],
)
def test_bad_files_give_clear_errors(show, tmp_path: Path, change, message: str) -> None:  # type: ignore[no-untyped-def]
    path = _mutated(show, tmp_path, change)
    with pytest.raises(XgoShowError, match=message) as err:
        load_schedule(path)
    assert str(path) in str(err.value)


def test_tempo_changes_survive_the_file(make_show, o, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [ActionCue(0.0, o("bow", 2), 14, "bow", 3.0)])},
                     bpm=120.0, beats_per_bar=4, tempo_map=((1, 120.0, 4), (3, 60.0, 3)))
    loaded = load_schedule(save_schedule(compile_show(show), tmp_path / "t.xshow.json"))
    assert loaded.tempo_map == ((1, 120.0, 4), (3, 60.0, 3))
    tempo = loaded.tempo()
    assert tempo is not None
    assert tempo.position(3) == pytest.approx(4.0)  # two 4/4 bars at 120 bpm
    assert tempo.position(4) == pytest.approx(7.0)  # then a 3/4 bar at 60 bpm


def test_files_without_a_tempo_map_use_their_bpm(show, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = _mutated(show, tmp_path, lambda d: d["show"].pop("tempo_map"))
    tempo = load_schedule(path).tempo()
    assert tempo is not None and tempo.position(2) == pytest.approx(2.0)


def test_not_json_or_missing_file(tmp_path: Path) -> None:
    with pytest.raises(XgoShowError, match="invalid JSON at line 1"):
        load_schedule(_write(tmp_path, "{nope"))
    with pytest.raises(XgoShowError, match=r"cannot read schedule .*missing"):
        load_schedule(tmp_path / "missing.xshow.json")
    with pytest.raises(XgoShowError, match="not an xgo-show schedule"):
        load_schedule(_write(tmp_path, "[1, 2]"))


def _arm_frame(doc: dict, hex_text: str) -> None:  # type: ignore[type-arg]
    arm = next(p for p in doc["performers"] if p["model"] == "xarm")
    arm["frames"][0]["hex"] = hex_text


@pytest.mark.parametrize(
    ("hex_text", "message"),
    [
        # Garbage after a valid header: command 9 does not exist.
        ("555509000102030405060708", "not one valid xArm packet"),
        # Two packets in one frame: a frame is one packet.
        ("55550207" "55550207", "not one valid xArm packet"),
        # A valid GroupStop with a byte left over.
        ("5555020700", "not one valid xArm packet"),
        # A truncated ServoMove (count says 2 servos, 1 given).
        ("55550803" "02c800" "01f401", "not one valid xArm packet"),
        ("", "not one valid xArm packet"),
        # A reply (battery voltage), not a request.
        ("5555040f" "b01d", "GetBatteryVoltage reply, not a request"),
        # Well framed, but position 1500 is out of range.
        ("55550803" "01c800" "01dc05", "position 1500 must be 0..1000"),
    ],
)
def test_xarm_frames_are_decoded_on_load(show, tmp_path: Path, hex_text: str, message: str) -> None:  # type: ignore[no-untyped-def]
    path = _mutated(show, tmp_path, lambda d: _arm_frame(d, hex_text))
    with pytest.raises(XgoShowError, match=message) as err:
        load_schedule(path)
    text = str(err.value)
    assert str(path) in text and "performer arm frame 0" in text and ".frames[0].hex" in text


def test_unsafe_xarm_commands_load_and_are_left_to_the_runtime(show, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from xgo_show.wire.xarm import servo_offset_write

    # A valid packet of a known command loads; refusing it is the runtime's job (--allow-unsafe).
    path = _mutated(show, tmp_path, lambda d: _arm_frame(d, servo_offset_write(2, -5).hex()))
    arm = load_schedule(path).performer("arm")
    assert arm.frames[0].data == servo_offset_write(2, -5)
