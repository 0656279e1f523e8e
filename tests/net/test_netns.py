"""Two "hosts" (network namespaces joined by a veth pair): time sync across real TCP stacks,
and a pulled cable, which TCP does not notice: only the missing answers show it."""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from tests.net.netns import Cable, Host

PEER = str(Path(__file__).with_name("timepeer.py"))
KEY = "xgo-show-test/relay/a/time"


class Lines:
    """A process's stdout lines, read on a thread so a test can wait with a timeout."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        self.proc = proc
        self.lines: queue.Queue[str] = queue.Queue()
        assert proc.stdout is not None
        stdout = proc.stdout
        threading.Thread(target=lambda: [self.lines.put(x) for x in stdout], daemon=True).start()

    def next(self, timeout: float = 10.0) -> str:
        try:
            return self.lines.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"no line from {self.proc.args} in {timeout} s") from None

    def until(self, predicate: Any, timeout: float = 10.0) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while True:
            line = json.loads(self.next(max(0.01, deadline - time.monotonic())))
            if predicate(line):
                return line


def _stop(*procs: subprocess.Popen[str]) -> None:
    for proc in procs:
        if proc.poll() is None:
            proc.kill()
        proc.wait(5)
        for pipe in (proc.stdin, proc.stdout, proc.stderr):
            if pipe is not None:
                pipe.close()


def test_time_sync_between_two_hosts_and_a_pulled_cable(
    two_hosts: tuple[Host, Host, Cable],
) -> None:
    a, b, cable = two_hosts
    endpoint = f"tcp/{a.address}:7447"
    env = {**os.environ, "XGO_SHOW_TEST_CLOCK": "offset=7.25"}
    relay = a.popen([sys.executable, PEER, "serve", endpoint, KEY], stdin=subprocess.PIPE, env=env)
    conductor = b.popen([sys.executable, PEER, "track", endpoint, KEY, "8"])
    try:
        assert relay.stdout is not None and relay.stdout.readline().strip() == "ready"
        lines = Lines(conductor)
        first = lines.until(lambda x: "offset" in x)
        assert abs(first["offset"] - 7.25) <= first["bound"]
        assert first["bound"] < 0.005

        cable.unplug()
        pulled = time.monotonic()
        lost = lines.until(lambda x: "error" in x)
        assert "no answer to 8 time-sync pings" in lost["error"]
        assert lost["t"] - pulled < 2.0

        cable.plug()
        again = lines.until(lambda x: "offset" in x, timeout=20.0)
        assert abs(again["offset"] - 7.25) <= again["bound"]
    finally:
        _stop(conductor, relay)
