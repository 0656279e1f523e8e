"""Payloads of the show-control API: versioned JSON, parsed and built here (no I/O).

Every payload is one JSON object carrying ``"v": 1`` (a request may leave it out: it means 1).
A request is checked whole before anything happens: a payload that is not JSON, too large,
of a newer version, with an unknown or mistyped field is answered with an error reply naming
the problem, never half-applied. Replies are ``{"v": 1, "ok": true, "command": ..., ...}``;
errors are sent as Zenoh error replies ``{"v": 1, "ok": false, "command": ..., "error": CODE,
"message": ...}``. :mod:`xgo_show.control.schemas` writes the JSON Schema of every payload
(these requests' from the models below) to ``schemas/``.
"""

from __future__ import annotations

import json
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StringConstraints,
    ValidationError,
    model_validator,
)
from pydantic_core import PydanticCustomError

from xgo_show.errors import ControlError

__all__ = [
    "MAX_PAYLOAD",
    "PROTOCOL_VERSION",
    "REQUESTS",
    "LoadRequest",
    "SeekRequest",
    "StartRequest",
    "StopRequest",
    "TriggerRequest",
    "error_payload",
    "ok_payload",
    "parse_request",
]

PROTOCOL_VERSION = 1
MAX_PAYLOAD = 4 * 1024 * 1024  # bytes: a routine or a compiled schedule inline, with room

Name = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_-]*$", max_length=64)]
Seconds = Annotated[float, Field(ge=0, allow_inf_nan=False)]


class _Request(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    v: Literal[1] = Field(1, description="Payload version (1).")


class EmptyRequest(_Request):
    """``pause``, ``resume``, ``panic``: no fields (the payload may be empty)."""


class LoadRequest(_Request):
    """Load a show: a file on the server's host, or the text of a routine or schedule."""

    path: Annotated[str, Field(min_length=1)] | None = Field(
        None, description="A routine (.yaml) or compiled schedule (.json) on the server's host."
    )
    routine: Annotated[str, Field(min_length=1)] | None = Field(
        None, description="The text of a routine (YAML); includes are not available."
    )
    schedule: Annotated[str, Field(min_length=1)] | None = Field(
        None, description="The text of a compiled schedule (JSON, as 'xgo-show compile' writes)."
    )

    @model_validator(mode="after")
    def _one_source(self) -> LoadRequest:
        given = [n for n in ("path", "routine", "schedule") if getattr(self, n) is not None]
        if len(given) != 1:
            raise PydanticCustomError(
                "load", "give exactly one of path, routine or schedule (got {given})",
                {"given": ", ".join(given) or "none"},
            )
        return self


class _From(_Request):
    """Where in the show: seconds, a bar (and beat), or a section."""

    time: Seconds | None = Field(None, description="Show time in seconds.")
    bar: Annotated[int, Field(ge=1)] | None = Field(None, description="Bar (from 1).")
    beat: Annotated[float, Field(ge=1, allow_inf_nan=False)] | None = Field(
        None, description="Beat in the bar (from 1; with bar)."
    )
    section: Name | None = Field(None, description="A section's name.")

    @model_validator(mode="after")
    def _one_place(self) -> _From:
        given = [n for n in ("time", "bar", "section") if getattr(self, n) is not None]
        if len(given) > 1:
            raise PydanticCustomError(
                "place", "give one of time, bar or section, not {given}",
                {"given": " and ".join(given)},
            )
        if self.beat is not None and self.bar is None:
            raise PydanticCustomError("place", "beat goes with bar", {})
        return self


class StartRequest(_From):
    """Start the loaded show: now, in a while, or at a wall-clock time; from the top or not."""

    at: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = Field(
        None, description="Wall-clock start time, Unix seconds (UTC); the hosts' clocks agree "
        "through NTP."
    )
    in_: Seconds | None = Field(None, alias="in", description="Start this many seconds from now.")
    force: bool = Field(False, description="Start even if battery or firmware checks fail.")

    model_config = ConfigDict(populate_by_name=True)

    @model_validator(mode="after")
    def _one_when(self) -> StartRequest:
        if self.at is not None and self.in_ is not None:
            raise PydanticCustomError("when", "give 'at' or 'in', not both", {})
        return self


class SeekRequest(_From):
    """Jump to a place in the show (one of time, bar, section is required)."""

    @model_validator(mode="after")
    def _a_place(self) -> SeekRequest:
        if self.time is None and self.bar is None and self.section is None:
            raise PydanticCustomError("place", "give time, bar or section", {})
        return self


class StopRequest(_Request):
    """Stop the show: every robot safe-stopped."""

    reason: Annotated[str, Field(max_length=200)] = Field(
        "stop requested", description="Said in the run log and the events."
    )


class TriggerRequest(_Request):
    """A trigger's optional payload (``NS/trigger/NAME``): any JSON value, echoed in events."""

    data: Any = Field(None, description="Anything the sender wants to attach (echoed).")
    source: Annotated[str, Field(max_length=64)] | None = Field(
        None, description="Who fires it (shown in events and the log)."
    )


REQUESTS: dict[str, type[_Request]] = {
    "load": LoadRequest,
    "start": StartRequest,
    "stop": StopRequest,
    "pause": EmptyRequest,
    "resume": EmptyRequest,
    "seek": SeekRequest,
    "panic": EmptyRequest,
    "trigger": TriggerRequest,
}


def parse_request(command: str, payload: bytes | None) -> _Request:
    """The request model for ``command`` from its payload; :class:`ControlError` if bad."""
    model = REQUESTS.get(command)
    if model is None:
        commands = ", ".join(c for c in REQUESTS if c != "trigger")
        raise ControlError(
            f"unknown command {command!r}; commands: {commands}", code="unknown_command"
        )
    raw = payload or b""
    if len(raw) > MAX_PAYLOAD:
        raise ControlError(
            f"payload of {len(raw)} bytes is over the limit of {MAX_PAYLOAD}", code="too_large"
        )
    data: object = {}
    if raw.strip():
        try:
            data = json.loads(raw)
        except (UnicodeDecodeError, ValueError) as exc:
            raise ControlError(f"payload is not JSON: {exc}", code="bad_request") from exc
    if not isinstance(data, dict):
        raise ControlError(f"payload must be a JSON object, not {_kind(data)}", code="bad_request")
    version = data.get("v", PROTOCOL_VERSION)
    if version != PROTOCOL_VERSION:
        raise ControlError(
            f"payload version {version!r} is not supported; this server speaks version "
            f"{PROTOCOL_VERSION}",
            code="version",
        )
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        first = exc.errors(include_url=False)[0]
        where = ".".join(str(p) for p in first["loc"] if not str(p).startswith("function-"))
        message = first["msg"].removeprefix("Value error, ")
        raise ControlError(f"{where + ': ' if where else ''}{message}", code="bad_request") from exc


def _kind(value: object) -> str:
    return {list: "an array", str: "a string", type(None): "null", bool: "a boolean"}.get(
        type(value), "a number"
    )


def ok_payload(command: str, **fields: Any) -> bytes:
    """A success reply."""
    return _dump({"v": PROTOCOL_VERSION, "ok": True, "command": command, **fields})


def error_payload(command: str, code: str, message: str) -> bytes:
    """An error reply (sent with ``query.reply_err``)."""
    return _dump({"v": PROTOCOL_VERSION, "ok": False, "command": command, "error": code,
                  "message": message})


def _dump(obj: dict[str, Any]) -> bytes:
    return json.dumps(obj, ensure_ascii=False, separators=(",", ":"), allow_nan=False).encode()
