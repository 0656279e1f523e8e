"""The compiled schedule as a file (``*.xshow.json``) and as bytes for the network.

Version 2 (what :func:`save_schedule` and :func:`schedule_to_bytes` write) is one line of JSON,
an envelope around a compressed binary body::

    {"format": "xgo-show-schedule", "version": 2, "encoding": "zlib+base64",
     "sha256": "<hex digest of the body>", "body": "<base64 of the zlib-deflated body>"}

The body (the *canonical bytes*, what the digest is of) is, little-endian throughout:

- the length of the document (uint32), then the document: UTF-8 JSON, keys sorted, compact
  (see :mod:`xgo_show.compiler.document`; a performer's ``frames`` is its frame count);
- then for each performer, in document order, its ``n`` frames as five columns: the time from
  the previous frame (the first: from show start) in microseconds (``n`` uint64), the frame's
  length in bytes (``n`` uint16), its origin (``n`` uint32: index into ``origins`` plus one, 0
  for none), how long its effect runs in microseconds (``n`` uint64), and then every frame's
  exact wire bytes, one after the other.

Why this encoding (``benchmarks/schedule_file.py`` compares them on the compile_speed show,
325,551 frames, 3,616,052 bytes on the wire): version 1 wrote one JSON object per frame, hex
bytes and label included: 12x the wire bytes, 2.4 s to write and 1.7 s to read. Columns keep
each kind of value together, where deflate finds its repeats (tick deltas, origins, durations
are nearly constant), and load with C-level array and slice operations; base64 keeps the file
one line of JSON (is it a schedule? which version? a text tool can tell). A frame's label is
not stored: it is derived from its bytes when shown (:attr:`ScheduledFrame.label`), so
``xgo-show inspect --frames`` prints the same transcript as ever, the way to diff schedules.

The digest is of the canonical bytes, not of the file: the deflated form may differ between
zlib builds, the schedule and its digest do not (:func:`schedule_digest`). Reading checks the
size caps, the format tag and version, the digest, the layout of the columns, every field of
the document and every frame's bytes (see :func:`xgo_show.compiler.document.frame_problem`);
anything wrong is one :class:`XgoShowError` naming the file and the place.

Version 1 files (JSON, a list of objects per performer's frames: ``{"t_us", "hex", "origin",
"label", "duration_us"}``) still load; their labels are derived again from the bytes.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import itertools
import json
import re
import sys
import zlib
from array import array
from collections.abc import Mapping, Sequence
from operator import sub
from pathlib import Path
from typing import Any

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
from xgo_show.compiler.schedule import (
    SCHEDULE_VERSION,
    PerformerSchedule,
    Schedule,
    ScheduledFrame,
    frame_columns,
)
from xgo_show.compiler.state import frame_labels
from xgo_show.diagnostics import Origin
from xgo_show.errors import FileAccessError, ScheduleError
from xgo_show.files import read_bytes_file, read_head
from xgo_show.gcpause import paused_gc
from xgo_show.profiles.model import Profile
from xgo_show.text import printable
from xgo_show.wire.xgo import MIN_LENGTH, TAIL

__all__ = [
    "FORMAT",
    "MAX_SCHEDULE_BYTES",
    "SCHEDULE_HINT",
    "is_schedule_file",
    "load_schedule",
    "save_schedule",
    "schedule_digest",
    "schedule_from_bytes",
    "schedule_to_bytes",
    "xarm_frame_problem",
]

#: what to tell someone who hands a compiled schedule to a command that takes a routine
SCHEDULE_HINT = (
    "is a compiled schedule already: run it with 'xgo-show run' or read it with "
    "'xgo-show inspect'"
)
#: the largest schedule read, as a file or bytes, and the largest body it may inflate to: a
#: 10-minute show of 10 robots at 50 Hz is 3 MB (version 1: 44 MB), its body 11 MB
MAX_SCHEDULE_BYTES = 256 * 1024 * 1024
ENCODING = "zlib+base64"
# Deflate level 1: within 10 % of level 6's size (the columns are mostly repeats), at a third
# of its time (benchmarks/schedule_file.py prints both).
_LEVEL = 1
# Column types: array type codes of these sizes (checked at import; array has no fixed-width
# codes of its own).
_U16, _U32, _U64 = "H", "I", "Q"
if (array(_U16).itemsize, array(_U32).itemsize, array(_U64).itemsize) != (2, 4, 8):
    raise ImportError("xgo_show.compiler.artifact needs 2-, 4- and 8-byte array items")
_BIG_ENDIAN = sys.byteorder == "big"


def _column(code: str, values: Sequence[int]) -> bytes:
    col = array(code, values)
    if _BIG_ENDIAN:
        col.byteswap()
    return col.tobytes()


def _performer_columns(p: PerformerSchedule, ref: OriginRef) -> bytes:
    # The columns as the compiler made them (frame_columns: no frame objects made), and C-level
    # maps where they do: these run once per frame.
    times, data, frame_origins, durations, _ = frame_columns(p.frames)
    deltas = list(map(sub, times, itertools.chain((0,), times)))
    if min(deltas, default=0) < 0:
        raise ScheduleError(f"performer {p.name}: frames are not in time order")
    # A cue's frames mostly follow one another: the last origin's index is reused. Else each
    # origin object is looked up by identity (an Origin hashes in Python, and a routine's
    # Rider alternates its move's and its LEDs' origins frame by frame), and ref() is told of
    # it once, in the order frames first name it.
    origins: list[int] = []
    append = origins.append
    seen: dict[int, int] = {}
    last: object = None
    index = 0
    for origin in frame_origins:
        if origin is not last:
            last = origin
            found = seen.get(id(origin))
            if found is None:
                ref_index = ref(origin)
                found = seen[id(origin)] = 0 if ref_index is None else ref_index + 1
            index = found
        append(index)
    return b"".join((
        _column(_U64, deltas),
        _column(_U16, list(map(len, data))),
        _column(_U32, origins),
        _column(_U64, [round(d * 1_000_000) if d else 0 for d in durations]
                if any(durations) else [0] * len(durations)),
        *data,
    ))


def _canonical(schedule: Schedule) -> bytes:
    """The body: the document, then each performer's frame columns (see the module doc)."""
    columns: list[bytes] = []

    def frames(p: PerformerSchedule, ref: OriginRef) -> int:
        columns.append(_performer_columns(p, ref))
        return len(p.frames)

    doc = schedule_document(schedule, frames)
    doc["version"] = SCHEDULE_VERSION
    text = json.dumps(doc, sort_keys=True, ensure_ascii=False, separators=(",", ":"))
    head = text.encode("utf-8")
    return b"".join((len(head).to_bytes(4, "little"), head, *columns))


