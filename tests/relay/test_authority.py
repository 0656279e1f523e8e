"""The relay is the authority for its robots, whoever conducts: unsafe writes, one holder at a
time, and no show restarted by a relay that comes back."""

from __future__ import annotations

import dataclasses
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from xgo_show.compiler.artifact import save_schedule
from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.wire.xgo import write_frame


def dry_run(show_file: Path, *args: str) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "xgo_show", "dry-run", str(show_file), *args]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_a_conductor_allowing_unsafe_writes_cannot_make_the_relay_send_them(
    relays, walk, tmp_path: Path
) -> None:
    strict = relays.start("strict", {"rex": "mini"})
    show = walk(0.3, rex="mini")
    rex = show.performers[0]
    zero = ScheduledFrame(0.225, write_frame(0x21, b"\x01"))  # servo_zero: unsafe
    save_schedule(
        dataclasses.replace(
            show, performers=(dataclasses.replace(rex, frames=(*rex.frames, zero)),)
        ),
        tmp_path / "s.xshow.json",
    )
    proc = dry_run(
        tmp_path / "s.xshow.json",
        "--allow-unsafe",  # the conductor allows it; the relay was not started with it
        "--map",
        "rex=zenoh:strict/rex",
        "--connect",
        strict.endpoint,
    )
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 2, stdout + stderr
    assert "servo_zero" in stdout and "without --allow-unsafe" in stdout
    assert "pre-flight failed" in stderr and "Traceback" not in stderr
    sent = {f.data for f in rex.frames} | {zero.data}
    assert not sent & set(strict.received("rex"))  # nothing of the show moved the robot


def test_a_relay_that_comes_back_is_not_restarted_mid_show(
    relays, walk, until, conductor_session, tmp_path: Path
) -> None:
    from xgo_show.relay.client import list_relays

    left, right = relays.start_many({"left": {"rex": "mini"}, "right": {"lola": "lite"}})
    watch = conductor_session(left)  # only looks: lists the relays
    first = {r["relay"]: r for r in list_relays(watch, timeout=2.0)}["left"]["instance"]
    show = dataclasses.replace(walk(4.0, rex="mini", lola="lite"), on_failure="continue")
    save_schedule(show, tmp_path / "s.xshow.json")
    proc = dry_run(
        tmp_path / "s.xshow.json",
        "--map",
        "rex=zenoh:left/rex",
        "--map",
        "lola=zenoh:right/lola",
        "--connect",
        left.endpoint,
        "--connect",
        right.endpoint,
        "--watchdog-ms",
        "300",
    )
    rex = [f.data for f in show.performer("rex").frames]
    until(lambda: rex[3] in left.received("rex"), 20)
    left.kill(signal.SIGKILL)
    back = relays.restart(left)  # same name, port and robot, while the show goes on
    restarted = time.monotonic()
    with left.servers["rex"].lock:
        before = len(left.servers["rex"].robot.received)
    stdout, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 2 and "relay left lost" in stdout + stderr  # and the show went on
    lola = [f.data for f in show.performer("lola").frames]
    with right.servers["lola"].lock:  # the show went on at right after left came back
        assert [
            f for f in right.servers["lola"].robot.received if f.t > restarted and f.data in lola
        ]
    with left.servers["rex"].lock:
        after = [f for f in left.servers["rex"].robot.received[before:] if f.t > restarted]
    assert not [f for f in after if f.data in rex], "the relay that came back played the show"
    assert back.proc.poll() is None

    seen: list[dict[str, Any]] = []

    def listed() -> bool:
        seen.append({r["relay"]: r for r in list_relays(watch, timeout=1.0)}.get("left", {}))
        return "instance" in seen[-1]

    until(listed, 10)  # the watching session reconnects to the new process first
    described = seen[-1]
    assert described["instance"] != first  # a new instance, which knows no show ...
    assert described["holder"] is None and described["state"] == "idle"  # ... and holds none
