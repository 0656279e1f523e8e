#!/usr/bin/env bash
# Mutation testing of chosen modules (mutmut), each against only its own test folders, two
# modules at a time, at the lowest CPU priority. Never run in CI: a module takes minutes.
#   scripts/mutation.sh [-j JOBS] [xgo_show/PACKAGE/MODULE.py ...]
# Without modules: those listed under [tool.xgo-show.mutation] in pyproject.toml.
# How to read the survivors: docs/contributing.md.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/venv.sh
if ! python -c 'import mutmut' 2>/dev/null; then
    echo "installing mutmut into .venv (pip install -e '.[mutation]')" >&2
    python -m pip install --quiet --disable-pip-version-check -e '.[mutation]'
fi
exec nice -n 19 python scripts/mutation.py "$@"
