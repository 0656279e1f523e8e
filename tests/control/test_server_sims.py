"""``serve``'s server (control/server.py) in this process over the recording session, with a
show on simulated robots (real ptys, real time, ``--sim``): the run log's times of a trigger's
release come from the writers' real frames. The server's decisions, on stand-in robots, are
test_server_stage.py's (what ``scripts/mutation.sh`` runs: these cost the show's real time)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from tests.conftest import wait_until
from tests.control.serving import Serve
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule


def records(path: Path, kind: str) -> list[dict[str, Any]]:
    lines = path.read_text(encoding="utf-8").splitlines()
    return [r for r in map(json.loads, lines) if r["kind"] == kind]


def test_a_put_releases_a_held_wait_and_the_log_keeps_its_times(
    tmp_path: Path, triggered_schedule: Schedule
) -> None:
    log = tmp_path / "run.jsonl"
    s = Serve(log=log)
    try:
        s.ask("load", schedule=schedule_to_bytes(triggered_schedule).decode())
        s.ask("start")
        wait_until(lambda: s.server.status()["state"] == "waiting", timeout=10)
        s.session.publish("ns/trigger/go", b'{"source": "desk", "data": 7}')
        wait_until(lambda: any(e.get("accepted") for e in s.events("trigger")))
        event = next(e for e in s.events("trigger") if e.get("accepted"))
        assert (event["trigger"], event["section"], event["held"], event["source"],
                event["data"]) == ("go", "b", True, "desk", 7)
        assert s.server.counters["accepted"] == 1
        wait_until(lambda: s.server._trace is None, timeout=10)  # the section's first frame
        s.ask("stop")
    finally:
        s.close()
    (trace,) = records(log, "trigger")
    assert (trace["trigger"], trace["section"]) == ("go", "b")
    times = [trace[k] for k in ("received", "parsed", "decided", "woke", "released",
                                "first_frame")]
    assert all(isinstance(t, float) for t in times), trace
    assert times == sorted(times) and times[-1] - times[0] < 5.0
    assert trace["received"] <= trace["first_write"] <= trace["first_frame"]
