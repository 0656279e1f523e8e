"""Zenoh's own security from configuration files (what ``--zenoh-config FILE`` reads): user and
password authentication, and mutual TLS. A peer without the credentials neither sees the
relay-side time server (a query finds nobody) nor drives it (time-sync pings go unanswered);
with them it does both. Certificates are made in the test with ``openssl``.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

from tests.loopback import free_port
from xgo_show.net.timesync import TimeSyncError, measure, serve_time
from xgo_show.runtime.clock import MonotonicClock

KEY = "xgo-show/relay/vault/time"


def _config(path: Path, config: dict[str, Any]) -> zenoh.Config:
    """Write ``config`` as a file and read it back the way --zenoh-config does."""
    path.write_text(json.dumps(config, indent=2), encoding="utf-8")
    return zenoh.Config.from_file(str(path))


def _peer(endpoints: dict[str, list[str]], **transport: Any) -> dict[str, Any]:
    out: dict[str, Any] = {
        "mode": "peer",
        "scouting": {"multicast": {"enabled": False}},
        **{what: {"endpoints": eps} for what, eps in endpoints.items()},
    }
    if transport:
        out["transport"] = transport
    return out


def _reaches(relay_conf: zenoh.Config, conductor_conf: zenoh.Config) -> tuple[bool, bool]:
    """(sees the time server, drives it) for a conductor with ``conductor_conf``."""
    with zenoh.open(relay_conf) as relay:
        server = serve_time(relay, KEY, MonotonicClock())
        try:
            with zenoh.open(conductor_conf) as conductor:
                seen = False
                for _ in range(10):  # up to ~1 s for the session to come up
                    replies = conductor.get(
                        KEY, payload=b'{"v":1,"op":"ping","seq":0}', timeout=0.1
                    )
                    seen = any(r.ok is not None for r in replies)
                    if seen:
                        break
                try:
                    measure(conductor, KEY, n=3, timeout=0.2)
                    driven = True
                except TimeSyncError:
                    driven = False
                return seen, driven
        finally:
            server.close()


def usrpwd_configs(
    tmp_path: Path, endpoint: str
) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
    """A relay's config that requires a user and password (listening on ``endpoint``), and
    conductors' configs: ``none`` (no credentials), ``wrong`` (a wrong password), ``right``.
    Also used by ``tests/relay/test_security.py`` with a relay process."""
    users = tmp_path / "users.txt"
    users.write_text("relay:relay-pw\nalice:s3cret\n", encoding="utf-8")
    auth = {"user": "relay", "password": "relay-pw", "dictionary_file": str(users)}
    relay = _peer({"listen": [endpoint]}, auth={"usrpwd": auth})
    conn = {"connect": [endpoint]}
    return relay, {
        "none": _peer(conn),
        "wrong": _peer(conn, auth={"usrpwd": {"user": "alice", "password": "guess"}}),
        "right": _peer(conn, auth={"usrpwd": {"user": "alice", "password": "s3cret"}}),
    }


def test_user_and_password(tmp_path: Path) -> None:
    relay, cases = usrpwd_configs(tmp_path, f"tcp/127.0.0.1:{free_port()}")
    got = {
        name: _reaches(
            _config(tmp_path / "relay.json5", relay), _config(tmp_path / f"{name}.json5", c)
        )
        for name, c in cases.items()
    }
    assert got == {"none": (False, False), "wrong": (False, False), "right": (True, True)}


@pytest.fixture
def certs(tmp_path: Path) -> Iterator[Path]:
    """A throw-away CA, and relay and conductor certificates for 127.0.0.1 (openssl)."""
    if shutil.which("openssl") is None:
        pytest.skip("openssl is not installed: cannot make the test certificates")
    (tmp_path / "leaf.ext").write_text(
        "subjectAltName=IP:127.0.0.1\nextendedKeyUsage=serverAuth,clientAuth\n", encoding="utf-8"
    )
    ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]

    def openssl(*args: str) -> None:
        subprocess.run(["openssl", *args], cwd=tmp_path, check=True, capture_output=True)

    openssl(
        "req",
        "-x509",
        *ec,
        "-days",
        "1",
        "-subj",
        "/CN=test CA",
        "-keyout",
        "ca.key",
        "-out",
        "ca.pem",
    )
    for who in ("relay", "conductor"):
        openssl("req", *ec, "-subj", f"/CN={who}", "-keyout", f"{who}.key", "-out", f"{who}.csr")
        openssl(
            "x509",
            "-req",
            "-in",
            f"{who}.csr",
            "-CA",
            "ca.pem",
            "-CAkey",
            "ca.key",
            "-CAcreateserial",
            "-days",
            "1",
            "-extfile",
            "leaf.ext",
            "-out",
            f"{who}.pem",
        )
    yield tmp_path


def test_mutual_tls(certs: Path) -> None:
    port = free_port()
    ca = str(certs / "ca.pem")
    relay = _peer(
        {"listen": [f"tls/127.0.0.1:{port}"]},
        link={
            "tls": {
                "root_ca_certificate": ca,
                "enable_mtls": True,
                "listen_private_key": str(certs / "relay.key"),
                "listen_certificate": str(certs / "relay.pem"),
            }
        },
    )
    tls = {"connect": [f"tls/127.0.0.1:{port}"]}
    cases = {
        "plain tcp": _peer({"connect": [f"tcp/127.0.0.1:{port}"]}),
        "no certificate": _peer(tls, link={"tls": {"root_ca_certificate": ca}}),
        "certificate": _peer(
            tls,
            link={
                "tls": {
                    "root_ca_certificate": ca,
                    "enable_mtls": True,
                    "connect_private_key": str(certs / "conductor.key"),
                    "connect_certificate": str(certs / "conductor.pem"),
                }
            },
        ),
    }
    got = {
        name: _reaches(_config(certs / "relay.json5", relay), _config(certs / "c.json5", c))
        for name, c in cases.items()
    }
    assert got == {
        "plain tcp": (False, False),
        "no certificate": (False, False),
        "certificate": (True, True),
    }
