"""Show-control payloads, parsed in-process: a request is checked whole, and a malformed one is
refused with the code and a message that names the field (docs/zenoh-api.md), never half
applied. Replies are compact JSON with the version, and trigger names are one key chunk."""

from __future__ import annotations

import json

import pytest

from xgo_show.control.keys import (
    check_trigger_name,
    control_key,
    event_key,
    status_key,
    telemetry_key,
    trigger_key,
)
from xgo_show.control.protocol import (
    MAX_PAYLOAD,
    EmptyRequest,
    LoadRequest,
    SeekRequest,
    StartRequest,
    StopRequest,
    TriggerRequest,
    error_payload,
    ok_payload,
    parse_request,
)
from xgo_show.errors import ControlError, UsageError


def refusal(command: str, payload: bytes | None) -> tuple[str, str]:
    with pytest.raises(ControlError) as err:
        parse_request(command, payload)
    return err.value.code, str(err.value)


@pytest.mark.parametrize(
    ("command", "model"),
    [("load", LoadRequest), ("start", StartRequest), ("stop", StopRequest),
     ("pause", EmptyRequest), ("resume", EmptyRequest), ("seek", SeekRequest),
     ("panic", EmptyRequest), ("trigger", TriggerRequest)],
)
def test_each_command_has_its_request(command: str, model: type) -> None:
    payload = {"load": b'{"path": "show.yaml"}', "seek": b'{"time": 1.5}'}.get(command, b"")
    assert type(parse_request(command, payload)) is model


def test_an_empty_or_missing_payload_is_the_default_request() -> None:
    for payload in (None, b"", b"  \n"):
        assert parse_request("stop", payload) == StopRequest(reason="stop requested")
        assert parse_request("pause", payload) == EmptyRequest()


def test_an_unknown_command_lists_the_commands_but_not_trigger() -> None:
    assert refusal("jump", b"") == (
        "unknown_command",
        "unknown command 'jump'; commands: load, start, stop, pause, resume, seek, panic",
    )


def test_a_payload_over_the_limit_is_refused_and_one_at_it_is_read() -> None:
    at_limit = b'{"reason": "x"}'.ljust(MAX_PAYLOAD)
    assert parse_request("stop", at_limit) == StopRequest(reason="x")
    over = at_limit + b" "
    assert refusal("stop", over) == (
        "too_large", f"payload of {MAX_PAYLOAD + 1} bytes is over the limit of {MAX_PAYLOAD}"
    )


@pytest.mark.parametrize("payload", [b"{not json", b"\xff\xfe{}", b'{"v": 1'])
def test_a_payload_that_is_not_json_is_a_bad_request(payload: bytes) -> None:
    code, message = refusal("start", payload)
    assert code == "bad_request" and message.startswith("payload is not JSON: ")


@pytest.mark.parametrize(
    ("payload", "kind"),
    [(b"[1]", "an array"), (b'"go"', "a string"), (b"null", "null"), (b"true", "a boolean"),
     (b"3", "a number"), (b"2.5", "a number")],
)
def test_a_payload_that_is_no_object_says_what_it_is(payload: bytes, kind: str) -> None:
    assert refusal("pause", payload) == ("bad_request", f"payload must be a JSON object, not {kind}")


def test_another_version_is_refused_and_version_1_may_be_said_or_left_out() -> None:
    assert refusal("pause", b'{"v": 2}') == (
        "version", "payload version 2 is not supported; this server speaks version 1"
    )
    assert refusal("pause", b'{"v": "1"}')[0] == "version"
    assert parse_request("pause", b'{"v": 1}') == parse_request("pause", b"{}")


@pytest.mark.parametrize(
    ("command", "payload", "message"),
    [
        ("pause", b'{"now": true}', "now: Extra inputs are not permitted"),
        ("start", b'{"in": -1}', "in: Input should be greater than or equal to 0"),
        ("start", b'{"at": 0}', "at: Input should be greater than 0"),
        ("start", b'{"time": "3"}', "time: Input should be a valid number"),
        ("start", b'{"bar": 0}', "bar: Input should be greater than or equal to 1"),
        ("start", b'{"section": "two words"}', "section: String should match pattern"),
        ("stop", b'{"reason": 7}', "reason: Input should be a valid string"),
        ("trigger", b'{"source": "%s"}' % (b"s" * 65), "source: String should have at most 64"),
        ("load", b"{}", "give exactly one of path, routine or schedule (got none)"),
        ("load", b'{"path": "a.yaml", "routine": "x"}',
         "give exactly one of path, routine or schedule (got path, routine)"),
        ("load", b'{"path": ""}', "path: String should have at least 1 character"),
        ("start", b'{"time": 1, "section": "verse"}', "give one of time, bar or section, not "
         "time and section"),
        ("start", b'{"beat": 2}', "beat goes with bar"),
        ("start", b'{"at": 5, "in": 1}', "give 'at' or 'in', not both"),
        ("seek", b"{}", "give time, bar or section"),
    ],
)
def test_a_malformed_request_is_refused_naming_its_field(
    command: str, payload: bytes, message: str
) -> None:
    code, said = refusal(command, payload)
    assert code == "bad_request"
    assert said.startswith(message), said


def test_a_valid_request_keeps_what_was_sent() -> None:
    start = parse_request("start", b'{"bar": 3, "beat": 2.5, "in": 0.5, "force": true}')
    assert start == StartRequest(bar=3, beat=2.5, in_=0.5, force=True)
    assert parse_request("seek", b'{"section": "chorus"}') == SeekRequest(section="chorus")
    trigger = parse_request("trigger", b'{"data": {"n": [1, 2]}, "source": "door"}')
    assert trigger == TriggerRequest(data={"n": [1, 2]}, source="door")


def test_replies_are_compact_json_with_the_version() -> None:
    assert ok_payload("start", at=1.5, name="é") == (
        '{"v":1,"ok":true,"command":"start","at":1.5,"name":"é"}'.encode()
    )
    assert json.loads(error_payload("seek", "bad_request", "no")) == {
        "v": 1, "ok": False, "command": "seek", "error": "bad_request", "message": "no"}
    with pytest.raises(ValueError):
        ok_payload("status", at=float("nan"))  # not JSON: never sent


def test_keys_sit_under_the_namespace() -> None:
    assert control_key("ns") == "ns/control/*" and control_key("ns", "stop") == "ns/control/stop"
    assert status_key("ns") == "ns/status"
    assert trigger_key("ns") == "ns/trigger/*" and trigger_key("ns", "go") == "ns/trigger/go"
    assert event_key("ns") == "ns/event/**" and event_key("ns", "cue") == "ns/event/cue"
    assert telemetry_key("ns") == "ns/event/telemetry/*"
    assert telemetry_key("ns", "rex") == "ns/event/telemetry/rex"


@pytest.mark.parametrize("name", ["go", "_x", "Door-Bell_2", "a" * 64])
def test_a_trigger_name_is_one_key_chunk(name: str) -> None:
    assert check_trigger_name(name) == name


@pytest.mark.parametrize("name", ["", "2go", "-x", "a/b", "a*", "door bell", "a" * 65])
def test_a_trigger_name_that_is_not_one_key_chunk_is_refused(name: str) -> None:
    with pytest.raises(UsageError) as err:
        check_trigger_name(name)
    assert str(err.value) == (
        f"trigger name {name!r}: use letters, digits, '_' and '-', starting with a letter or "
        "'_' (at most 64)"
    )
