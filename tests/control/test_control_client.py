"""The show-control client (control/client.py, what ``ctl`` and ``trigger`` use) in this
process, over a recording session (tests/relay/recording.py) in place of Zenoh: the key and
payload of each call, replies, error replies in words, silence, replies that are not JSON,
and a trigger put. test_server.py runs the same client against ``serve`` over Zenoh."""

from __future__ import annotations

import json
from typing import Any

import pytest
import zenoh

from tests.relay.recording import Answer, RecordingSession
from xgo_show.control.client import ControlClient, ControlFailed


def ok(body: dict[str, Any]) -> Answer:
    return Answer(json.dumps(body).encode())


def err(body: Any) -> Answer:
    return Answer(err=json.dumps(body).encode())


def test_a_client_defaults_to_the_namespace_and_five_seconds() -> None:
    s = RecordingSession()
    c = ControlClient(s)  # type: ignore[arg-type]
    assert (c.ns, c.timeout, c.session) == ("xgo-show", 5.0, s)


def test_a_command_is_one_query_with_its_fields_and_returns_the_reply() -> None:
    s = RecordingSession(lambda q: [ok({"ok": True, "command": "start", "offset": 1.0})])
    c = ControlClient(s, "ns", timeout=2.5)  # type: ignore[arg-type]
    assert c.command("start", time=1.0, section=None, force=False) == {
        "ok": True, "command": "start", "offset": 1.0}
    (q,) = s.queries
    assert (q.key, q.timeout, q.congestion_control) == ("ns/control/start", 2.5,
                                                         zenoh.CongestionControl.BLOCK)
    assert json.loads(q.payload) == {"v": 1, "time": 1.0, "force": False}  # None left out


def test_status_asks_without_a_payload() -> None:
    s = RecordingSession(lambda q: [ok({"state": "idle"})])
    assert ControlClient(s, "ns").status() == {"state": "idle"}  # type: ignore[arg-type]
    (q,) = s.queries
    assert (q.key, q.payload) == ("ns/status", b"")


def test_a_trigger_query_carries_its_source_and_data_only_when_given() -> None:
    s = RecordingSession(lambda q: [ok({"held": True})])
    c = ControlClient(s, "ns")  # type: ignore[arg-type]
    assert c.trigger("go") == {"held": True}
    c.trigger("go", source="desk", data={"n": 1})
    c.trigger("go", data=0)
    assert [q.key for q in s.queries] == ["ns/trigger/go"] * 3
    assert [json.loads(q.payload) for q in s.queries] == [
        {"v": 1}, {"v": 1, "source": "desk", "data": {"n": 1}}, {"v": 1, "data": 0}]


def test_a_trigger_put_is_fire_and_forget() -> None:
    s = RecordingSession()
    got = ControlClient(s, "ns").trigger("go", source="desk", reply=False)  # type: ignore[arg-type]
    assert got == {"v": 1, "ok": True, "command": "trigger", "sent": True}
    assert s.queries == []
    (key, payload, congestion) = s.puts[0]
    assert (key, json.loads(payload), congestion) == (
        "ns/trigger/go", {"v": 1, "source": "desk"}, zenoh.CongestionControl.BLOCK)


def test_an_error_reply_is_control_failed_with_the_server_words_and_code() -> None:
    body = {"ok": False, "command": "start", "error": "refused",
            "message": "no show is loaded: send load first"}
    s = RecordingSession(lambda q: [err(body), ok({"ok": True})])
    with pytest.raises(ControlFailed) as info:
        ControlClient(s, "ns").command("start")  # type: ignore[arg-type]
    assert str(info.value) == "start: no show is loaded: send load first"
    assert info.value.code == "refused" and info.value.reply == body


def test_an_error_message_naming_the_command_is_not_prefixed_again() -> None:
    s = RecordingSession(lambda q: [err({"error": "refused", "message": "trigger 'go' refused"})])
    with pytest.raises(ControlFailed) as info:
        ControlClient(s, "ns").trigger("go")  # type: ignore[arg-type]
    assert str(info.value) == "trigger 'go' refused"


def test_an_error_reply_without_a_message_or_code_shows_itself() -> None:
    s = RecordingSession(lambda q: [err({"why": "x"})])
    with pytest.raises(ControlFailed) as info:
        ControlClient(s, "ns").status()  # type: ignore[arg-type]
    assert str(info.value) == "status: {'why': 'x'}" and info.value.code == "error"


def test_no_server_answering_says_where_and_how_long() -> None:
    s = RecordingSession()
    with pytest.raises(ControlFailed) as info:
        ControlClient(s, "ns", timeout=0.5).command("pause")  # type: ignore[arg-type]
    assert str(info.value) == (
        "pause: no xgo-show serve answered on ns/control/pause within 0.5 s (is it running, "
        "with the same --namespace and reachable endpoints?)")
    assert info.value.code == "no_reply"


@pytest.mark.parametrize(("raw", "message"), [
    (b"{no", "status: the reply is not JSON: "),
    (b"[1]", "status: the reply is not a JSON object"),
])
def test_a_reply_that_is_not_a_json_object_is_refused(raw: bytes, message: str) -> None:
    for answer in (Answer(raw), Answer(err=raw)):
        s = RecordingSession(lambda q, a=answer: [a])  # type: ignore[misc]
        with pytest.raises(ControlFailed) as info:
            ControlClient(s, "ns").status()  # type: ignore[arg-type]
        assert str(info.value).startswith(message) and info.value.code == "bad_reply"
