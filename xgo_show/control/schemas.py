"""The JSON Schema of every payload of the show-control API (``schemas/zenoh-api.v1.schema.json``).

Requests are the models the server parses with (:mod:`xgo_show.control.protocol`); replies and
events are described by the models below, which say exactly what the server sends (no field
more: ``additionalProperties`` is false, so a field added to a reply without its schema fails
the tests that validate the server's real payloads). One file, one ``$defs`` entry per payload,
named ``request-COMMAND``, ``reply-COMMAND`` (``status`` and ``trigger`` included), ``error``
and ``event-KIND``; docs/zenoh-api.md names them beside each key. Regenerate with
``python -m xgo_show.control.schemas > schemas/zenoh-api.v1.schema.json``.
"""

from __future__ import annotations

import json
import sys
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter

from xgo_show.control.keys import COMMANDS, EVENT_KINDS
from xgo_show.control.protocol import PROTOCOL_VERSION, REQUESTS

__all__ = ["ERROR_CODES", "SCHEMA_FILE", "api_schema", "definition"]

SCHEMA_FILE = f"zenoh-api.v{PROTOCOL_VERSION}.schema.json"
#: Every ``error`` an error reply can carry (docs/zenoh-api.md says when).
ERROR_CODES = (
    "unknown_command", "bad_request", "version", "too_large", "not_found", "refused",
    "failed", "busy", "cancelled", "closing", "internal",
)

Num = float


class _Out(BaseModel):
    model_config = ConfigDict(extra="forbid")

    v: Literal[1] = Field(description="Payload version.")


# ---------------------------------------------------------------------- pieces


