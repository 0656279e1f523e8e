"""Schedule files: round trip, determinism, size, the bytes API and clear errors for bad files."""

from __future__ import annotations

import base64
import json
import zlib
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show, load_schedule, save_schedule
from xgo_show.compiler.artifact import (
    _canonical,
    _envelope,
    schedule_digest,
    schedule_from_bytes,
    schedule_to_bytes,
)
from xgo_show.errors import XgoShowError

VERSION1 = Path(__file__).parent / "data" / "version1.xshow.json"


@pytest.fixture
def show(make_show, o):  # type: ignore[no-untyped-def]
    # The show tests/compiler/data/version1.xshow.json was written from (by the version 1 writer).
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
    assert [f.label for p in loaded.performers for f in p.frames] == [
        f.label for p in schedule.performers for f in p.frames]
    assert save_schedule(loaded, tmp_path / "again.xshow.json").read_bytes() == path.read_bytes()


def test_compiling_twice_gives_identical_bytes_and_digest(show) -> None:  # type: ignore[no-untyped-def]
    first, second = compile_show(show), compile_show(show)
    assert schedule_to_bytes(first) == schedule_to_bytes(second)
    assert schedule_digest(first) == schedule_digest(second)
    assert len(schedule_digest(first)) == 64


def test_file_is_one_line_of_json_around_a_digested_body(show) -> None:  # type: ignore[no-untyped-def]
    schedule = compile_show(show)
    data = schedule_to_bytes(schedule)
    assert data.count(b"\n") == 1 and data.startswith(b'{"format":"xgo-show-schedule"')
    envelope = json.loads(data)
    assert envelope["version"] == 2 and envelope["encoding"] == "zlib+base64"
    body = zlib.decompress(base64.b64decode(envelope["body"]))
    assert body == _canonical(schedule)
    assert envelope["sha256"] == schedule_digest(schedule)
    size = int.from_bytes(body[:4], "little")
    doc = json.loads(body[4:4 + size])
    rex = doc["performers"][0]
    assert rex["link"] == {"baud": 115200, "bits_per_byte": 10, "gap_us": 1200}
    assert rex["frames"] == len(schedule.performer("rex").frames)
    assert doc["origins"][0] == {"column": 5, "cue": "setup", "file": "show.yaml", "line": 2}


def test_a_show_file_is_smaller_than_its_bytes_on_the_wire(make_show, o) -> None:  # type: ignore[no-untyped-def]
    moves = [MotionCue(2.0 * i, o(f"m{i}", i + 2), {"body_z": 80.0 + 10 * (i % 3),
                                                    "roll": 5.0 - 5 * (i % 3)}, 2.0)
             for i in range(15)]
    schedule = compile_show(make_show({"rex": ("mini", moves)}))
    wire = sum(p.total_bytes for p in schedule.performers)
    assert wire > 10_000
    assert len(schedule_to_bytes(schedule)) < 1.5 * wire


def test_version_1_files_still_load(show, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    old = load_schedule(VERSION1)
    stored = json.loads(VERSION1.read_text(encoding="utf-8"))
    # Labels are derived from the bytes: the very ones the old file stored.
    assert [f.label for p in old.performers for f in p.frames] == [
        f["label"] for p in stored["performers"] for f in p["frames"]]
    again = schedule_from_bytes(schedule_to_bytes(old))
    assert again == old and again.tempo_map == old.tempo_map
    assert [p.name for p in old.performers] == ["rex", "wheels", "arm"]


def _wrapped(schedule_bytes: bytes, change) -> bytes:  # type: ignore[no-untyped-def]
    """The file of ``schedule_bytes`` with its canonical body changed (and a matching digest)."""
    body = bytearray(zlib.decompress(base64.b64decode(json.loads(schedule_bytes)["body"])))
    return _envelope(bytes(change(body)))


def _doc_changed(change):  # type: ignore[no-untyped-def]
    def on_body(body: bytearray) -> bytes:
        size = int.from_bytes(body[:4], "little")
        doc = json.loads(body[4:4 + size])
        change(doc)
        head = json.dumps(doc).encode()
        return len(head).to_bytes(4, "little") + head + bytes(body[4 + size:])
    return on_body


def _last_frame_byte_flipped(body: bytearray) -> bytearray:
    body[-1] = 0xFF  # the arm's last frame: the high byte of its last servo's position
    return body


def _first_rex_frame_broken(body: bytearray) -> bytearray:
    size = int.from_bytes(body[:4], "little")
    n = json.loads(body[4:4 + size])["performers"][0]["frames"]
    at = 4 + size + n * (8 + 2 + 4 + 8)  # the columns of rex's n frames, then its bytes
    body[at + 5] ^= 0xFF  # the first frame's data: its checksum no longer matches
    return body


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda b: b + b"\0", "1 bytes after the last performer's frames"),
        (lambda b: b[:-1], "the body ends inside its frames' bytes"),
        (lambda b: b[:30], "its document is cut short"),
        (_first_rex_frame_broken, "performers\\[0\\].frames\\[0\\]: performer rex frame 0: "
                                  "not one valid XGO frame"),
        (_last_frame_byte_flipped, "performer arm frame 0: .*must be 0..1000"),
        (_doc_changed(lambda d: d["performers"][0].update(frames=10**6)),
         "the body ends inside its frame columns"),
        (_doc_changed(lambda d: d["origins"].clear()), "no origin #0 \\(the table has 0\\)"),
        (_doc_changed(lambda d: d.update(version=1)), "not a version 2 schedule document"),
        (_doc_changed(lambda d: d["show"].update(battery_floor=150)), "150 is not a percentage"),
    ],
)
def test_bad_bodies_give_clear_errors(show, change, message: str) -> None:  # type: ignore[no-untyped-def]
    data = _wrapped(schedule_to_bytes(compile_show(show)), change)
    with pytest.raises(XgoShowError, match=message) as err:
        schedule_from_bytes(data, name="sent.xshow.json")
    assert str(err.value).startswith("sent.xshow.json: ")


