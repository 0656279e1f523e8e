"""The schedule document (compiler/document.py) in-process: the JSON a schedule is written as,
read back to the same schedule, and every refusal of a hand-edited document word for word,
naming the file and the field (test_artifact.py covers the file versions around it)."""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import pytest

from xgo_show.choreo.music import Music
from xgo_show.choreo.sections import Section, Wait
from xgo_show.compiler.document import (
    FORMAT,
    OriginOf,
    OriginRef,
    Reader,
    frame_problem,
    read_document,
    schedule_document,
    xarm_frame_problem,
)
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.errors import ProfileError, ScheduleError
from xgo_show.profiles import Link, Profile, get_profile
from xgo_show.wire.xarm import ServoMove, encode_packet
from xgo_show.wire.xgo import write_frame

NAME = "show.xgos"
UP, WAVE, INTRO = (Origin("show.yaml", 3, 5, "rex: up"), Origin("show.yaml", 7, 9, "rex: wave"),
                   Origin("show.yaml", 1, 1, "intro"))


def _frames(p: PerformerSchedule, ref: OriginRef) -> object:
    return [[round(f.t * 1_000_000), f.data.hex(), ref(f.origin), round(f.duration * 1e6)]
            for f in p.frames]


def _read_frames(r: Reader, p: Mapping[str, Any], where: str, name: str, profile: Profile,
                 origins: Sequence[Origin], origin: OriginOf) -> list[ScheduledFrame]:
    # A performer's frames reader is given the file's reader, the performer's path, name and
    # profile, and the origins table (the file versions' readers check frames with them).
    assert isinstance(r, Reader) and r.name == NAME
    assert where.startswith("performers[") and name == p["name"]
    assert profile.model == p["model"] and isinstance(profile, Profile)
    assert [o.line for o in origins] == [7, 3, 1]
    return [ScheduledFrame(t / 1e6, bytes.fromhex(h), origin({"origin": o}, where), d / 1e6)
            for t, h, o, d in p["frames"]]


def _schedule() -> Schedule:
    mini, xarm = get_profile("mini"), get_profile("xarm")
    rex = PerformerSchedule("rex", "mini", Link(115200, 0.0012, 10), (
        ScheduledFrame(0.5, write_frame(0x35, b"\x90"), UP),
        ScheduledFrame(1.0, write_frame(0x3E, b"\x0d"), WAVE, 7.0),
        ScheduledFrame(8.0, write_frame(0x35, b"\x80"), UP),
    ), 9.0, port="/dev/ttyUSB0")
    arm = PerformerSchedule("arm", "xarm", Link(9600, 0.002, 10), (
        ScheduledFrame(0.25, ServoMove(1000, {1: 500}).encode(), None, 1.0),), 2.0)
    assert mini.model == "mini" and xarm.model == "xarm"
    return Schedule(
        "the show", "show.yaml", (rex, arm), 50.0, on_failure="continue", battery_floor=30,
        warnings=(Diagnostic("warning", "slow", WAVE, "tracks.rex"),
                  Diagnostic("warning", "no origin", None, "show")),
        bpm=120.0, beats_per_bar=3, tempo_map=((1, 120.0, 3), (5, 90.0, 4)),
        sections=(Section("intro", 0.0, None, INTRO),
                  Section("verse", 2.0, Wait("go", 1.5, "end"), None),
                  Section("outro", 6.0, Wait("done", None, "verse"), UP)),
        music=Music("song.ogg", "/music/song.ogg", -1.25),
    )


def _doc() -> dict[str, Any]:
    return schedule_document(_schedule(), _frames)


def _read(doc: object) -> Schedule:
    return read_document(doc, NAME, _read_frames)