def schedule_digest(schedule: Schedule) -> str:
    """SHA-256 (hex) of ``schedule``'s canonical bytes: equal schedules, equal digests."""
    return hashlib.sha256(_canonical(schedule)).hexdigest()


def schedule_to_bytes(schedule: Schedule) -> bytes:
    """The schedule file's bytes (version 2, deterministic for one zlib build)."""
    return _envelope(_canonical(schedule))


def _envelope(body: bytes) -> bytes:
    """The file around canonical bytes: one line of JSON (see the module docstring)."""
    envelope = ",".join((
        f'{{"format":{json.dumps(FORMAT)}',
        f'"version":{SCHEDULE_VERSION}',
        f'"encoding":{json.dumps(ENCODING)}',
        f'"sha256":"{hashlib.sha256(body).hexdigest()}"',
        f'"body":"{base64.b64encode(zlib.compress(body, _LEVEL)).decode("ascii")}"}}',
    ))
    return envelope.encode("ascii") + b"\n"


def is_schedule_file(path: str | Path) -> bool:
    """Whether ``path`` starts as JSON carrying the schedule format tag (whatever its name)."""
    # A pipe, a device or an unreadable file is not one: whoever reads it next says why.
    head = read_head(path, 4096).decode("utf-8", errors="replace")
    return head.lstrip().startswith("{") and re.search(
        rf'"format"\s*:\s*"{re.escape(FORMAT)}"', head
    ) is not None


def save_schedule(schedule: Schedule, path: str | Path) -> Path:
    """Write ``schedule`` to ``path`` (:func:`schedule_to_bytes`); returns the path."""
    target = Path(path)
    try:
        target.write_bytes(schedule_to_bytes(schedule))
    except OSError as exc:
        raise FileAccessError(f"cannot write schedule {target}: {exc.strerror or exc}") from exc
    return target


def load_schedule(path: str | Path, *, max_bytes: int = MAX_SCHEDULE_BYTES) -> Schedule:
    """Read a schedule file (either version; see the module docstring)."""
    source = Path(path)
    try:  # a regular file only (a pipe would block, /dev/zero never end), at most max_bytes
        data = read_bytes_file(source, limit=max_bytes)
    except FileAccessError as exc:
        raise FileAccessError(f"cannot read schedule {source}: {exc}") from exc
    return schedule_from_bytes(data, name=str(source), max_bytes=max_bytes)


