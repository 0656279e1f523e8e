"""A relay process started with ``--zenoh-config`` that requires a user and password: a
conductor without them (none, or a wrong password) neither sees it (``relays`` lists nothing)
nor drives it (``hello`` goes unanswered); with them it does both. The same configuration files
as ``tests/net/test_security.py``, which also covers mutual TLS at the session level."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from tests.loopback import free_port
from tests.net.test_security import usrpwd_configs
from tests.relay.conftest import wait_for
from tests.relay.processes import Relays
from xgo_show.errors import NetworkError
from xgo_show.net.session import SessionOptions, open_session
from xgo_show.relay.client import RelayClient, list_relays

REFUSED_WAIT = 0.6  # seconds a refused conductor is given to find the relay anyway


def _write(path: Path, config: dict[str, Any]) -> str:
    path.write_text(json.dumps(config, indent=2), encoding="utf-8")
    return str(path)


def _conductor(config_file: str, *, expect: bool) -> tuple[list[str], str]:
    """What a conductor with this config sees (relay names) and what ``hello`` gives."""
    session = open_session(SessionOptions(config_file=config_file))
    try:
        seen: list[str] = []

        def found() -> bool:
            seen[:] = [r["relay"] for r in list_relays(session, timeout=0.2)]
            return bool(seen)

        try:
            wait_for(found, timeout=5.0 if expect else REFUSED_WAIT)
        except AssertionError:
            pass  # nothing found: the hello below says the rest
        try:
            RelayClient(session, "vault", timeout=0.5).hello()
            hello = "held"
        except NetworkError as exc:
            hello = str(exc)
        return seen, hello
    finally:
        session.close()


def test_a_relay_requiring_a_password_is_invisible_and_deaf_without_it(
    tmp_path: Path, relays: Relays
) -> None:
    relay_conf, cases = usrpwd_configs(tmp_path, f"tcp/127.0.0.1:{free_port()}")
    config = _write(tmp_path / "relay.json5", relay_conf)
    relays.start("vault", {"rex": "mini"}, "--zenoh-config", config, listen=False)
    got = {
        name: _conductor(_write(tmp_path / f"{name}.json5", conf), expect=name == "right")
        for name, conf in cases.items()
    }
    assert got["right"] == (["vault"], "held")
    for refused in ("none", "wrong"):
        seen, hello = got[refused]
        assert seen == [], refused
        assert "did not answer hello" in hello, (refused, hello)
