"""A conductor in a process of its own, for tests that freeze it or cut its cable.

    python conductor_peer.py ENDPOINT RELAY SCHEDULE_FILE LINK_LOSS

Connects to the relay at ENDPOINT, claims RELAY, beats every 100 ms (watchdog 500 ms), syncs
the relay's clock, uploads the schedule (JSON file) with the link-loss policy, starts it 0.5 s
later and prints one JSON line per event: {"event": "started", "start_at": t, "bound": b}, then
{"event": "relay lost", "t": t, "silence": s} if the relay goes silent. Runs until stdin closes.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from xgo_show.net.keys import relay_key
from xgo_show.net.session import SessionOptions, open_session
from xgo_show.net.timesync import ClockTracker
from xgo_show.relay.client import RelayClient
from xgo_show.relay.validate import schedule_digest


def say(**fields: object) -> None:
    print(json.dumps(fields), flush=True)


def main(argv: list[str]) -> int:
    endpoint, relay, schedule_file, link_loss = argv
    text = Path(schedule_file).read_text(encoding="utf-8")
    session = open_session(SessionOptions(connect=(endpoint,), listen=()))
    try:
        client = RelayClient(session, relay)
        client.request("hello", timeout=10.0)  # resent until the session has a route
        client.start_heartbeat(
            period=0.1,
            watchdog=0.5,
            on_lost=lambda s: say(event="relay lost", t=time.monotonic(), silence=s),
        )
        tracker = ClockTracker(
            session,
            relay_key("xgo-show", relay, "time"),
            conductor=client.conductor.id,
            interval=0.5,
        )
        timebase = tracker.start()
        sha = schedule_digest(text)
        client.upload(text, sha, link_loss=link_loss, watchdog_ms=500)
        start_at = time.monotonic() + 0.5
        client.start(sha, start_at)
        say(event="started", start_at=start_at, bound=timebase.bound)
        sys.stdin.read()
        client.stop_heartbeat()
        tracker.close()
    finally:
        session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
