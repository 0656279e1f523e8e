#!/usr/bin/env bash
# The main job, end to end, on a fresh clone: set up ./.venv, then dry-run the bundled
# three-minute show for five robots (two Minis, a Lite, a Rider, an xArm) on simulated robots,
# each served on its own real pseudo-terminal: YAML -> validate -> compile -> pyserial -> tty ->
# simulator, in real time, with live progress, the timing report and what every robot did.
# Extra arguments go to `xgo-show dry-run` (e.g. --fast to skip the waiting, --plot show.png).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/venv.sh
exec xgo-show dry-run choreographies/mixed_five.yaml "$@"
