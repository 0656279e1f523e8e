"""The schedule file's bytes on hand-made schedules, to the byte and word for word: the body's
layout (a document compact, keys sorted, UTF-8, then each performer's columns), performers
without frames or frames without a cue, every refusal with its place, the size caps at their
edges, and which files count as schedules."""

from __future__ import annotations

import base64
import hashlib
import json
import os
import tracemalloc
import zlib
from pathlib import Path

import pytest

from xgo_show.choreo.music import Music
from xgo_show.choreo.sections import Section, Wait
from xgo_show.compiler import load_schedule, save_schedule
from xgo_show.compiler.artifact import (
    _canonical,
    _envelope,
    _first_bad_frame,
    _performer_columns,
    is_schedule_file,
    schedule_from_bytes,
    schedule_to_bytes,
)
from xgo_show.compiler.document import frame_problem
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.diagnostics import Origin
from xgo_show.errors import XgoShowError
from xgo_show.profiles import get_profile
from xgo_show.wire.xgo import write_frame

MINI = get_profile("mini")
BODY_Z = MINI.register("body_z")
PITCH = MINI.register("pitch")
CUE = Origin("show.yaml", 3, 5, "élan")  # not ASCII: the document is UTF-8
OTHER = Origin("show.yaml", 7, 5, "rise")


def _z(mm: float) -> bytes:
    return write_frame(BODY_Z.address, bytes((BODY_Z.to_byte(mm),)))


def _performer(name: str, frames: list[ScheduledFrame]) -> PerformerSchedule:
    return PerformerSchedule(name, "mini", MINI.link, tuple(frames), 2.0)


def _schedule(*performers: PerformerSchedule, **fields: object) -> Schedule:
    return Schedule("Pas de deux", "show.yaml", performers, 50.0, **fields)  # type: ignore[arg-type]


def _rex() -> PerformerSchedule:
    # The first frame has no cue (as a frame the compiler files under none would).
    return _performer("rex", [
        ScheduledFrame(0.0, _z(90.0)),
        ScheduledFrame(0.5, _z(100.0), CUE, 0.25),
        ScheduledFrame(0.5, write_frame(PITCH.address, bytes((PITCH.to_byte(5.0),))), OTHER),
        ScheduledFrame(1.0, _z(110.0), None),
    ])


def _body(schedule: Schedule) -> tuple[dict[str, object], bytes, bytes]:
    """The canonical body's document, its text and its columns."""
    body = _canonical(schedule)
    size = int.from_bytes(body[:4], "little")
    text = body[4:4 + size]
    return json.loads(text), text, body[4 + size:]


def _fails(data: bytes, message: str, **kwargs: object) -> None:
    with pytest.raises(XgoShowError) as err:
        schedule_from_bytes(data, **kwargs)  # type: ignore[arg-type]
    assert str(err.value) == message


def test_performers_without_frames_and_frames_without_a_cue_round_trip() -> None:
    idle = _performer("idle", [])
    for schedule in (_schedule(_rex(), idle), _schedule(idle), _schedule(idle, _rex())):
        loaded = schedule_from_bytes(schedule_to_bytes(schedule))
        assert loaded == schedule
        assert [[f.origin for f in p.frames] for p in loaded.performers] == [
            [f.origin for f in p.frames] for p in schedule.performers]
    doc, _, columns = _body(_schedule(_rex()))
    # Time from the previous frame, lengths, origins (0: none, else index + 1), durations.
    n = 4
    assert list(columns[:8 * n:8]) == [0, 0x20, 0, 0x20]  # 0, 500000 (0x07a120), 0, 500000
    assert [int.from_bytes(columns[i:i + 8], "little") for i in range(0, 8 * n, 8)] == [
        0, 500_000, 0, 500_000]
    origins = columns[10 * n:14 * n]
    assert [int.from_bytes(origins[i:i + 4], "little") for i in range(0, 4 * n, 4)] == [
        0, 1, 2, 0]
    durations = columns[14 * n:22 * n]
    assert [int.from_bytes(durations[i:i + 8], "little") for i in range(0, 8 * n, 8)] == [
        0, 250_000, 0, 0]
    assert doc["origins"] == [{"column": 5, "cue": "élan", "file": "show.yaml", "line": 3},
                              {"column": 5, "cue": "rise", "file": "show.yaml", "line": 7}]