def _whole_number(text: str) -> int:
    """A JSON integer, refused when it has more digits than any schedule value (a float made
    from it would overflow, and Python parses thousands of digits slowly)."""
    if len(text.lstrip("-")) > 18:
        raise ValueError(f"the number {text[:12]}... has {len(text)} digits: far too large")
    return int(text)


def _one_each(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object whose keys are all different: ``json`` keeps the last of two equal keys,
    so a hand-edited file with two ``"control_rate"`` would be read differently from what
    its first line says."""
    out = dict(pairs)
    if len(out) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise ValueError(f"the key {printable(key)!r} appears twice in one object")
            seen.add(key)
    return out


def schedule_from_bytes(
    data: bytes, *, name: str = "<schedule>", max_bytes: int = MAX_SCHEDULE_BYTES
) -> Schedule:
    """The schedule in ``data`` (a file's bytes, e.g. received over the network).

    ``name`` starts every error message. Refuses more than ``max_bytes``, in ``data`` or once
    the body is inflated.
    """
    if len(data) > max_bytes:
        raise ScheduleError(f"{name}: larger than {max_bytes:,} bytes: not a schedule this reads")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScheduleError(f"{name}: not a schedule file (not UTF-8 text: byte {exc.start})"
                           ) from exc
    try:
        doc = json.loads(text, parse_int=_whole_number, object_pairs_hook=_one_each)
    except json.JSONDecodeError as exc:
        raise ScheduleError(
            f"{name}: not a schedule file (invalid JSON at line {exc.lineno} column {exc.colno}: "
            f"{exc.msg})"
        ) from exc
    except RecursionError as exc:
        raise ScheduleError(f"{name}: not a schedule file (JSON nested too deeply)") from exc
    except ValueError as exc:  # a number of too many digits (_whole_number)
        raise ScheduleError(f"{name}: not a schedule file ({exc})") from exc
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ScheduleError(f"{name}: not an xgo-show schedule (no \"format\": \"{FORMAT}\")")
    version = doc.get("version")
    r = Reader(name)
    if not isinstance(version, int) or isinstance(version, bool):
        raise r.fail("version", "missing or not an integer")
    if version > SCHEDULE_VERSION:
        raise ScheduleError(
            f"{name}: schedule format version {version} was written by a newer xgo-show; this "
            f"one reads versions 1 to {SCHEDULE_VERSION}: upgrade xgo-show or compile the show "
            "again"
        )
    if version == 1:
        return read_document(doc, name, _frames_v1)
    if version != 2:
        raise r.fail("version", f"unknown schedule format version {version}")
    return _read_v2(r, doc, max_bytes)


def _read_v2(r: Reader, envelope: Mapping[str, Any], max_bytes: int) -> Schedule:
    encoding = r.get(envelope, "encoding", str, "")
    if encoding != ENCODING:
        raise r.fail("encoding", f"unknown encoding {encoding!r} (this reads {ENCODING!r})")
    digest = r.get(envelope, "sha256", str, "")
    try:
        packed = base64.b64decode(r.get(envelope, "body", str, ""), validate=True)
    except (binascii.Error, ValueError) as exc:
        raise r.fail("body", "not base64") from exc
    inflater = zlib.decompressobj()
    try:
        body = inflater.decompress(packed, max_bytes + 1)
    except zlib.error as exc:
        raise r.fail("body", f"not zlib data ({exc})") from exc
    if len(body) > max_bytes:
        raise r.fail("body", f"inflates to more than {max_bytes:,} bytes")
    if not inflater.eof or inflater.unused_data:
        raise r.fail("body", "truncated or followed by other data")
    if hashlib.sha256(body).hexdigest() != digest:
        raise r.fail("sha256", "the body does not match its digest (the file is damaged)")
    cut = 4 + int.from_bytes(body[:4], "little")
    if len(body) < 4 or cut > len(body):
        raise r.fail("body", "its document is cut short")
    try:
        doc = json.loads(body[4:cut].decode("utf-8"), object_pairs_hook=_one_each)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise r.fail("body", f"its document is not JSON ({exc})") from exc
    if not isinstance(doc, dict) or doc.get("format") != FORMAT or doc.get("version") != 2:
        raise r.fail("body", "its document is not a version 2 schedule document")
    columns = _Columns(memoryview(body), cut)
    with paused_gc():  # see gcpause: 100k's of frames, no cycle to collect
        schedule = read_document(doc, r.name, columns.frames)
    if columns.at != len(body):
        raise r.fail("body", f"{len(body) - columns.at} bytes after the last performer's frames")
    return schedule


class _Columns:
    """Reads each performer's frame columns from the body, in document order."""

    def __init__(self, body: memoryview, at: int) -> None:
        self.body = body
        self.at = at

    def _take(self, r: Reader, where: str, code: str, n: int) -> list[int]:
        col = array(code)
        end = self.at + n * col.itemsize
        if end > len(self.body):
            raise r.fail(where, "the body ends inside its frame columns")
        col.frombytes(self.body[self.at:end])
        if _BIG_ENDIAN:
            col.byteswap()
        self.at = end
        return col.tolist()

    def frames(self, r: Reader, p: Mapping[str, Any], where: str, performer: str,
               profile: Profile, origins: Sequence[Origin], origin: OriginOf
               ) -> list[ScheduledFrame]:
        n = r.get(p, "frames", int, where)
        fw = f"{where}.frames"
        if n < 0:
            raise r.fail(fw, "must not be negative")
        deltas = self._take(r, fw, _U64, n)
        lengths = self._take(r, fw, _U16, n)
        origin_refs = self._take(r, fw, _U32, n)
        durations = self._take(r, fw, _U64, n)
        start = self.at
        end = start + sum(lengths)
        if end > len(self.body):
            raise r.fail(fw, "the body ends inside its frames' bytes")
        self.at = end
        blob = self.body[start:end].tobytes()
        table: list[Origin | None] = [None, *origins]
        if max(origin_refs, default=0) >= len(table):
            j = next(j for j, o in enumerate(origin_refs) if o >= len(table))
            raise r.fail(f"{fw}[{j}].origin",
                         f"no origin #{origin_refs[j] - 1} (the table has {len(table) - 1})")
        offsets = list(itertools.accumulate(lengths, initial=0))
        datas = [blob[a:b] for a, b in itertools.pairwise(offsets)]
        bad = _first_bad_frame(profile, datas)
        if bad is not None:
            j, problem = bad
            raise r.fail(f"{fw}[{j}]", f"performer {performer} frame {j}: {problem}")
        labels = frame_labels(profile)
        return [
            ScheduledFrame(t / 1_000_000, data, table[o], d / 1_000_000, labels)
            for t, data, o, d in zip(
                itertools.accumulate(deltas), datas, origin_refs, durations, strict=True)
        ]


def _first_bad_frame(profile: Profile, datas: list[bytes]) -> tuple[int, str] | None:
    """The first frame that cannot be ``profile``'s and why (None when all can)."""
    if profile.family == "xgo" and all(
        # is_one_frame inlined (a call per frame costs as much as the check)
        len(d) >= MIN_LENGTH and d[0] == 0x55 and d[1] == 0x00 and d[2] == len(d)
        and d[-2:] == TAIL
        and d[-3] == (~sum(d[2:-3])) & 0xFF
        for d in datas
    ):
        return None
    for j, data in enumerate(datas):
        problem = frame_problem(profile, data)
        if problem is not None:
            return j, problem
    return None


def _frames_v1(r: Reader, p: Mapping[str, Any], where: str, performer: str,
               profile: Profile, origins: Sequence[Origin], origin: OriginOf
               ) -> list[ScheduledFrame]:
    """Version 1: ``frames`` is a list of objects, one per frame (its label is not read)."""
    labels = frame_labels(profile)
    frames: list[ScheduledFrame] = []
    last = 0.0
    for j, fraw in enumerate(r.get(p, "frames", list, where)):
        fw = f"{where}.frames[{j}]"
        f = r.obj(fraw, fw)
        t = r.us(f, "t_us", fw)
        if t < last:
            raise r.fail(f"{fw}.t_us", "frames must be in time order")
        last = t
        try:
            data = bytes.fromhex(r.get(f, "hex", str, fw))
        except ValueError as exc:
            raise r.fail(f"{fw}.hex", "not hexadecimal") from exc
        problem = frame_problem(profile, data)
        if problem is not None:
            raise r.fail(f"{fw}.hex", f"performer {performer} frame {j}: {problem}")
        frames.append(ScheduledFrame(t, data, origin(f, fw), r.us(f, "duration_us", fw), labels))
    return frames
