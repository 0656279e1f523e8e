"""``xgo-show relays`` and ``xgo-show probe zenoh:RELAY/ROBOT`` against relay processes."""

from __future__ import annotations

import json
import subprocess
import sys


def xgo(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "xgo_show", *args], capture_output=True, text=True, timeout=60
    )


def test_relays_lists_every_robot_with_model_firmware_battery_and_state(relays) -> None:
    left = relays.start("left", {"rex": "mini"})
    right = relays.start("right", {"arm": "xarm", "wheels": "rider"}, "--model", "arm=xarm")
    out = xgo("relays", "--connect", left.endpoint, "--connect", right.endpoint, "--wait", "1")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0].split() == [
        "relay",
        "state",
        "holder",
        "robot",
        "model",
        "firmware",
        "battery",
        "robot",
        "state",
    ]
    rows = {line.split()[3]: line.split() for line in lines[1:]}
    assert rows["rex"][:7] == ["left", "idle", "-", "rex", "mini", "M-1.4.1", "100%"]
    assert rows["wheels"][:5] == ["right", "idle", "-", "wheels", "rider"]
    assert rows["arm"][4:7] == ["xarm", "xArm", "controller"]
    as_json = xgo("relays", "--connect", left.endpoint, "--json", "--wait", "0.5")
    # right is found through left: the first listing introduced them to each other (gossip)
    assert "left" in [r["relay"] for r in json.loads(as_json.stdout)]


def test_relays_says_when_there_is_none(unused_port) -> None:
    out = xgo("relays", "--listen", f"tcp/127.0.0.1:{unused_port}", "--wait", "0.2")
    assert out.returncode == 0 and "no relay found in namespace xgo-show" in out.stdout


def test_probe_reads_a_robot_through_its_relay(relays) -> None:
    left = relays.start("left", {"rex": "rider"})
    out = xgo("probe", "zenoh:left/rex", "--connect", left.endpoint)
    assert out.returncode == 0, out.stderr
    rows = dict(line.split(None, 1) for line in out.stdout.splitlines())
    assert rows["relay"] == "left" and rows["firmware"].startswith("R-")
    missing = xgo("probe", "zenoh:left/nobody", "--connect", left.endpoint)
    assert missing.returncode == 2 and "no robot 'nobody' on relay left" in missing.stderr
    bad = xgo("probe", "zenoh:left", "--connect", left.endpoint)
    assert bad.returncode == 2 and "name the robot too" in bad.stderr