def test_the_origin_column_asks_the_table_once_for_each_cue() -> None:
    # A Rider's move and LED fades alternate frame by frame: the table is asked once for each
    # cue (in the order frames first name them), not once a frame, and each frame still gets
    # its own cue's index (0: none, else the table's index + 1).
    cues = [CUE, OTHER, CUE, OTHER, None, CUE, None, OTHER]
    rex = _performer("rex", [ScheduledFrame(0.1 * i, _z(90.0), cue) for i, cue in
                             enumerate(cues)])
    asked: list[Origin | None] = []
    table = {CUE: 6, OTHER: 2}

    def ref(origin: Origin | None) -> int | None:
        asked.append(origin)
        return None if origin is None else table[origin]

    columns = _performer_columns(rex, ref)
    n = len(cues)
    origins = columns[10 * n:14 * n]
    assert [int.from_bytes(origins[i:i + 4], "little") for i in range(0, 4 * n, 4)] == [
        7, 3, 7, 3, 0, 7, 0, 3]
    assert asked == [CUE, OTHER, None]


def test_frames_out_of_time_order_are_not_written() -> None:
    rex = _performer("rex", [ScheduledFrame(1.0, _z(90.0)), ScheduledFrame(0.5, _z(100.0))])
    with pytest.raises(XgoShowError) as err:
        schedule_to_bytes(_schedule(rex))
    assert str(err.value) == "performer rex: frames are not in time order"


def test_the_body_is_its_document_compact_with_sorted_keys_in_utf8() -> None:
    # Whatever version the object says, the writer writes its own format's. Sections and
    # music are objects whose fields are not made in sorted order.
    sections = (Section("intro", 0.0, None, CUE),
                Section("drop", 1.0, Wait("go", 5.0, "end"), OTHER))
    music = Music("song.ogg", "/music/song.ogg", 0.25)
    schedule = _schedule(_rex(), version=1, sections=sections, music=music)
    doc, text, _ = _body(schedule)
    assert text.decode("utf-8") == json.dumps(doc, sort_keys=True, ensure_ascii=False,
                                              separators=(",", ":"))
    assert "élan".encode() in text and b"\\u" not in text
    assert sorted(doc) == ["format", "origins", "performers", "show", "version", "warnings"]
    assert doc["version"] == 2
    assert schedule_from_bytes(schedule_to_bytes(schedule)) == _schedule(
        _rex(), sections=sections, music=music)
    # The envelope: the body deflated at level 1 (the fast level), in base64, and its digest.
    body = _canonical(schedule)
    envelope = json.loads(schedule_to_bytes(schedule))
    assert envelope["body"] == base64.b64encode(zlib.compress(body, 1)).decode("ascii")
    assert envelope["sha256"] == hashlib.sha256(body).hexdigest()


def test_a_schedule_that_cannot_be_written_says_where(tmp_path: Path) -> None:
    with pytest.raises(XgoShowError) as err:
        save_schedule(_schedule(_rex()), tmp_path)
    assert str(err.value) == f"cannot write schedule {tmp_path}: Is a directory"


def test_the_size_caps_hold_at_their_edges(tmp_path: Path) -> None:
    data = schedule_to_bytes(_schedule(_rex()))
    assert schedule_from_bytes(data, max_bytes=len(data)) == _schedule(_rex())
    _fails(data, f"<schedule>: larger than {len(data) - 1:,} bytes: not a schedule this reads",
           max_bytes=len(data) - 1)
    # A body of exactly the cap inflates; one byte more does not (here: 1000 zero bytes,
    # whose "document" is then empty).
    zeros = _envelope(bytes(1000))
    _fails(zeros, "<schedule>: body: its document is not JSON (Expecting value: line 1 column "
           "1 (char 0))", max_bytes=1000)
    _fails(zeros, "<schedule>: body: inflates to more than 999 bytes", max_bytes=999)
    # load_schedule hands its cap on to the body too.
    path = tmp_path / "zeros.xshow.json"
    path.write_bytes(zeros)
    with pytest.raises(XgoShowError) as err:
        load_schedule(path, max_bytes=999)
    assert str(err.value) == f"{path}: body: inflates to more than 999 bytes"


