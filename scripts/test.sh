#!/usr/bin/env bash
# Run the test suite in ./.venv (created and installed on first use). Extra arguments go to
# pytest, e.g. scripts/test.sh tests/transports -x
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/venv.sh
# Compiled bytecode, even where PYTHONDONTWRITEBYTECODE is set (this machine sets it): the suite
# starts dozens of Python processes (relays, serve, the CLI), each compiling xgo_show from
# source again (+0.3 s each), and pytest would rewrite every test module's asserts again (+8 s).
# Kept under .venv, so no __pycache__ appears beside the sources.
unset PYTHONDONTWRITEBYTECODE
export PYTHONPYCACHEPREFIX="$PWD/.venv/pycache"
exec python -m pytest "$@"
