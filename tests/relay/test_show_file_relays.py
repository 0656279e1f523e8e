"""A relay named in the show file (``port: zenoh:RELAY/ROBOT``), and ``--map`` overriding it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from xgo_show.cli.run import load_schedule_file
from xgo_show.sim import PtyServer, create_robot

SHOW = """\
show: Relayed
performers:
  rex: {model: mini, port: "zenoh:left/rex"}
  lola: {model: lite, port: "zenoh:backstage/lola"}
tracks:
  rex:
    - move: {body_z: 105}
      duration: 0.8
  lola:
    - move: {body_z: 105}
      duration: 0.8
"""


def test_the_show_files_relay_plays_and_map_overrides_another(relays, tmp_path: Path) -> None:
    # Only the show file names relays: --map gives lola a local port instead of backstage.
    left = relays.start("left", {"rex": "mini"})
    lola = PtyServer(create_robot("lite")).start()
    path = tmp_path / "relayed.yaml"
    path.write_text(SHOW, encoding="utf-8")
    try:
        out = subprocess.run(
            [
                sys.executable,
                "-m",
                "xgo_show",
                "run",
                str(path),
                "--countdown",
                "0",
                "--map",
                f"lola={lola.path}",
                "--in-process",  # no relay child: only the show file names a relay
                "--connect",
                left.endpoint,
            ],
            capture_output=True,
            text=True,
            timeout=90,
        )
        assert out.returncode == 0, out.stdout + out.stderr
        table = out.stdout.split("battery floor")[0]
        assert "via relay left" in table and lola.path in table
        assert "backstage" not in out.stdout + out.stderr
        show = load_schedule_file(path)
        got = {"rex": left.received("rex")}
        with lola.lock:
            got["lola"] = [f.data for f in lola.robot.received]
        for name, received in got.items():
            sent = [f.data for f in show.performer(name).frames]
            assert [d for d in received if d in sent] == sent, name
    finally:
        lola.close()


def test_dry_run_simulates_the_show_files_relayed_performers(tmp_path: Path) -> None:
    # dry-run plays every performer not given with --map on a local simulator, relayed or not:
    # nothing reaches for the relays (none runs here).
    path = tmp_path / "relayed.yaml"
    path.write_text(SHOW, encoding="utf-8")
    out = subprocess.run(
        [sys.executable, "-m", "xgo_show", "dry-run", str(path)],
        capture_output=True,
        text=True,
        timeout=90,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    assert "via relay" not in out.stdout
