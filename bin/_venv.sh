# Sourced by bin/homecog, bin/test and bin/bench: make .venv and install homecog into it
# when it is missing or pyproject.toml changed since the last install.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$root/.venv"

ensure_venv() {
    local extras="$1" python stamp want
    python=""
    for candidate in ${PYTHON:-} python3 python3.13 python3.12 python3.11; do
        if "$candidate" -c 'import sys; sys.exit(sys.version_info < (3, 11))' >/dev/null 2>&1; then
            python="$candidate"
            break
        fi
    done
    if [ -z "$python" ]; then
        echo "homecog needs Python 3.11 or newer (set PYTHON to its path)" >&2
        exit 1
    fi
    if [ ! -x "$venv/bin/python" ]; then
        echo "setting up $venv ..." >&2
        "$python" -m venv "$venv"
    fi
    # The stamp has a line "<hash of pyproject.toml> [extras]" per install; the plain install
    # is satisfied by any line of the current hash.
    stamp="$venv/.homecog-installed"
    hash="$(sha256sum "$root/pyproject.toml" | cut -d' ' -f1)"
    if [ -f "$stamp" ] && { grep -qxF "$hash [$extras]" "$stamp" || { [ -z "$extras" ] && grep -q "^$hash " "$stamp"; }; }; then
        return 0
    fi
    [ -f "$stamp" ] && grep -q "^$hash " "$stamp" || : > "$stamp"
    echo "installing homecog${extras:+ with [$extras]} into $venv ..." >&2
    # uv installs the same pinned packages twice as fast as pip (25 s against 53 s from an empty
    # cache here, bytecode compiled, so that later starts need not compile even where
    # PYTHONDONTWRITEBYTECODE is set); where uv cannot be had or fails, pip does it.
    if "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "uv==0.13.9" >/dev/null 2>&1 &&
        "$venv/bin/uv" pip install --quiet --compile-bytecode --python "$venv/bin/python" -e "$root${extras:+[$extras]}" >&2; then
        :
    else
        echo "(uv could not install it; pip does)" >&2
        "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade pip >&2
        "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -e "$root${extras:+[$extras]}" >&2
    fi
    echo "$hash [$extras]" >> "$stamp"
}