class _Piece(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Wait(_Piece):
    trigger: str
    timeout: Num | None = Field(description="Seconds; null: waits for ever.")
    else_: str = Field(alias="else", description="continue, end or a section's name.")


class Section(_Piece):
    name: str
    start: Num = Field(description="Show time, seconds.")
    wait: Wait | None


class ShowPerformer(_Piece):
    name: str
    model: str


class ShowSummary(_Piece):
    """What is loaded."""

    name: str
    source: str = Field(description="The path loaded, <routine> or <schedule>.")
    duration: Num
    performers: list[ShowPerformer]
    sections: list[Section]
    triggers: list[str] = Field(description="Every trigger a section waits for.")


class PreflightRow(_Piece):
    performer: str
    port: str
    firmware: str
    battery: Num | None
    voltage: Num | None
    low_latency: bool
    problems: list[str]


class Preflight(_Piece):
    ok: bool
    realtime: str
    rows: list[PreflightRow]


class Robot(_Piece):
    """One robot in a status reply or a progress event."""

    state: str = Field(description="idle, reaching, running, paused, finished, stopped, failed.")
    show_time: Num
    cue: str
    frames_sent: int
    frames_total: int
    battery: Num | None
    readings: dict[str, Num]
    fault: str | None


class StopResult(_Piece):
    ok: bool
    error: str


class LastResult(_Piece):
    show: str
    completed: bool
    reason: str
    faults: dict[str, str]
    time: Num = Field(description="When it ended, Unix seconds.")


class WaitingFor(_Piece):
    section: str
    trigger: str
    timeout: Num | None


class NextWait(_Piece):
    section: str
    trigger: str


class Counters(_Piece):
    """What came in since the server started, and what became of it."""

    triggers: int = Field(description="Triggers received (puts and queries), malformed apart.")
    accepted: int = Field(description="Triggers that released a wait or were kept for one.")
    refused: int = Field(description="Triggers nobody waited for.")
    unknown: int = Field(description="Of the refused: triggers no section of the loaded show "
                         "waits for, refused before their payload is read.")
    malformed: int = Field(description="Triggers whose payload was refused (dropped).")
    busy: int = Field(description="Commands refused because 64 were queued.")
    cancelled: int = Field(description="Commands (and starts being armed) a panic cancelled.")
    events_dropped: int = Field(description="Events lost to a full event queue.")
    events_suppressed: int = Field(description="Noisy events left out over the rate.")


class _PlaceFields(BaseModel):
    """Where in the show: show time, bar and beat (shows with a tempo), the section."""

    model_config = ConfigDict(extra="forbid")
    show_time: Num
    bar: int | None = Field(None, description="Only in shows with a tempo.")
    beat: Num | None = Field(None, description="Only in shows with a tempo.")
    section: str | None


# ---------------------------------------------------------------------- replies


class _Reply(_Out):
    ok: Literal[True]


class LoadReply(_Reply):
    command: Literal["load"]
    show: ShowSummary
    warnings: list[str]


class StartReply(_Reply):
    command: Literal["start"]
    show: str
    offset: Num = Field(description="Show time it starts from, seconds.")
    start_time: Num = Field(description="Wall-clock start, Unix seconds.")
    preflight: Preflight | None


class _Ended(_Reply):
    state: Literal["ended", "stopping", "idle"]
    reason: str | None = None
    stops: dict[str, StopResult] | None = None
    note: str | None = None


class StopReply(_Ended):
    command: Literal["stop"]


class PanicReply(_Ended):
    command: Literal["panic"]


class PauseReply(_Reply):
    command: Literal["pause"]
    state: str = Field(description="The show's state after it: paused, or waiting.")


class ResumeReply(_Reply):
    command: Literal["resume"]
    state: str


class SeekReply(_Reply, _PlaceFields):
    command: Literal["seek"]


class TriggerReply(_Reply):
    command: Literal["trigger"]
    trigger: str
    section: str = Field(description="The section whose wait took it.")
    held: bool = Field(description="true: released the wait held now; false: kept for the "
                       "wait ahead.")


class StatusReply(_Reply):
    command: Literal["status"]
    state: Literal["idle", "loaded", "starting", "playing", "waiting", "paused", "ended"]
    show: ShowSummary | None
    last_result: LastResult | None
    namespace: str
    version: int
    counters: Counters
    # while a show runs:
    show_time: Num | None = None
    bar: int | None = None
    beat: Num | None = None
    section: str | None = None
    duration: Num | None = None
    waiting_for: WaitingFor | None = None
    next_wait: NextWait | None = None
    robots: dict[str, Robot] | None = None
    faults: dict[str, str] | None = None


class ErrorReply(_Out):
    """Sent as a Zenoh error reply (``reply.err``)."""

    ok: Literal[False]
    command: str
    error: Literal[ERROR_CODES]  # type: ignore[valid-type]
    message: str


REPLIES: dict[str, type[BaseModel]] = {
    "load": LoadReply, "start": StartReply, "stop": StopReply, "pause": PauseReply,
    "resume": ResumeReply, "seek": SeekReply, "panic": PanicReply, "status": StatusReply,
    "trigger": TriggerReply,
}

# ---------------------------------------------------------------------- events


class _Event(_Out):
    time: Num = Field(description="When it was published, Unix seconds.")


class ShowLoaded(_Event):
    event: Literal["state"]
    state: Literal["loaded"]
    show: str


class ShowPreflight(_Event, Preflight):
    event: Literal["state"]
    state: Literal["preflight"]


class ShowPlaying(_Event):
    event: Literal["state"]
    state: Literal["playing"]
    show: str | None = Field(None, description="At the start (with offset).")
    offset: Num | None = None
    show_time: Num | None = Field(None, description="On resume.")


class ShowPaused(_Event):
    event: Literal["state"]
    state: Literal["paused"]
    show_time: Num


class ShowSeek(_Event, _PlaceFields):
    event: Literal["state"]
    state: Literal["seek"]


class ShowPanic(_Event):
    event: Literal["state"]
    state: Literal["panic"]


class ShowEnded(_Event):
    event: Literal["state"]
    state: Literal["ended"]
    completed: bool
    reason: str
    faults: dict[str, str]


class RobotState(_Event):
    event: Literal["state"]
    robot: str
    state: Literal["idle", "reaching", "running", "paused", "finished", "stopped", "failed"]
    show_time: Num


class RobotSafeStopped(_Event):
    event: Literal["state"]
    robot: str
    state: Literal["safe_stopped"]
    ok: bool
    reason: str
    error: str


class CueEvent(_Event):
    event: Literal["cue"]
    robot: str
    cue: str
    show_time: Num


class WaitingEvent(_Event):
    event: Literal["wait"]
    state: Literal["waiting"]
    section: str
    trigger: str
    show_time: Num
    timeout: Num | None


class ReleasedEvent(_Event):
    event: Literal["wait"]
    state: Literal["released"]
    section: str
    trigger: str
    how: Literal["trigger", "early", "timeout", "seek"]
    goto: str = Field(description="Where the show went on (a timeout's else).")


class TriggerAccepted(_Event):
    event: Literal["trigger"]
    trigger: str
    accepted: Literal[True]
    section: str
    held: bool
    source: str | None
    data: Any = Field(description="The trigger's data, echoed.")


class TriggerRefusedEvent(_Event):
    event: Literal["trigger"]
    trigger: str
    accepted: Literal[False]
    reason: str


class FaultEvent(_Event):
    event: Literal["fault"]
    robot: str
    reason: str


class ProgressEvent(_Event, _PlaceFields):
    event: Literal["progress"]
    duration: Num
    robots: dict[str, Robot]


class TelemetryEvent(_Event):
    event: Literal["telemetry"]
    robot: str
    readings: dict[str, Num]


class WarningEvent(_Event):
    event: Literal["warning"]
    message: str
    suppressed: int | None = Field(None, description="Refused triggers not published.")
    unknown: int | None = Field(None, description="Triggers no section waits for, refused "
                                "since the last such warning (at most one a second).")
    trigger: str | None = Field(None, description="With unknown: the last of them.")


EVENTS: dict[str, tuple[type[BaseModel], ...]] = {
    "state": (ShowLoaded, ShowPreflight, ShowPlaying, ShowPaused, ShowSeek, ShowPanic, ShowEnded,
              RobotState, RobotSafeStopped),
    "cue": (CueEvent,),
    "wait": (WaitingEvent, ReleasedEvent),
    "trigger": (TriggerAccepted, TriggerRefusedEvent),
    "fault": (FaultEvent,),
    "progress": (ProgressEvent,),
    "telemetry": (TelemetryEvent,),
    "warning": (WarningEvent,),
}


def api_schema() -> dict[str, Any]:
    """The whole schema file: one ``$defs`` entry per payload (see the module docstring)."""
    assert set(EVENTS) == set(EVENT_KINDS) and set(REPLIES) - {"status", "trigger"} == set(
        COMMANDS)
    named: dict[str, Any] = {f"request-{c}": REQUESTS[c] for c in (*COMMANDS, "trigger")}
    named.update({f"reply-{c}": m for c, m in REPLIES.items()})
    named["error"] = ErrorReply
    for kind, models in EVENTS.items():
        named[f"event-{kind}"] = models[0] if len(models) == 1 else _union(models)
    defs: dict[str, Any] = {}
    for name, model in named.items():
        schema = TypeAdapter(model).json_schema(by_alias=True, ref_template="#/$defs/{model}")
        defs.update(schema.pop("$defs", {}))
        defs[name] = schema
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": f"https://github.com/xgo-show/xgo-show/schemas/{SCHEMA_FILE}",
        "title": f"xgo-show show-control API on Zenoh, payload version {PROTOCOL_VERSION}",
        "description": "Every payload of docs/zenoh-api.md: request-COMMAND, reply-COMMAND, "
        "error and event-KIND.",
        "$defs": dict(sorted(defs.items())),
    }


def _union(models: tuple[type[BaseModel], ...]) -> Any:
    from typing import Union

    return Union[models]  # noqa: UP007 - a tuple of classes only works with Union[...]


def definition(name: str) -> dict[str, Any]:
    """A schema validating payload ``name`` alone (``$defs`` kept for its references)."""
    whole = api_schema()
    return {"$schema": whole["$schema"], "$defs": whole["$defs"], "$ref": f"#/$defs/{name}"}


if __name__ == "__main__":  # pragma: no cover - a developer's tool
    json.dump(api_schema(), sys.stdout, indent=1)
    sys.stdout.write("\n")
