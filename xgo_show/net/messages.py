"""The relay protocol's payloads: versioned JSON, checked field by field, with size caps.

Every command is a Zenoh query on ``NS/relay/NAME/cmd`` whose payload is one JSON object::

    {"v": 1, "op": "start", "seq": 7, "conductor": {"id": "5f1c...", "name": "alice@laptop"},
     "sent": 1234.567891, ...the op's own fields}

and every reply is one JSON object::

    {"v": 1, "seq": 7, "ok": true, "error": null, "relay": "stage-left",
     "relay_time": 98765.432109, ...the op's own result fields}

- ``v`` is :data:`PROTOCOL_VERSION`; a message of another version is refused with an error
  reply naming both versions.
- ``seq`` is the conductor's sequence number, echoed in the reply; a relay ignores nothing
  silently: a request it cannot read gets ``ok: false`` and ``error`` saying why.
- Clock times. ``sent`` is the conductor's monotonic clock when it sent the request (seconds).
  ``relay_time`` and every time a command carries (``start_at``, ``at``) are on the relay's
  SHOW clock. Once the holder's clock tracker has pushed a timebase (``NS/relay/NAME/time``,
  :mod:`xgo_show.net.timesync`), that clock reads the conductor's own monotonic time, slewed to
  follow its drift, so the conductor sends its own clock times unconverted and every host acts
  at the same instant. Before any timebase (a new holder, or sync refused) it is the relay's
  monotonic clock, and the conductor converts with the offset its command round trips show.
  Show times (``offset``, ``show_time``) are seconds from the start of the show.
- A timed command is refused, never acted on late: a ``start`` that leaves the relay's robots
  less than their lead (``start: the robots need ...``), or a ``pause``/``resume``/``seek``
  whose ``at`` has passed when it arrives, since a host acting late would play on another frame
  than the others for the rest of the show.
- Sizes: a request is at most :data:`MAX_REQUEST_BYTES` (an upload: :data:`MAX_UPLOAD_BYTES`);
  a bigger one is refused before it is parsed.

Operations and their fields (besides the common ones):

========== ============================================= ==========================================
op         request                                       reply
========== ============================================= ==========================================
hello      (none): claims the relay for this conductor   ``relay`` description (see ``info``)
release    (none): gives the relay up                    (none)
upload     ``schedule`` (schedule JSON text), ``sha256``  ``sha256``, ``preflight`` rows,
           (of that text), ``link_loss`` ("stop" or      ``preflight_ok``
           "continue"), ``watchdog_ms``, ``battery_floor``
start      ``sha256``, ``start_at`` (relay time) or      ``start_at``, ``margin`` (seconds to
           ``start_in`` (seconds after the command       spare when the robots were armed)
           arrives: the naive way, for comparisons),
           ``offset`` (show time)
pause      ``at`` (relay time or null: now)              ``at``
resume     ``at``                                        ``at``
seek       ``show_time``, ``at``                         ``at``
stop       ``reason``: safe stop now                     ``stops``: per performer result
heartbeat  (none): the conductor is alive                ``show``: state, per performer progress
probe      ``performer``: read its identity and health   ``rows``: [[label, value], ...]
========== ============================================= ==========================================

A remote behaviour (``xgo-show behave`` with ``zenoh:`` performers) keeps the relay as a stage
for its whole run instead of playing one show (:mod:`xgo_show.behave.relay_host`); ``robots`` is
a list of the relay's robot names, times are on the show clock as above:

============ =========================================== ==========================================
op           request                                     reply
============ =========================================== ==========================================
stage_upload ``schedule``, ``sha256``: one routine or    ``sha256``
             ``set``/``led`` action, kept by its hash
stage_open   ``robots``; ``telemetry`` (s between reads) ``robots``
             and ``watch`` (s between fall/tilt reads,
             null: in rotation): start watching them;
             ``watchdog_ms`` as for ``upload``
stage_play   ``sha256``, ``robots``, ``play`` (the       ``at`` (when it starts), ``late`` (s: an
             conductor's id for it), ``at`` (null: now)  ``at`` already past starts at once)
stage_write  ``sha256``, ``robots``: its frames now,     ``at``
             beside what plays
stage_rest   ``robots``: end what plays, through rest    ``at``
stage_stop   ``robots``, ``reason``: the full safe stop  ``at``
============ =========================================== ==========================================

While a stage is open, each heartbeat answer's ``show`` also carries ``stage``:
``{"open": true, "ended": [[robot, play], ...]}`` (the plays that ran to their end since the
previous answer), and ``events`` carries the stage's telemetry readings and frames all the
time, not only during a show. Shows (``upload``/``start``) are refused while a stage is open,
and ``stage_*`` commands while a show runs. Releasing the relay, or a silent conductor (the
watchdog), closes the stage with a safe stop of its robots.

The description a relay serves on ``NS/relay/NAME/info`` (and in the ``hello`` reply)::

    {"v": 1, "relay": "stage-left", "instance": "3f9a0c1d2e4b", "relay_time": ...,
     "allow_unsafe": false, "holder": {"id": ..., "name": ...} | null,
     "state": "idle" | "loaded" | "armed" | "running" | "ended", "last": {...} | null,
     "robots": [{"name": "rex", "model": "mini", "port": "/dev/ttyUSB0",
                 "firmware": "XGO-mini ...", "battery": 87.0, "state": "idle"}, ...]}

``instance`` is new each time the relay process starts: a relay that restarted is a new
instance, with no holder and no show (it never resumes one it did not arm itself).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from xgo_show.errors import MessageError

__all__ = [
    "LINK_LOSS_POLICIES",
    "MAX_NAMES",
    "MAX_REQUEST_BYTES",
    "MAX_UPLOAD_BYTES",
    "OPS",
    "PROTOCOL_VERSION",
    "UPLOAD_OPS",
    "Conductor",
    "MessageError",
    "Reply",
    "Request",
    "decode_reply",
    "decode_request",
    "encode",
    "error_reply",
]

PROTOCOL_VERSION = 1
MAX_REQUEST_BYTES = 64 * 1024
MAX_UPLOAD_BYTES = 32 * 1024 * 1024
LINK_LOSS_POLICIES = ("stop", "continue")

# op -> {field: kind}; kinds: "str", "float", "float?" (or null), "int", "policy", "names"
# (a list of robot names).
OPS: dict[str, dict[str, str]] = {
    "hello": {},
    "release": {},
    "upload": {
        "schedule": "str",
        "sha256": "str",
        "link_loss": "policy",
        "watchdog_ms": "int",
        "battery_floor": "float?",
    },
    "start": {"sha256": "str", "start_at": "float?", "start_in": "float?", "offset": "float"},
    "pause": {"at": "float?"},
    "resume": {"at": "float?"},
    "seek": {"show_time": "float", "at": "float?"},
    "stop": {"reason": "str"},
    "heartbeat": {},
    "probe": {"performer": "str"},
    # A remote behaviour's stage (xgo_show/behave/relay_host.py).
    "stage_upload": {"schedule": "str", "sha256": "str"},
    "stage_open": {
        "robots": "names",
        "watch": "float?",
        "telemetry": "float",
        "watchdog_ms": "int",
    },
    "stage_play": {"sha256": "str", "robots": "names", "play": "int", "at": "float?"},
    "stage_write": {"sha256": "str", "robots": "names"},
    "stage_rest": {"robots": "names"},
    "stage_stop": {"robots": "names", "reason": "str"},
}
#: The ops whose request may be as big as :data:`MAX_UPLOAD_BYTES` (they carry a schedule).
UPLOAD_OPS = ("upload", "stage_upload")
#: Most names in a ``names`` field.
MAX_NAMES = 64



@dataclass(frozen=True)
class Conductor:
    """Who sends a command: a unique id per conductor process and a name for people."""

    id: str
    name: str

    def to_json(self) -> dict[str, str]:
        return {"id": self.id, "name": self.name}


@dataclass(frozen=True)
class Request:
    """One decoded command: its op, sequence number, sender and checked fields."""

    op: str
    seq: int
    conductor: Conductor
    sent: float
    fields: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "v": PROTOCOL_VERSION,
            "op": self.op,
            "seq": self.seq,
            "conductor": self.conductor.to_json(),
            "sent": self.sent,
            **self.fields,
        }

    def text(self, name: str) -> str:
        value = self.fields[name]
        assert isinstance(value, str)
        return value

    def number(self, name: str) -> float:
        value = self.fields[name]
        assert isinstance(value, float)
        return value

    def maybe_number(self, name: str) -> float | None:
        value = self.fields.get(name)
        assert value is None or isinstance(value, float)
        return value

    def whole(self, name: str) -> int:
        value = self.fields[name]
        assert isinstance(value, int)
        return value


@dataclass(frozen=True)
class Reply:
    """One decoded reply."""

    seq: int
    ok: bool
    error: str | None
    relay: str
    relay_time: float
    fields: Mapping[str, Any] = field(default_factory=dict)


def encode(message: Mapping[str, Any]) -> bytes:
    """A message as compact UTF-8 JSON (NaN and infinities refused)."""
    return json.dumps(message, separators=(",", ":"), allow_nan=False).encode("utf-8")


def _load(data: bytes, limit: int) -> dict[str, Any]:
    if len(data) > limit:
        raise MessageError(f"message of {len(data)} bytes is over the limit of {limit} bytes")
    try:
        value = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise MessageError(f"not a JSON message: {exc}") from exc
    if not isinstance(value, dict):
        raise MessageError(f"a message is a JSON object, not {type(value).__name__}")
    version = value.get("v")
    if version != PROTOCOL_VERSION:
        raise MessageError(
            f"protocol version {version!r}; this xgo-show speaks version {PROTOCOL_VERSION}"
        )
    return value


def _number(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise MessageError(f"field {name!r} must be a number, not {type(value).__name__}")
    number = float(value)
    if not math.isfinite(number):
        raise MessageError(f"field {name!r} must be finite")
    return number


def _check(kind: str, value: Any, name: str) -> Any:
    if kind == "str":
        if not isinstance(value, str):
            raise MessageError(f"field {name!r} must be a string")
        return value
    if kind == "float":
        return _number(value, name)
    if kind == "float?":
        return None if value is None else _number(value, name)
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise MessageError(f"field {name!r} must be a whole number >= 0")
        return value
    if kind == "names":
        if (
            not isinstance(value, list)
            or len(value) > MAX_NAMES
            or not all(isinstance(v, str) and 0 < len(v) <= 64 for v in value)
        ):
            raise MessageError(f"field {name!r} must be a list of at most {MAX_NAMES} names")
        return tuple(value)
    if kind == "policy":
        if value not in LINK_LOSS_POLICIES:
            raise MessageError(
                f"field {name!r} must be one of {', '.join(LINK_LOSS_POLICIES)}, not {value!r}"
            )
        return value
    raise AssertionError(kind)


def decode_request(data: bytes) -> Request:
    """Check and decode a command; a :class:`MessageError` (one line) for anything wrong."""
    raw = _load(data, MAX_UPLOAD_BYTES)
    op = raw.get("op")
    if not isinstance(op, str) or op not in OPS:
        raise MessageError(f"unknown op {op!r}; one of {', '.join(OPS)}")
    if op not in UPLOAD_OPS and len(data) > MAX_REQUEST_BYTES:
        raise MessageError(f"{op} of {len(data)} bytes is over {MAX_REQUEST_BYTES}")
    seq = raw.get("seq")
    if isinstance(seq, bool) or not isinstance(seq, int) or seq < 0:
        raise MessageError("field 'seq' must be a whole number >= 0")
    who = raw.get("conductor")
    if (
        not isinstance(who, dict)
        or not isinstance(who.get("id"), str)
        or not isinstance(who.get("name"), str)
        or not who["id"]
    ):
        raise MessageError("field 'conductor' must be {'id': str, 'name': str}")
    sent = _number(raw.get("sent"), "sent")
    fields: dict[str, Any] = {}
    for name, kind in OPS[op].items():
        if name not in raw and not kind.endswith("?"):
            raise MessageError(f"{op}: missing field {name!r}")
        fields[name] = _check(kind, raw.get(name), f"{op}.{name}")
    return Request(op, seq, Conductor(who["id"][:64], who["name"][:200]), sent, fields)


def decode_reply(data: bytes) -> Reply:
    """Check and decode a relay's reply (the conductor side)."""
    raw = _load(data, MAX_UPLOAD_BYTES)
    seq = raw.get("seq")
    ok = raw.get("ok")
    error = raw.get("error")
    relay = raw.get("relay")
    if isinstance(seq, bool) or not isinstance(seq, int):
        raise MessageError("reply field 'seq' must be a whole number")
    if not isinstance(ok, bool) or not (error is None or isinstance(error, str)):
        raise MessageError("reply fields 'ok' (bool) and 'error' (str or null) are required")
    if not isinstance(relay, str):
        raise MessageError("reply field 'relay' must be a string")
    relay_time = _number(raw.get("relay_time"), "relay_time")
    rest = {
        k: v for k, v in raw.items() if k not in ("v", "seq", "ok", "error", "relay", "relay_time")
    }
    return Reply(seq, ok, error, relay, relay_time, rest)


def error_reply(relay: str, relay_time: float, seq: int, error: str) -> dict[str, Any]:
    """The reply to a request that failed or could not be read (``seq`` -1 if unknown)."""
    return {
        "v": PROTOCOL_VERSION,
        "seq": seq,
        "ok": False,
        "error": error,
        "relay": relay,
        "relay_time": relay_time,
    }