def test_the_document_names_every_field_with_times_in_microseconds_and_one_origin_table() -> None:
    # Origins in first-use order: the warnings', then the performers' frames, then sections'.
    assert _doc() == {
        "format": FORMAT, "version": 2,
        "origins": [{"file": "show.yaml", "line": 7, "column": 9, "cue": "rex: wave"},
                    {"file": "show.yaml", "line": 3, "column": 5, "cue": "rex: up"},
                    {"file": "show.yaml", "line": 1, "column": 1, "cue": "intro"}],
        "warnings": [{"severity": "warning", "message": "slow", "origin": 0,
                      "path": "tracks.rex"},
                     {"severity": "warning", "message": "no origin", "origin": None,
                      "path": "show"}],
        "performers": [
            {"name": "rex", "model": "mini", "port": "/dev/ttyUSB0", "end_us": 9_000_000,
             "link": {"baud": 115200, "gap_us": 1200, "bits_per_byte": 10},
             "frames": [[500_000, write_frame(0x35, b"\x90").hex(), 1, 0],
                        [1_000_000, write_frame(0x3E, b"\x0d").hex(), 0, 7_000_000],
                        [8_000_000, write_frame(0x35, b"\x80").hex(), 1, 0]]},
            {"name": "arm", "model": "xarm", "port": None, "end_us": 2_000_000,
             "link": {"baud": 9600, "gap_us": 2000, "bits_per_byte": 10},
             "frames": [[250_000, ServoMove(1000, {1: 500}).encode().hex(), None, 1_000_000]]},
        ],
        "show": {"name": "the show", "source": "show.yaml", "control_rate": 50.0,
                 "on_failure": "continue", "battery_floor": 30, "bpm": 120.0,
                 "beats_per_bar": 3, "tempo_map": [[1, 120.0, 3], [5, 90.0, 4]],
                 "sections": [
                     {"name": "intro", "start_us": 0, "origin": 2, "wait": None},
                     {"name": "verse", "start_us": 2_000_000, "origin": None,
                      "wait": {"trigger": "go", "timeout_us": 1_500_000, "else": "end"}},
                     {"name": "outro", "start_us": 6_000_000, "origin": 1,
                      "wait": {"trigger": "done", "timeout_us": None, "else": "verse"}}],
                 "music": {"file": "song.ogg", "path": "/music/song.ogg", "offset": -1.25}},
    }


def test_a_document_reads_back_to_the_same_schedule() -> None:
    schedule = _read(_doc())
    assert schedule == _schedule()
    assert [p.frames for p in schedule.performers] == [p.frames for p in _schedule().performers]
    assert schedule.warnings[0].severity == "warning"
    doc = _doc()
    doc["warnings"][0]["severity"] = "error"
    assert _read(doc).warnings[0].severity == "error"


def test_fields_added_later_are_optional_and_nulls_read_as_none() -> None:
    doc = _doc()
    for key in ("tempo_map", "sections", "music"):
        del doc["show"][key]
    doc["show"]["bpm"] = None
    doc["performers"][0]["port"] = None
    schedule = _read(doc)
    assert (schedule.tempo_map, schedule.sections, schedule.music, schedule.bpm,
            schedule.performers[0].port) == ((), (), None, None, None)
    doc["show"]["music"] = None
    assert _read(doc).music is None
    # Whole numbers where floats go: read as floats.
    doc = _doc()
    doc["show"].update(control_rate=50, bpm=120, tempo_map=[[1, 120, 3]])
    doc["show"]["music"]["offset"] = 2
    schedule = _read(doc)
    for value in (schedule.control_rate, schedule.bpm, schedule.tempo_map[0][1],
                  schedule.music and schedule.music.offset):
        assert type(value) is float
    # The ends of each range are accepted, and either failure policy.
    doc["show"].update(control_rate=1, on_failure="halt_all")
    doc["performers"][1]["link"]["baud"] = 1
    schedule = _read(doc)
    assert (schedule.control_rate, schedule.on_failure, schedule.performers[1].link.baud) == (
        1.0, "halt_all", 1)
    for floor in (0, 100):
        doc["show"]["battery_floor"] = floor
        assert _read(doc).battery_floor == floor
    doc["performers"][0]["link"]["gap_us"] = 0
    assert _read(doc).performers[0].link.gap == 0.0
    assert Reader(NAME).us({"t_us": 2**53}, "t_us", "x") == 2**53 / 1e6
    doc = _doc()
    doc["warnings"][0]["origin"] = 2  # the table's last
    assert _read(doc).warnings[0].origin == INTRO


Edit = Callable[[dict[str, Any]], object]


def _set(path: str, value: object) -> Edit:
    """An edit setting ``path`` (keys and indexes, dotted) to ``value``."""
    def edit(doc: dict[str, Any]) -> None:
        *parents, last = path.split(".")
        node: Any = doc
        for key in parents:
            node = node[int(key)] if key.isdigit() else node[key]
        node[int(last) if last.isdigit() else last] = value
    return edit


def _drop(path: str) -> Edit:
    def edit(doc: dict[str, Any]) -> None:
        *parents, last = path.split(".")
        node: Any = doc
        for key in parents:
            node = node[int(key)] if key.isdigit() else node[key]
        del node[last]
    return edit


try:
    get_profile("nosuch")
except ProfileError as exc:
    UNKNOWN_MODEL = str(exc)

