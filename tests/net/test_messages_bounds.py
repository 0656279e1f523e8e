"""The relay protocol's payloads (net/messages.py) at their bounds and in their words: the size
limits at the byte, every field check's edge and message, the reply's own fields, and the
compact encoding (test_messages.py holds the round trips and the random inputs)."""

from __future__ import annotations

import json
from typing import Any

import pytest

from xgo_show.errors import MessageError
from xgo_show.net import messages as msg

WHO = {"id": "c1", "name": "alice"}


def raw(op: str, **fields: Any) -> dict[str, Any]:
    return {"v": msg.PROTOCOL_VERSION, "op": op, "seq": 1, "conductor": WHO, "sent": 1.0,
            **fields}


def decode(message: dict[str, Any]) -> msg.Request:
    return msg.decode_request(json.dumps(message).encode())


def refused(message: dict[str, Any] | bytes) -> str:
    data = message if isinstance(message, bytes) else json.dumps(message).encode()
    with pytest.raises(MessageError) as info:
        msg.decode_request(data)
    return str(info.value)


def padded(op: str, size: int, **fields: Any) -> bytes:
    """A request of exactly ``size`` bytes (padding in its string field ``pad_field``)."""
    base = json.dumps(raw(op, **fields)).encode()
    message = raw(op, **fields, pad="")
    short = json.dumps(message).encode()
    message["pad"] = "x" * (size - len(short))
    data = json.dumps(message).encode()
    assert len(data) == size and len(base) < size
    return data


def test_encoding_is_compact_utf8_json_without_nan() -> None:
    assert msg.encode({"a": 1, "b": [1, "é"]}) == b'{"a":1,"b":[1,"\\u00e9"]}'
    with pytest.raises(ValueError):
        msg.encode({"x": float("nan")})


def test_a_request_of_exactly_the_limit_is_read_and_one_byte_more_is_not() -> None:
    assert msg.decode_request(padded("heartbeat", msg.MAX_REQUEST_BYTES)).op == "heartbeat"
    over = padded("heartbeat", msg.MAX_REQUEST_BYTES + 1)
    assert refused(over) == f"heartbeat of {len(over)} bytes is over {msg.MAX_REQUEST_BYTES}"


def test_any_message_over_the_upload_limit_is_refused_before_it_is_read() -> None:
    data = b" " * (msg.MAX_UPLOAD_BYTES + 1)
    assert refused(data) == (f"message of {len(data)} bytes is over the limit of "
                             f"{msg.MAX_UPLOAD_BYTES} bytes")
    with pytest.raises(MessageError, match=r"^not a JSON message"):
        msg.decode_request(b" " * msg.MAX_UPLOAD_BYTES)  # at the limit: read (and empty)


@pytest.mark.parametrize(("value", "kind"), [([1], "list"), ("s", "str"), (None, "NoneType")])
def test_a_message_that_is_no_object_says_what_it_is(value: Any, kind: str) -> None:
    assert refused(json.dumps(value).encode()) == f"a message is a JSON object, not {kind}"


def test_an_unknown_op_lists_the_known_ones() -> None:
    assert refused(raw("dance")) == f"unknown op 'dance'; one of {', '.join(msg.OPS)}"


@pytest.mark.parametrize("seq", [-1, 1.5, True, "1", None])
def test_a_sequence_number_is_a_whole_number_from_zero(seq: Any) -> None:
    assert refused(raw("hello") | {"seq": seq}) == "field 'seq' must be a whole number >= 0"


def test_sequence_number_zero_is_fine() -> None:
    assert decode(raw("hello") | {"seq": 0}).seq == 0


@pytest.mark.parametrize(
    "who", [{"id": "c1"}, {"name": "x"}, {"id": "", "name": "x"}, {"id": 1, "name": "x"},
            {"id": "c1", "name": 2}, "c1", None])
def test_the_conductor_needs_an_id_and_a_name(who: Any) -> None:
    assert refused(raw("hello") | {"conductor": who}) == (
        "field 'conductor' must be {'id': str, 'name': str}")


