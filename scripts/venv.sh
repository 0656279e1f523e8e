# Source this file (bash): make sure ./.venv exists with xgo-show installed editable with its
# test extras, then activate it. Reinstalls only when pyproject.toml changed since last time.
#   source scripts/venv.sh

_xgo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
_xgo_stamp="$_xgo_root/.venv/.xgo-show-installed"
if [ ! -x "$_xgo_root/.venv/bin/python" ]; then
    echo "creating $_xgo_root/.venv" >&2
    python3 -m venv "$_xgo_root/.venv"
fi
if [ ! -f "$_xgo_stamp" ] || [ "$_xgo_root/pyproject.toml" -nt "$_xgo_stamp" ]; then
    echo "installing xgo-show and its test tools into .venv (pip install -e '.[test]')" >&2
    "$_xgo_root/.venv/bin/python" -m pip install --quiet --disable-pip-version-check \
        -e "$_xgo_root[test]"
    touch "$_xgo_stamp"
fi
# shellcheck disable=SC1091
source "$_xgo_root/.venv/bin/activate"
unset _xgo_root _xgo_stamp
