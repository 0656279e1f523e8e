#!/usr/bin/env bash
# The main job, end to end, on a fresh clone: set up ./.venv, start a simulated XGO-Mini on a
# real pseudo-terminal, drive it through a short routine over that port, and print every frame
# it received, decoded. Extra arguments go to the example (--model lite|rider, --hex).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/venv.sh
exec python examples/drive_sim.py "$@"
