"""The relay protocol's payloads: round trips, every malformed message refused in one line."""

from __future__ import annotations

import contextlib
import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.net import messages as msg

WHO = msg.Conductor("c0ffee", "alice@laptop")


def request(op: str, **fields: object) -> bytes:
    return msg.encode(msg.Request(op, 3, WHO, 12.5, fields).to_json())


def test_a_request_round_trips() -> None:
    data = request("start", sha256="ab" * 32, start_at=101.25, offset=0.0)
    got = msg.decode_request(data)
    assert (got.op, got.seq, got.conductor, got.sent) == ("start", 3, WHO, 12.5)
    assert got.number("start_at") == 101.25
    assert got.text("sha256") == "ab" * 32


def test_optional_times_may_be_null_or_missing() -> None:
    assert msg.decode_request(request("pause", at=None)).maybe_number("at") is None
    assert msg.decode_request(request("pause")).maybe_number("at") is None
    assert msg.decode_request(request("resume", at=5)).maybe_number("at") == 5.0


@pytest.mark.parametrize(
    ("data", "says"),
    [
        (b"\xff\xfe", "not a JSON message"),
        (b"[1, 2]", "JSON object"),
        (b'{"v": 2, "op": "hello"}', "protocol version 2"),
        (b'{"v": 1, "op": "dance"}', "unknown op 'dance'"),
        (b'{"v": 1, "op": "hello", "seq": -1}', "'seq'"),
        (b'{"v": 1, "op": "hello", "seq": 1, "conductor": "me"}', "'conductor'"),
    ],
)
def test_malformed_messages_say_what_is_wrong(data: bytes, says: str) -> None:
    with pytest.raises(msg.MessageError, match=says):
        msg.decode_request(data)


def test_missing_and_mistyped_fields_are_named() -> None:
    with pytest.raises(msg.MessageError, match="missing field 'offset'"):
        msg.decode_request(request("start", sha256="x", start_at=1.0))
    with pytest.raises(msg.MessageError, match=r"start\.start_at' must be a number"):
        msg.decode_request(request("start", sha256="x", start_at="soon", offset=0.0))
    with pytest.raises(msg.MessageError, match="link_loss"):
        msg.decode_request(
            request("upload", schedule="", sha256="", link_loss="pray", watchdog_ms=500)
        )
    raw = json.loads(request("start", sha256="x", start_at=1.0, offset=0.0))
    raw["start_at"] = float("inf")
    with pytest.raises(ValueError):  # the encoder refuses non-finite numbers outright
        msg.encode(raw)
    text = json.dumps(raw).encode()  # Python's json writes Infinity; the decoder refuses it
    with pytest.raises(msg.MessageError, match="finite"):
        msg.decode_request(text)


def test_size_caps() -> None:
    big = request("stop", reason="x" * msg.MAX_REQUEST_BYTES)
    with pytest.raises(msg.MessageError, match="over"):
        msg.decode_request(big)
    schedule = "x" * (msg.MAX_REQUEST_BYTES * 2)
    upload = request("upload", schedule=schedule, sha256="", link_loss="stop", watchdog_ms=500)
    assert msg.decode_request(upload).op == "upload"  # uploads have their own, larger cap
    with pytest.raises(msg.MessageError, match="over the limit"):
        msg.decode_request(b" " * (msg.MAX_UPLOAD_BYTES + 1))


@given(st.binary(max_size=300))
def test_random_bytes_never_raise_anything_else(data: bytes) -> None:
    with contextlib.suppress(msg.MessageError):
        msg.decode_request(data)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.dictionaries(
        st.sampled_from(["v", "op", "seq", "conductor", "sent", "at", "reason", "performer"]),
        st.one_of(
            st.none(),
            st.booleans(),
            st.integers(),
            st.floats(allow_nan=False),
            st.text(max_size=8),
            st.sampled_from(list(msg.OPS)),
            st.fixed_dictionaries({"id": st.text(max_size=4), "name": st.text(max_size=4)}),
        ),
    ),
    st.sampled_from(list(msg.OPS)),
)
def test_random_objects_never_raise_anything_else(fields: dict[str, object], op: str) -> None:
    fields.setdefault("op", op)
    with contextlib.suppress(msg.MessageError):
        msg.decode_request(json.dumps(fields).encode())


def test_replies_round_trip_and_are_checked() -> None:
    out = msg.error_reply("left", 5.0, 9, "held by bob")
    got = msg.decode_reply(msg.encode(out))
    assert (got.seq, got.ok, got.error) == (9, False, "held by bob")
    assert (got.relay, got.relay_time) == ("left", 5.0)
    with pytest.raises(msg.MessageError, match="'ok'"):
        msg.decode_reply(b'{"v": 1, "seq": 1, "relay": "x", "relay_time": 1}')


def test_a_names_field_is_a_short_list_of_names() -> None:
    def play(robots: object) -> bytes:
        return msg.encode({"v": 1, "op": "stage_play", "seq": 1, "sent": 0.0,
                           "conductor": {"id": "c", "name": "c"}, "sha256": "ab",
                           "robots": robots, "play": 3, "at": None})

    assert msg.decode_request(play(["rex", "fido"])).fields["robots"] == ("rex", "fido")
    for bad in ("rex", [1], [""], ["x" * 65], ["r"] * (msg.MAX_NAMES + 1)):
        with pytest.raises(msg.MessageError, match="stage_play.robots"):
            msg.decode_request(play(bad))