def _envelope_changed(data: bytes, **changes: object) -> bytes:
    envelope = json.loads(data)
    envelope.update(changes)
    return json.dumps(envelope).encode()


def test_bad_envelopes_give_clear_errors(show) -> None:  # type: ignore[no-untyped-def]
    data = schedule_to_bytes(compile_show(show))
    body = json.loads(data)["body"]
    cases = {
        _envelope_changed(data, sha256="0" * 64): "does not match its digest",
        _envelope_changed(data, body=body[:-8]): "not zlib data|truncated",
        _envelope_changed(data, body="***"): "body: not base64",
        _envelope_changed(data, encoding="gzip"): "unknown encoding 'gzip'",
        _envelope_changed(data, version=3): "version 3 was written by a newer xgo-show",
        _envelope_changed(data, version=0): "unknown schedule format version 0",
        _envelope_changed(data, format="other"): "not an xgo-show schedule",
        data[:100]: "invalid JSON",
        b"\xff\xfe": "not UTF-8",
        b"[" * 100_000 + b"]" * 100_000: "nested too deeply|invalid JSON",
    }
    for bad, message in cases.items():
        with pytest.raises(XgoShowError, match=message):
            schedule_from_bytes(bad)


def test_size_caps_refuse_big_files_and_bodies_that_inflate_past_them(show) -> None:  # type: ignore[no-untyped-def]
    data = schedule_to_bytes(compile_show(show))
    with pytest.raises(XgoShowError, match="larger than 100 bytes"):
        schedule_from_bytes(data, max_bytes=100)
    # A small file whose body inflates past the cap (a zip bomb) is refused as it inflates.
    bomb = _envelope_changed(data, body=base64.b64encode(zlib.compress(bytes(10**6))).decode())
    assert len(bomb) < 5000
    with pytest.raises(XgoShowError, match="inflates to more than 5,000 bytes"):
        schedule_from_bytes(bomb, max_bytes=5000)


@settings(max_examples=60, deadline=None)
@given(st.binary(max_size=300))
def test_any_bytes_load_or_give_one_clear_error(junk: bytes) -> None:
    with pytest.raises(XgoShowError):
        schedule_from_bytes(junk)


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.xshow.json"
    path.write_text(text, encoding="utf-8")
    return path


def _mutated(show, tmp_path: Path, change) -> Path:  # type: ignore[no-untyped-def]
    """The version 1 file, changed: its document is what version 2 bodies hold, but readable."""
    doc = json.loads(VERSION1.read_text(encoding="utf-8"))
    change(doc)
    return _write(tmp_path, json.dumps(doc))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.update(version=3), "version 3 was written by a newer xgo-show"),
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


def _key_twice(text: str, key: str) -> str:
    """``text`` (JSON) with the first ``"key": value`` written again before it, changed."""
    at = text.index(f'"{key}"')
    return text[:at] + f'"{key}": 1e-3, ' + text[at:]


@pytest.mark.parametrize("key", ["control_rate", "version", "t_us", "name"])
def test_a_key_written_twice_is_refused_not_read_as_the_last(key: str) -> None:
    """json keeps the last of two equal keys: a hand-edited schedule would be run with a
    value other than the one a reader of the file sees first."""
    text = VERSION1.read_text(encoding="utf-8")
    with pytest.raises(XgoShowError, match=f"the key '{key}' appears twice in one object"):
        schedule_from_bytes(_key_twice(text, key).encode(), name="edited.xshow.json")


def test_a_key_written_twice_inside_the_body_is_refused(show) -> None:  # type: ignore[no-untyped-def]
    def twice(body: bytearray) -> bytes:
        size = int.from_bytes(body[:4], "little")
        head = _key_twice(body[4:4 + size].decode(), "bpm").encode()
        return len(head).to_bytes(4, "little") + head + bytes(body[4 + size:])

    data = _wrapped(schedule_to_bytes(compile_show(show)), twice)
    with pytest.raises(XgoShowError, match="the key 'bpm' appears twice"):
        schedule_from_bytes(data, name="sent.xshow.json")