REFUSALS: list[tuple[Edit, str]] = [
    (_drop("origins"), "origins: missing"),
    (_set("origins", {}), "origins: expected list, not dict"),
    (_set("origins.0", "x"), "origins[0]: expected an object, not str"),
    (_drop("origins.1.file"), "origins[1].file: missing"),
    (_set("origins.1.line", "3"), "origins[1].line: expected int, not str"),
    (_set("origins.1.line", True), "origins[1].line: expected int, not bool"),
    (_set("origins.1.column", 1.0), "origins[1].column: expected int, not float"),
    (_set("origins.1.cue", None), "origins[1].cue: expected str, not NoneType"),
    (_drop("show"), "show: missing"),
    (_set("show", []), "show: expected dict, not list"),
    (_drop("warnings"), "warnings: missing"),
    (_set("warnings.1", 3), "warnings[1]: expected an object, not int"),
    (_set("warnings.1.severity", "note"), "warnings[1].severity: unknown severity 'note'"),
    (_drop("warnings.1.severity"), "warnings[1].severity: missing"),
    (_set("warnings.1.message", 5), "warnings[1].message: expected str, not int"),
    (_drop("warnings.1.path"), "warnings[1].path: missing"),
    (_set("warnings.1.origin", 3), "warnings[1].origin: no origin #3 (the table has 3)"),
    (_set("warnings.1.origin", -1), "warnings[1].origin: no origin #-1 (the table has 3)"),
    (_set("warnings.1.origin", "0"), "warnings[1].origin: expected int, not str"),
    (_drop("warnings.1.origin"), "warnings[1].origin: missing"),
    (_drop("performers"), "performers: missing"),
    (_set("performers.1", []), "performers[1]: expected an object, not list"),
    (_set("performers.1.model", "nosuch"), f"performers[1].model: {UNKNOWN_MODEL}"),
    (_set("performers.1.model", 1), "performers[1].model: expected str, not int"),
    (_set("performers.1.link", [1]), "performers[1].link: expected dict, not list"),
    (_set("performers.1.link.baud", 0), "performers[1].link.baud: must be positive"),
    (_set("performers.1.link.baud", -9600), "performers[1].link.baud: must be positive"),
    (_set("performers.1.link.baud", 9600.0), "performers[1].link.baud: expected int, not float"),
    (_set("performers.1.link.gap_us", -1), "performers[1].link.gap_us: must not be negative"),
    (_set("performers.1.link.gap_us", 2**53 + 1),
     "performers[1].link.gap_us: 9.01e+15 us is far too large"),
    (_set("performers.1.link.gap_us", 1.5), "performers[1].link.gap_us: expected int, not float"),
    (_drop("performers.1.link.bits_per_byte"), "performers[1].link.bits_per_byte: missing"),
    (_drop("performers.1.name"), "performers[1].name: missing"),
    (_set("performers.1.end_us", -5), "performers[1].end_us: must not be negative"),
    (_set("performers.1.port", 5), "performers[1].port: expected str, not int"),
    (_drop("performers.1.port"), "performers[1].port: missing"),
    (_set("show.on_failure", "stop"), "show.on_failure: unknown policy 'stop'"),
    (_drop("show.on_failure"), "show.on_failure: missing"),
    (_set("show.control_rate", 0), "show.control_rate: must be positive"),
    (_set("show.control_rate", -50.0), "show.control_rate: must be positive"),
    (_set("show.control_rate", "50"), "show.control_rate: expected int or float, not str"),
    (_set("show.control_rate", True), "show.control_rate: expected int or float, not bool"),
    (_set("show.battery_floor", 101), "show.battery_floor: 101 is not a percentage (0 to 100)"),
    (_set("show.battery_floor", -1), "show.battery_floor: -1 is not a percentage (0 to 100)"),
    (_set("show.battery_floor", 20.0), "show.battery_floor: expected int, not float"),
    (_set("show.bpm", "fast"), "show.bpm: expected int or float, not str"),
    (_drop("show.bpm"), "show.bpm: missing"),
    (_set("show.tempo_map", {}), "show.tempo_map: expected a list, not dict"),
    (_set("show.tempo_map.1", [5, 90.0]), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.tempo_map.1", {"bar": 5}), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.tempo_map.1", [5, 90.0, 4, 1]), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.tempo_map.1", [True, 90.0, 4]), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.tempo_map.1", [5, True, 4]), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.tempo_map.1", [5, 90.0, True]), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.tempo_map.1", [5.0, 90.0, 4]), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.tempo_map.1", [5, "90", 4]), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.tempo_map.1", [5, 90.0, 4.0]), "show.tempo_map[1]: expected [first bar, bpm, "
     "beats_per_bar]"),
    (_set("show.sections", {}), "show.sections: expected a list, not dict"),
    (_set("show.sections.2", "outro"), "show.sections[2]: expected an object, not str"),
    (_drop("show.sections.2.start_us"), "show.sections[2].start_us: missing"),
    (_set("show.sections.2.start_us", 2_000_000),
     "show.sections[2].start_us: sections must be in time order"),
    (_set("show.sections.2.start_us", 1_000_000),
     "show.sections[2].start_us: sections must be in time order"),
    (_set("show.sections.2.wait", "go"), "show.sections[2].wait: expected dict, not str"),
    (_drop("show.sections.2.wait"), "show.sections[2].wait: missing"),
    (_set("show.sections.1.wait.timeout_us", -1),
     "show.sections[1].wait.timeout_us: must not be negative"),
    (_drop("show.sections.1.wait.trigger"), "show.sections[1].wait.trigger: missing"),
    (_set("show.sections.1.wait.else", 3), "show.sections[1].wait.else: expected str, not int"),
    (_set("show.sections.2.wait.else", "bridge"),
     "show.sections[2].wait.else: no section named 'bridge'"),
    (_set("show.sections.2.name", 2), "show.sections[2].name: expected str, not int"),
    (_set("show.sections.2.origin", 9), "show.sections[2].origin: no origin #9 (the table has 3)"),
    (_set("show.music", "song.ogg"), "show.music: expected an object, not str"),
    (_drop("show.music.path"), "show.music.path: missing"),
    (_set("show.music.file", None), "show.music.file: expected str, not NoneType"),
    (_set("show.music.offset", "1"), "show.music.offset: expected int or float, not str"),
    (_drop("show.name"), "show.name: missing"),
    (_set("show.source", 1), "show.source: expected str, not int"),
    (_set("show.beats_per_bar", 4.0), "show.beats_per_bar: expected int, not float"),
]


