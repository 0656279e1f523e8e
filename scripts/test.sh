#!/usr/bin/env bash
# Run the test suite in ./.venv (created and installed on first use). Extra arguments go to
# pytest, e.g. scripts/test.sh tests/transports -x
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/venv.sh
exec python -m pytest "$@"
