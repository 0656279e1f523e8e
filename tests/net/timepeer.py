"""A time-sync peer for tests that need it in another process or network namespace.

python timepeer.py serve ENDPOINT KEY       listen on ENDPOINT, serve the clock of
                                            XGO_SHOW_TEST_CLOCK on KEY, print "ready",
                                            run until stdin closes
python timepeer.py track ENDPOINT KEY N     connect to ENDPOINT and measure N pings every
                                            0.1 s, printing each estimate as a JSON line
                                            ({"error": ...} when none is answered)
"""

from __future__ import annotations

import json
import sys
import time

import zenoh

from xgo_show.net.testhooks import clock_from_env, delay_from_env
from xgo_show.net.timesync import TimeSyncError, measure, serve_time


def config(**endpoints: list[str]) -> zenoh.Config:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    for what, value in endpoints.items():
        conf.insert_json5(f"{what}/endpoints", json.dumps(value))
    return conf


def main(argv: list[str]) -> int:
    role, endpoint, key = argv[:3]
    if role == "serve":
        with zenoh.open(config(listen=[endpoint])) as session:
            server = serve_time(session, key, clock_from_env(), delay=delay_from_env())
            print("ready", flush=True)
            sys.stdin.read()
            server.close()
        return 0
    n = int(argv[3])
    with zenoh.open(config(connect=[endpoint])) as session:
        while True:
            try:
                est = measure(session, key, n=n, timeout=0.2)
                line = {"offset": est.offset, "bound": est.bound, "rtt": est.rtt}
            except TimeSyncError as exc:
                line = {"error": str(exc)}
            print(json.dumps({"t": time.monotonic(), **line}), flush=True)
            time.sleep(0.1)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