def test_the_conductors_id_and_name_are_cut_to_size() -> None:
    request = decode(raw("hello") | {"conductor": {"id": "i" * 70, "name": "n" * 250}})
    assert request.conductor == msg.Conductor("i" * 64, "n" * 200)


@pytest.mark.parametrize(("sent", "error"), [
    ("now", "field 'sent' must be a number, not str"),
    (True, "field 'sent' must be a number, not bool"),
    (None, "field 'sent' must be a number, not NoneType"),
])
def test_sent_is_a_number(sent: Any, error: str) -> None:
    assert refused(raw("hello") | {"sent": sent}) == error


def test_each_kind_of_field_is_checked_with_its_own_words() -> None:
    assert refused(raw("stop", reason=3)) == "field 'stop.reason' must be a string"
    assert refused(raw("seek", show_time="1")) == (
        "field 'seek.show_time' must be a number, not str")
    assert refused(raw("pause", at="soon")) == "field 'pause.at' must be a number, not str"
    good = {"schedule": "s", "sha256": "h", "link_loss": "stop", "watchdog_ms": 0}
    assert decode(raw("upload", **good)).whole("watchdog_ms") == 0
    for bad in (-1, 1.5, True):
        assert refused(raw("upload", **good | {"watchdog_ms": bad})) == (
            "field 'upload.watchdog_ms' must be a whole number >= 0")
    assert refused(raw("upload", **good | {"link_loss": "pause"})) == (
        "field 'upload.link_loss' must be one of stop, continue, not 'pause'")


def test_a_list_of_names_has_its_bounds() -> None:
    def names(value: Any) -> msg.Request:
        return decode(raw("stage_rest", robots=value))

    assert names(["a", "b" * 64]).fields["robots"] == ("a", "b" * 64)
    assert len(names([f"r{i}" for i in range(msg.MAX_NAMES)]).fields["robots"]) == msg.MAX_NAMES
    error = f"field 'stage_rest.robots' must be a list of at most {msg.MAX_NAMES} names"
    for bad in ([f"r{i}" for i in range(msg.MAX_NAMES + 1)], [""], ["b" * 65], [1], "rex"):
        assert refused(raw("stage_rest", robots=bad)) == error


def test_a_requests_fields_are_read_by_kind() -> None:
    request = decode(raw("start", sha256="h", start_at=None, offset=2.0))
    assert request.text("sha256") == "h"
    assert request.number("offset") == 2.0
    assert request.maybe_number("start_at") is None
    assert request.maybe_number("start_in") is None


def reply(**changes: Any) -> bytes:
    base = {"v": msg.PROTOCOL_VERSION, "seq": 3, "ok": True, "error": None, "relay": "hall",
            "relay_time": 5.0, "show": {"state": "idle"}, "at": 7.5}
    return json.dumps(base | changes).encode()


def test_a_reply_keeps_its_own_fields_apart_from_the_envelope() -> None:
    got = msg.decode_reply(reply())
    assert (got.seq, got.ok, got.error, got.relay, got.relay_time) == (3, True, None, "hall",
                                                                       5.0)
    assert got.fields == {"show": {"state": "idle"}, "at": 7.5}
    assert msg.decode_reply(reply(ok=False, error="no")).error == "no"


@pytest.mark.parametrize(("changes", "error"), [
    ({"seq": "3"}, "reply field 'seq' must be a whole number"),
    ({"seq": True}, "reply field 'seq' must be a whole number"),
    ({"ok": 1}, "reply fields 'ok' (bool) and 'error' (str or null) are required"),
    ({"error": 5}, "reply fields 'ok' (bool) and 'error' (str or null) are required"),
    ({"relay": None}, "reply field 'relay' must be a string"),
    ({"relay_time": "t"}, "field 'relay_time' must be a number, not str"),
])
def test_a_bad_reply_says_which_field(changes: dict[str, Any], error: str) -> None:
    with pytest.raises(MessageError) as info:
        msg.decode_reply(reply(**changes))
    assert str(info.value) == error