@pytest.mark.parametrize(("edit", "message"), REFUSALS, ids=[m for _, m in REFUSALS])
def test_a_hand_edited_document_is_refused_naming_the_file_and_the_field(edit: Edit,
                                                                         message: str) -> None:
    doc = copy.deepcopy(_doc())
    edit(doc)
    with pytest.raises(ScheduleError) as err:
        _read(doc)
    assert str(err.value) == f"{NAME}: {message}"


def test_a_document_that_is_not_an_object_and_a_schedule_that_is_not_sound() -> None:
    with pytest.raises(ScheduleError, match=rf"^{NAME}: the document: expected an object, not "
                       "list$"):
        _read([])
    # What the document says is then checked as a schedule (compiler/schedule_check.py): a
    # wait's else may name a section or continue; a show lasts an hour at most.
    doc = _doc()
    doc["show"]["sections"][2]["wait"]["else"] = "continue"
    assert _read(doc).sections[2].wait == Wait("done", None, "continue")
    doc["performers"][0]["end_us"] = 3_601_000_000
    with pytest.raises(ScheduleError, match=rf"^{NAME}: performers\[0\]\.end_us: .* is outside "
                       r"0\.\.3600 s$"):
        _read(doc)


def test_an_xarm_frame_must_be_one_request_of_a_known_command_with_values_in_range() -> None:
    move = ServoMove(1000, {1: 500}).encode()
    assert xarm_frame_problem(move) is None
    assert frame_problem(get_profile("xarm"), move) is None
    for bad in (move + b"\x00", move[:-1], b"\x55\x55\x02\x63", b""):
        assert xarm_frame_problem(bad) == (
            f"not one valid xArm packet ({len(bad)} bytes; expected 55 55, a length and a known "
            "command whose parameters fit it)")
    # A position past 1000 (the typed parser's range), and a command not interpreted.
    wild = encode_packet(3, bytes((1,)) + (1000).to_bytes(2, "little") + bytes((1,))
                         + (1200).to_bytes(2, "little"))
    problem = xarm_frame_problem(wild)
    assert problem is not None and "1200" in problem
    assert frame_problem(get_profile("xarm"), wild) == problem
    # Motor mode, servo info write and read: framed only.
    for command, params in ((26, b"\x01\x02\x03\x04"), (27, bytes(range(12))), (28, b"")):
        assert xarm_frame_problem(encode_packet(command, params)) is None
    # A reply (a voltage reading the board sends back) is not a request.
    reply = encode_packet(15, b"\x10\x27")
    assert xarm_frame_problem(reply) == "an xArm GetBatteryVoltage reply, not a request"
    mini = get_profile("mini")
    assert frame_problem(mini, write_frame(0x35, b"\x90")) is None
    assert frame_problem(mini, move) == "not one valid XGO frame (bad length or checksum)"