def test_a_zip_bomb_is_never_inflated_past_the_cap() -> None:
    bomb = _envelope(bytes(20_000_000))
    assert len(bomb) < 150_000
    tracemalloc.start()
    try:
        with pytest.raises(XgoShowError, match="inflates to more than 200,000 bytes"):
            schedule_from_bytes(bomb, max_bytes=200_000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 3_000_000  # the 20 MB body is never made


def test_numbers_of_more_digits_than_any_schedule_value_are_refused() -> None:
    def envelope(version: str) -> bytes:
        return f'{{"format": "xgo-show-schedule", "version": {version}}}'.encode()

    _fails(envelope("1" * 19), "<schedule>: not a schedule file (the number 111111111111... "
           "has 19 digits: far too large)")
    _fails(envelope("-" + "1" * 19), "<schedule>: not a schedule file (the number "
           "-11111111111... has 20 digits: far too large)")
    # 18 digits are read (and then found to be a version from the future).
    _fails(envelope("1" * 18), f"<schedule>: schedule format version {'1' * 18} was written "
           "by a newer xgo-show; this one reads versions 1 to 2: upgrade xgo-show or compile "
           "the show again")


@pytest.mark.parametrize(("version", "message"), [
    (None, "version: missing or not an integer"),
    ('"2"', "version: missing or not an integer"),
    ("true", "version: missing or not an integer"),
    ("1.0", "version: missing or not an integer"),
    ("0", "version: unknown schedule format version 0"),
    ("-1", "version: unknown schedule format version -1"),
])
def test_a_version_must_be_a_known_integer(version: str | None, message: str) -> None:
    field = "" if version is None else f', "version": {version}'
    data = f'{{"format": "xgo-show-schedule"{field}, "performers": []}}'.encode()
    _fails(data, f"shown.json: {message}", name="shown.json")


def _envelope_with(**fields: object) -> bytes:
    envelope = json.loads(schedule_to_bytes(_schedule(_rex())))
    for key, value in fields.items():
        if value is None:
            del envelope[key]
        else:
            envelope[key] = value
    return json.dumps(envelope).encode()


@pytest.mark.parametrize(("fields", "message"), [
    ({"encoding": None}, "encoding: missing"),
    ({"encoding": "gzip"}, "encoding: unknown encoding 'gzip' (this reads 'zlib+base64')"),
    ({"sha256": None}, "sha256: missing"),
    ({"body": None}, "body: missing"),
    ({"body": "a*"}, "body: not base64"),
    ({"body": base64.b64encode(b"not deflated").decode()},
     "body: not zlib data (Error -3 while decompressing data: incorrect header check)"),
    ({"body": base64.b64encode(zlib.compress(b"body") + b"more").decode()},
     "body: truncated or followed by other data"),
    ({"body": base64.b64encode(zlib.compress(b"body")[:-3]).decode()},
     "body: truncated or followed by other data"),
    ({"sha256": "0" * 64}, "sha256: the body does not match its digest (the file is damaged)"),
])
def test_each_envelope_refusal_names_its_field(fields: dict[str, object], message: str
                                               ) -> None:
    _fails(_envelope_with(**fields), f"sent.json: {message}", name="sent.json")


@pytest.mark.parametrize(("body", "message"), [
    (b"\x00\x00\x00", "its document is cut short"),
    (b"\x05\x00\x00\x00{}", "its document is cut short"),
    (b"\x00\x00\x00\x00", "its document is not JSON (Expecting value: line 1 column 1 (char 0))"),
    (b"\x02\x00\x00\x00{}", "its document is not a version 2 schedule document"),
    (b"\x02\x00\x00\x00[]", "its document is not a version 2 schedule document"),
    (b'\x1e\x00\x00\x00{"format":"xgo-show-schedule"}',
     "its document is not a version 2 schedule document"),
])
def test_each_body_refusal_names_the_body(body: bytes, message: str) -> None:
    _fails(_envelope(body), f"sent.json: body: {message}", name="sent.json")


def _cut(schedule: Schedule, keep: int) -> bytes:
    """The file of ``schedule`` with its body cut ``keep`` bytes into the frame columns."""
    body = _canonical(schedule)
    size = int.from_bytes(body[:4], "little")
    return _envelope(body[:4 + size + keep])


def test_a_body_cut_inside_any_column_is_refused_at_the_performer() -> None:
    schedule = _schedule(_rex())
    n = 4
    columns = "sent.json: performers[0].frames: the body ends inside its frame columns"
    for keep in (8 * n - 1, 10 * n - 1, 14 * n - 1, 22 * n - 1):  # in each of the 4 columns
        _fails(_cut(schedule, keep), columns, name="sent.json")
    _fails(_cut(schedule, 22 * n + 9), "sent.json: performers[0].frames: the body ends inside "
           "its frames' bytes", name="sent.json")
    body = _canonical(schedule)
    _fails(_envelope(body + b"\x00\x00"), "sent.json: body: 2 bytes after the last "
           "performer's frames", name="sent.json")


def _document_changed(schedule: Schedule, change: object) -> bytes:
    doc, _, columns = _body(schedule)
    change(doc)  # type: ignore[operator]
    head = json.dumps(doc).encode()
    return _envelope(len(head).to_bytes(4, "little") + head + columns)


def test_a_frame_count_must_be_there_and_not_negative() -> None:
    schedule = _schedule(_rex())
    _fails(_document_changed(schedule, lambda d: d["performers"][0].pop("frames")),
           "sent.json: performers[0].frames: missing", name="sent.json")
    _fails(_document_changed(schedule, lambda d: d["performers"][0].update(frames=-1)),
           "sent.json: performers[0].frames: must not be negative", name="sent.json")


def test_an_origin_one_past_the_table_is_refused() -> None:
    schedule = _schedule(_rex())
    body = bytearray(_canonical(schedule))
    size = int.from_bytes(body[:4], "little")
    at = 4 + size + 10 * 4 + 4 * 3  # the 4th frame's origin: 0 (none)
    body[at] = 3  # the table has 2: #2 is one past it
    _fails(_envelope(bytes(body)), "sent.json: performers[0].frames[3].origin: no origin #2 "
           "(the table has 2)", name="sent.json")
    body[at] = 2  # the last one there is
    assert schedule_from_bytes(_envelope(bytes(body))).performers[0].frames[3].origin == OTHER


def _variants(frame: bytes) -> list[bytes]:
    """``frame`` with each byte set to every other value, cut short and lengthened."""
    out = [frame[:i] for i in range(len(frame))] + [frame + b"\xaa", frame + frame]
    for i in range(len(frame)):
        for value in range(256):
            if value != frame[i]:
                out.append(frame[:i] + bytes((value,)) + frame[i + 1:])
    return out


def _checked(frame: bytes) -> bytes:
    """``frame`` with its checksum made right for its other bytes."""
    return frame[:-3] + bytes(((~sum(frame[2:-3])) & 0xFF,)) + frame[-2:]


def _fields_changed(frame: bytes) -> list[bytes]:
    """``frame`` with each byte between header and checksum set to every other value, the
    checksum made right; and its length and type bytes changed together."""
    out = []
    for i in range(2, len(frame) - 3):
        out += [_checked(frame[:i] + bytes((v,)) + frame[i + 1:]) for v in range(256)
                if v != frame[i]]
    out += [_checked(frame[:2] + bytes((n, t)) + frame[4:]) for n in range(256)
            for t in range(16)]
    return out


def test_a_frame_is_accepted_exactly_when_it_is_one_valid_frame() -> None:
    # The loader's quick check of a performer's frames must agree with frame_problem on
    # every frame, valid or not.
    rider = get_profile("rider")
    white = write_frame(rider.register("led1").address, bytes((255, 255, 255)))
    for profile, frame in ((MINI, _z(100.0)),
                           (MINI, write_frame(PITCH.address, bytes((PITCH.to_byte(-5.0),)))),
                           (rider, white)):
        assert _first_bad_frame(profile, [frame]) is None
        for bad in _variants(frame) + _fields_changed(frame):
            problem = frame_problem(profile, bad)
            assert _first_bad_frame(profile, [bad]) == (None if problem is None
                                                        else (0, problem))
            assert _first_bad_frame(profile, [frame, bad]) == (None if problem is None
                                                                else (1, problem))


V1_FRAME = {"t_us": 0, "hex": _z(90.0).hex(), "origin": None, "duration_us": 0}


def _v1(frames: object) -> bytes:
    doc = json.loads(schedule_to_bytes(_schedule(_performer("rex", []))))
    body = zlib.decompress(base64.b64decode(doc["body"]))
    size = int.from_bytes(body[:4], "little")
    inner = json.loads(body[4:4 + size])
    inner["version"] = 1
    inner["origins"] = [{"column": 5, "cue": "c", "file": "show.yaml", "line": 2}]
    inner["performers"][0]["frames"] = frames
    return json.dumps(inner).encode()


@pytest.mark.parametrize(("frames", "message"), [
    (None, "performers[0].frames: expected list, not NoneType"),
    ([7], "performers[0].frames[0]: expected an object, not int"),
    ([{**V1_FRAME, "t_us": None}], "performers[0].frames[0].t_us: expected int, not "
     "NoneType"),
    ([V1_FRAME, {**V1_FRAME, "t_us": 5}, V1_FRAME],
     "performers[0].frames[2].t_us: frames must be in time order"),
    ([{**V1_FRAME, "hex": 5}], "performers[0].frames[0].hex: expected str, not int"),
    ([{**V1_FRAME, "hex": "5g"}], "performers[0].frames[0].hex: not hexadecimal"),
    ([{**V1_FRAME, "hex": "55"}], "performers[0].frames[0].hex: performer rex frame 0: "),
    ([{**V1_FRAME, "origin": 1}], "performers[0].frames[0].origin: no origin #1 (the table "
     "has 1)"),
    ([{**V1_FRAME, "duration_us": -1}], "performers[0].frames[0].duration_us: must not be "
     "negative"),
])
def test_version_1_refusals_name_the_frame(frames: object, message: str) -> None:
    with pytest.raises(XgoShowError) as err:
        schedule_from_bytes(_v1(frames), name="old.json")
    assert str(err.value).startswith(f"old.json: {message}")
    loaded = schedule_from_bytes(_v1([V1_FRAME, {**V1_FRAME, "origin": 0, "t_us": 20}]))
    assert [(f.t, f.origin) for f in loaded.performers[0].frames] == [
        (0.0, None), (2e-05, Origin("show.yaml", 2, 5, "c"))]


def test_a_schedule_file_is_told_by_its_first_bytes(tmp_path: Path) -> None:
    def file(name: str, data: bytes) -> Path:
        path = tmp_path / name
        path.write_bytes(data)
        return path

    saved = save_schedule(_schedule(_rex()), tmp_path / "a.xshow.json")
    assert is_schedule_file(saved)
    assert is_schedule_file(file("spaced", b'\n  \t{"format" : "xgo-show-schedule"}'))
    # Bytes that are not UTF-8 in the head do not hide the tag.
    assert is_schedule_file(file("latin", b'{"x": "\xe9", "format": "xgo-show-schedule"}'))
    assert not is_schedule_file(file("routine.yaml", b"show:\n  name: x\n"))
    assert not is_schedule_file(file("list", b'[{"format": "xgo-show-schedule"}]'))
    assert not is_schedule_file(file("other", b'{"format": "xgo-show-routine"}'))
    assert not is_schedule_file(file("trailing", b'{"format": "xgo-show-schedule"'
                                                 .replace(b"{", b"x{")))
    # Only the first 4096 bytes are read: a tag ending on byte 4096 is seen, on 4097 not.
    tag = b'"format": "xgo-show-schedule"'
    for end, seen in ((4096, True), (4097, False)):
        pad = b"{" + b" " * (end - 1 - len(tag))
        assert len(pad + tag) == end
        assert is_schedule_file(file(f"pad{end}", pad + tag + b"}")) is seen
    assert not is_schedule_file(tmp_path / "missing.json")
    assert not is_schedule_file(tmp_path)
    assert not is_schedule_file(file("empty", b""))
    if hasattr(os, "mkfifo"):  # a pipe is never read (it would block)
        os.mkfifo(tmp_path / "pipe")
        assert not is_schedule_file(tmp_path / "pipe")
