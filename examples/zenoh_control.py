"""Start a show, fire a trigger and print status with nothing but ``zenoh`` (no xgo_show import).

The proof that the control API (docs/zenoh-api.md) stands on its own: a game engine, a sensor
or a lighting desk can do exactly this. Against a running ``xgo-show serve``::

    python examples/zenoh_control.py --connect tcp/192.168.1.20:7447 --show show.yaml

or self-contained, with a server of simulated robots started for the demo::

    python examples/zenoh_control.py --serve --show choreographies/curtain_call.yaml
"""

from __future__ import annotations

import argparse
import json
import socket
import subprocess
import sys
import time
from typing import Any

import zenoh


def ask(session: zenoh.Session, key: str, payload: dict[str, Any] | None = None) -> dict[str, Any]:
    """One query: the reply's JSON, or an exception carrying the server's error message."""
    data = None if payload is None else json.dumps({"v": 1, **payload}).encode()
    for reply in session.get(key, payload=data, timeout=5.0,
                             congestion_control=zenoh.CongestionControl.BLOCK):
        if reply.ok is not None:
            return dict(json.loads(reply.ok.payload.to_bytes()))
        assert reply.err is not None
        raise RuntimeError(json.loads(reply.err.payload.to_bytes())["message"])
    raise RuntimeError(f"nobody answered on {key}")


def main(connect: str, ns: str, show: str, trigger: str) -> None:
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([connect]))
    with zenoh.open(config) as session:
        deadline = time.monotonic() + 30
        while True:  # wait for the server: a status query answered
            try:
                status = ask(session, f"{ns}/status")
                break
            except RuntimeError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        print(f"server state: {status['state']}")
        loaded = ask(session, f"{ns}/control/load", {"path": show})["show"]
        print(f"loaded {loaded['name']!r}, triggers: {', '.join(loaded['triggers']) or 'none'}")
        started = ask(session, f"{ns}/control/start")
        print(f"started {started['show']!r}")
        while ask(session, f"{ns}/status")["state"] != "waiting":
            time.sleep(0.1)
        status = ask(session, f"{ns}/status")
        print(f"waiting for {status['waiting_for']['trigger']!r} at {status['show_time']:.2f} s")
        fired = ask(session, f"{ns}/trigger/{trigger}", {"source": "zenoh_control.py"})
        print(f"trigger {trigger!r}: released section {fired['section']!r}")
        time.sleep(1.0)
        status = ask(session, f"{ns}/status")
        robots = ", ".join(f"{n}: {r['state']} ({r['cue'] or '-'})"
                           for n, r in status.get("robots", {}).items())
        print(f"{status['state']} at {status.get('show_time', 0):.2f} s, section "
              f"{status.get('section')}; {robots}")
        print(f"stop: {ask(session, f'{ns}/control/stop')['reason']}")


def _free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--connect", help="the server's Zenoh endpoint")
    parser.add_argument("--namespace", default="xgo-show")
    parser.add_argument("--show", default="choreographies/curtain_call.yaml",
                        help="a routine on the server's host")
    parser.add_argument("--trigger", default="go")
    parser.add_argument("--serve", action="store_true",
                        help="start an 'xgo-show serve --sim' for the demo (a separate process)")
    args = parser.parse_args()
    server = None
    connect = args.connect
    if args.serve:
        connect = connect or _free_endpoint()
        server = subprocess.Popen(
            [sys.executable, "-m", "xgo_show", "serve", "--sim", "--no-telemetry",
             "--listen", connect, "--namespace", args.namespace],
            stdout=subprocess.DEVNULL,
        )
    if connect is None:
        parser.error("give --connect ENDPOINT (or --serve)")
    try:
        main(connect, args.namespace, args.show, args.trigger)
    finally:
        if server is not None:
            server.terminate()
            server.wait(10)
