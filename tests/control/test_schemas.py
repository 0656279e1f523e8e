"""The API's schema file is current, and docs/zenoh-api.md lists every key and every payload.

That the server's real replies and events match the schemas is checked where a real server
runs: tests/control/test_server.py validates every request, reply and event of its tests.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import jsonschema
import pytest

from xgo_show.control.keys import COMMANDS, EVENT_KINDS
from xgo_show.control.protocol import error_payload, ok_payload
from xgo_show.control.schemas import ERROR_CODES, SCHEMA_FILE, api_schema, definition

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "zenoh-api.md").read_text(encoding="utf-8")


def _payload_names() -> set[str]:
    return {n for n in api_schema()["$defs"] if n[0].islower()}


def test_the_committed_schema_is_current() -> None:
    committed = json.loads((ROOT / "schemas" / SCHEMA_FILE).read_text(encoding="utf-8"))
    assert committed == api_schema(), (
        f"regenerate: python -m xgo_show.control.schemas > schemas/{SCHEMA_FILE}"
    )
    jsonschema.Draft202012Validator.check_schema(committed)


def test_every_payload_has_a_definition() -> None:
    expected = {f"request-{c}" for c in (*COMMANDS, "trigger")}
    expected |= {f"reply-{c}" for c in (*COMMANDS, "status", "trigger")}
    expected |= {f"event-{k}" for k in EVENT_KINDS} | {"error"}
    assert _payload_names() == expected


def test_the_doc_lists_every_key_with_its_schema() -> None:
    rows = dict(re.findall(r"^\| `(NS/[^`]+)` \|.*\| ([^|]+) \|$", DOC, re.MULTILINE))
    keys = {f"NS/control/{c}" for c in COMMANDS} | {"NS/status", "NS/trigger/NAME"}
    keys |= {f"NS/event/{k}" for k in EVENT_KINDS if k != "telemetry"}
    keys.add("NS/event/telemetry/ROBOT")
    assert set(rows) == keys
    named = {n for cell in rows.values() for n in re.findall(r"`([a-z]+(?:-[a-z]+)?)`", cell)}
    assert named | {"error"} == _payload_names()
    assert f"schemas/{SCHEMA_FILE}" in DOC


def test_the_doc_shows_the_access_control_example_as_it_is() -> None:
    text = (ROOT / "examples" / "zenoh-acl" / "serve.json5").read_text(encoding="utf-8")
    assert f"```json5\n{text}```" in DOC


def test_the_doc_lists_every_error_code() -> None:
    section = DOC.split("\n## Errors\n", 1)[1].split("\n## ", 1)[0]
    table = set(re.findall(r"^\| `([a-z_]+)` \| ", section, re.MULTILINE))
    assert table == set(ERROR_CODES)


@pytest.mark.parametrize("code", ERROR_CODES)
def test_error_replies_match_the_schema(code: str) -> None:
    body = json.loads(error_payload("start", code, "why"))
    assert not list(jsonschema.Draft202012Validator(definition("error")).iter_errors(body))


def test_a_reply_with_a_field_the_schema_does_not_know_is_invalid() -> None:
    good = json.loads(ok_payload("trigger", trigger="go", section="b", held=True))
    validator = jsonschema.Draft202012Validator(definition("reply-trigger"))
    assert not list(validator.iter_errors(good))
    assert list(validator.iter_errors({**good, "surprise": 1}))


def test_a_definition_is_a_schema_of_its_own_draft_for_one_payload() -> None:
    whole = api_schema()
    assert definition("reply-start") == {"$schema": whole["$schema"], "$defs": whole["$defs"],
                                         "$ref": "#/$defs/reply-start"}
