"""``xgo-show run``/``dry-run`` with performers behind relay processes (``zenoh:RELAY/ROBOT``)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from tests.conftest import starved_ms
from tests.relay.conftest import claim, upload_text
from tests.relay.processes import READY_TIMEOUT
from xgo_show.compiler.artifact import save_schedule
from xgo_show.net.testhooks import CLOCK_ENV, TRACE_ENV


def conduct(show_file: Path, *args: str, relay=None) -> subprocess.Popen[str]:  # type: ignore[no-untyped-def]
    """Start ``xgo-show run SHOW ...`` connected to ``relay`` (no countdown)."""
    cmd = [sys.executable, "-m", "xgo_show", "run", str(show_file), "--countdown", "0", *args]
    if relay is not None:
        cmd += ["--connect", relay.endpoint, "--listen", "tcp/127.0.0.1:0"]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_dry_run_mixes_a_relayed_robot_with_a_local_one_in_one_table(
    relays, walk, tmp_path: Path
) -> None:
    left = relays.start("left", {"dog": "mini"})
    show = walk(0.6, rex="mini", lola="lite")
    save_schedule(show, tmp_path / "walk.xshow.json")
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "xgo_show",
            "dry-run",
            str(tmp_path / "walk.xshow.json"),
            "--map",
            "rex=zenoh:left/dog",
            "--connect",
            left.endpoint,
            "--listen",
            "tcp/127.0.0.1:0",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    table = out.stdout.split("battery floor")[0]
    assert left.servers["dog"].path in table and "via relay left" in table and "lola" in table
    sent = [f.data for f in show.performer("rex").frames]
    assert [d for d in left.received("dog") if d in sent] == sent


def test_a_held_relay_fails_the_preflight_with_the_holders_name(
    relays, conductor_session, walk, tmp_path: Path
) -> None:
    left = relays.start("left", {"rex": "mini"})
    holder = claim(conductor_session(left), left, "alice@desk")
    show = walk(0.3, rex="mini")
    # alice uploads her show with a long watchdog: the relay keeps her the holder even while
    # a loaded machine holds up this process's heartbeats for more than the default 0.5 s.
    assert holder.upload(*upload_text(show), watchdog_ms=30_000)["preflight_ok"]
    save_schedule(show, tmp_path / "s.xshow.json")
    proc = conduct(tmp_path / "s.xshow.json", "--map", "rex=zenoh:left/rex", relay=left)
    stdout, stderr = proc.communicate(timeout=60)
    holder.stop_heartbeat()
    assert proc.returncode == 2
    assert "held by conductor 'alice@desk'" in stdout
    assert "pre-flight failed" in stderr and "Traceback" not in stderr


def test_fast_is_refused_with_relays(walk, tmp_path: Path) -> None:
    save_schedule(walk(0.3, rex="mini"), tmp_path / "s.xshow.json")
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "xgo_show",
            "dry-run",
            str(tmp_path / "s.xshow.json"),
            "--fast",
            "--map",
            "rex=zenoh:left/rex",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2 and "--fast cannot drive relayed performers" in out.stderr


@pytest.mark.parametrize("policy", ["stop", "continue"])
def test_a_conductor_killed_mid_show_leaves_the_robots_safe(
    relays, walk, until, tmp_path: Path, policy: str
) -> None:
    left = relays.start("left", {"rex": "mini"})
    show = walk(2.0, rex="mini")
    save_schedule(show, tmp_path / "s.xshow.json")
    proc = conduct(
        tmp_path / "s.xshow.json",
        "--map",
        "rex=zenoh:left/rex",
        "--link-loss",
        policy,
        "--watchdog-ms",
        "300",
        relay=left,
    )
    first = show.performer("rex").frames[3].data
    until(lambda: first in left.received("rex"), 20)
    os.kill(proc.pid, signal.SIGKILL)
    killed = time.monotonic()
    proc.communicate(timeout=10)
    if policy == "stop":
        stopped = until(lambda: bool(left.stop_times("rex")), 3)
        assert stopped - killed < 0.3 + 0.2  # the watchdog, one check and the stop frames
    else:
        sent = [f.data for f in show.performer("rex").frames]
        until(lambda: [d for d in left.received("rex") if d in sent] == sent, 5)
        assert not left.stop_times("rex")


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGSTOP])
def test_a_lost_relay_stops_the_whole_show_within_the_watchdog(
    relays, walk, until, tmp_path: Path, sig: int
) -> None:
    left = relays.start("left", {"rex": "mini"})
    show = walk(3.0, rex="mini", lola="lite")
    save_schedule(show, tmp_path / "s.xshow.json")
    log = tmp_path / "run.jsonl"
    proc = conduct(
        tmp_path / "s.xshow.json",
        "--map",
        "rex=zenoh:left/rex",
        "--sim",
        "--watchdog-ms",
        "300",
        "--log",
        str(log),
        relay=left,
    )
    until(lambda: show.performer("rex").frames[3].data in left.received("rex"), 20)
    left.kill(sig)
    lost_at = time.monotonic()
    stdout, stderr = proc.communicate(timeout=20)
    assert proc.returncode == 2, stdout + stderr
    assert "relay left lost" in stderr + stdout
    from xgo_show.runtime.runlog import read_log

    records = read_log(log)
    events = [r for r in records if r.get("kind") == "event"]
    # stopped well before the show's end (3 s): lola's last frame a second or more before it
    assert not next(e for e in events if e.get("event") == "end")["completed"]
    lola = [r["actual"] for r in records if r["kind"] == "frame" and r["performer"] == "lola"
            and r["send"] == "frame"]
    assert lola and max(lola) < show.duration - 1.0, (max(lola), show.duration)
    faults = [e for e in events if e.get("event") == "fault" and "relay left lost" in e["reason"]]
    stops = [e for e in events if e.get("event") == "safe_stop" and e.get("performer") == "lola"]
    assert faults and stops and stops[0]["ok"]
    # lola (local) is stopped at once when the relay is found lost: 8-12 ms idle; on a
    # starved machine later, as its frames were late just before
    starved = starved_ms(records)
    assert stops[0]["mono"] - faults[0]["mono"] < 0.2 + starved / 1000, starved
    # found lost within the watchdog (300 ms from the last word heard) and one check
    assert faults[0]["mono"] - lost_at < 0.3 + 0.1 + starved / 1000, starved
    if sig == signal.SIGSTOP:
        left.proc.send_signal(signal.SIGCONT)  # its own watchdog then stops its robot
        until(lambda: bool(left.stop_times("rex")), 3)


def logged(path: Path, event: str, timeout: float = 10.0) -> dict[str, Any]:
    """The first ``event`` record of a relay's run log, once it is there: a relay writes its
    trace when its own show has ended, which can be a moment after the conductor has exited."""
    from xgo_show.runtime.runlog import read_log

    deadline = time.monotonic() + timeout
    while True:
        found = [r for r in read_log(path) if r.get("event") == event] if path.exists() else []
        if found or time.monotonic() > deadline:
            assert found, f"no {event} record in {path} after {timeout} s"
            return found[0]
        time.sleep(0.05)


def test_relays_with_skewed_clocks_start_together(relays, walk, tmp_path: Path) -> None:
    # Each relay's clock is seconds off this machine's and runs at another rate: only the
    # time sync (offset measured, timebase pushed) can put their first frames together.
    traced = {TRACE_ENV: "1"}
    left = relays.start(
        "left",
        {"rex": "mini"},
        "--log",
        str(tmp_path / "left.jsonl"),
        env={CLOCK_ENV: "offset=7.25,ppm=90", **traced},
    )
    right = relays.start(
        "right",
        {"lola": "lite"},
        "--log",
        str(tmp_path / "right.jsonl"),
        env={CLOCK_ENV: "offset=-3.5,ppm=-90", **traced},
    )
    show = walk(0.5, rex="mini", lola="lite")
    save_schedule(show, tmp_path / "s.xshow.json")
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "xgo_show",
            "dry-run",
            str(tmp_path / "s.xshow.json"),
            "--map",
            "rex=zenoh:left/rex",
            "--map",
            "lola=zenoh:right/lola",
            "--connect",
            left.endpoint,
            "--connect",
            right.endpoint,
            "--log",
            str(tmp_path / "run.jsonl"),
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    # Each relay's offset as measured (its clock also runs +-90 ppm from its start, and the
    # estimate has its own error: "+7.249998" is right too, so read numbers, not text).
    offsets = dict(re.findall(r"via relay (\w+), clock offset ([-+][\d.]+) s", out.stdout))
    assert offsets.keys() == {"left", "right"}, out.stdout
    assert float(offsets["left"]) == pytest.approx(7.25, abs=0.005), out.stdout
    assert float(offsets["right"]) == pytest.approx(-3.5, abs=0.005), out.stdout
    assert out.stdout.count(", round trip ") == 2  # each relay's, from its first burst
    found = re.findall(r"clock offset [-+][\d.]+ s \+- ([\d.]+) ms", out.stdout)
    bounds = [float(b) for b in found]
    assert len(bounds) == 2
    # Where each relay's clock put the first frame, on this machine's clock (its trace), is the
    # conductor's start to within the bound the estimate gave (plus its drift since): scheduling
    # on a busy machine cannot move this part, only the clock sync can.
    from xgo_show.runtime.runlog import read_log

    start_at = next(r for r in read_log(tmp_path / "run.jsonl") if r.get("event") == "start")
    for relay in ("left", "right"):
        first = logged(tmp_path / f"{relay}.jsonl", "first_frame")
        assert first["start_at"] == pytest.approx(start_at["start_at"], abs=1e-6)
        assert abs(first["planned_host"] - start_at["start_at"]) < max(bounds) / 1e3 + 0.0005
    firsts = []
    for relay, name in ((left, "rex"), (right, "lola")):
        first = show.performer(name).frames[0].data
        with relay.servers[name].lock:
            firsts.append(next(f.t for f in relay.servers[name].robot.received if f.data == first))
    assert abs(firsts[0] - firsts[1]) < 0.005  # a loaded CI machine; the benchmark measures it


def test_eight_relays_start_together_on_a_lead_from_measured_round_trips(
    relays, walk, tmp_path: Path
) -> None:
    # Start commands go out together (one round trip for all), so the lead is the slowest
    # relay's, not the sum: sent one after another, eight starts on a busy machine miss it.
    names = [f"r{i}" for i in range(8)]
    # Each relay logs its first frame's write on this machine's clock (XGO_SHOW_TEST_TRACE).
    logs = [tmp_path / f"host{i}.jsonl" for i in range(8)]
    started = [
        relays.spawn(f"host{i}", {n: "mini"}, "--log", str(logs[i]), env={TRACE_ENV: "1"})
        for i, n in enumerate(names)
    ]
    for relay in started:  # they share the CPUs while starting: give each its share
        relays.ready(relay, READY_TIMEOUT * 4)
    show = walk(0.4, **dict.fromkeys(names, "mini"))
    save_schedule(show, tmp_path / "s.xshow.json")
    log = tmp_path / "run.jsonl"
    cmd = [sys.executable, "-m", "xgo_show", "dry-run", str(tmp_path / "s.xshow.json")]
    for i, name in enumerate(names):
        cmd += ["--map", f"{name}=zenoh:host{i}"]  # the robot is named like the performer
    for relay in started:
        cmd += ["--connect", relay.endpoint]
    out = subprocess.run([*cmd, "--log", str(log)], capture_output=True, text=True, timeout=90)
    assert out.returncode == 0, out.stdout + out.stderr
    from xgo_show.runtime.runlog import read_log

    begun = next(r for r in read_log(log) if r.get("event") == "start")
    lead = begun["start_at"] - begun["mono"]
    # One relay's worth of round trips (3 x its worst recent one, plus set-up): 0.15-0.35 s on
    # an idle machine, 0.59 s seen with 8 relays on 2 CPUs at load 8; sent one after another,
    # eight starts would need eight relays' worth, which would not fit.
    assert lead < 1.0, f"lead {lead:.3f} s"
    writes = []
    for relay, name, relay_log in zip(started, names, logs, strict=True):
        sent = [f.data for f in show.performer(name).frames]
        assert [d for d in relay.received(name) if d in sent] == sent
        first = logged(relay_log, "first_frame")
        writes.append(first["actual_host"])
    # The relays wrote their first frames together: 8 relay processes with SCHED_FIFO writers
    # on a shared, busy 2-CPU machine. (Not the receive times: the simulators are threads of
    # this test process, which a busy machine stalls for tens of ms, some of them behind the
    # others: seen 20.6 ms for 2 of 8 in a full suite at load 10-17. benchmarks/relay_sync.py
    # measures the receive times with a simulator process per robot.)
    assert max(writes) - min(writes) < 0.020, writes
