#!/usr/bin/env bash
# Home Assistant 2024.3.3 for tests/test_home_assistant.py and benchmarks/bench_ha.py, in a venv of
# its own (.ha-venv/, or $HOMECOG_TEST_HA_VENV): never a dependency of homecog itself.
# 2024.3.3 is the last release that runs on Python 3.11; it runs on 3.12 too. It is installed
# with uv under the constraints it ships (homeassistant/package_constraints.txt in its wheel),
# plus josepy<2 (with josepy 2 every HTTP request of 2024.3 answers 500), plus what the
# integrations of the tests' configuration install at run time otherwise (the tests start it
# with --skip-pip: it must not reach for PyPI while it runs). Nothing here fails CI: where it
# cannot be had, the Home Assistant tests skip and say why.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

VERSION=2024.3.3
VENV="${HOMECOG_TEST_HA_VENV:-$PWD/.ha-venv}"
STAMP="$VENV/.homecog-ha"
# the requirements of the integrations the tests load (their manifest.json), at 2024.3.3's pins
EXTRAS=(
    "josepy<2"
    home-assistant-frontend==20240307.0  # frontend: recovery mode starts without it
    Pillow==10.2.0                       # image_upload, for person, for onboarding
    janus==1.0.0                         # file_upload, for frontend
    securetar==2024.2.1                  # backup
    SQLAlchemy==2.0.27 fnv-hash-fast==0.5.0 psutil-home-assistant==0.0.1  # recorder
    paho-mqtt==1.6.1                     # mqtt: homecog's MQTT discovery (tests/test_ha_discovery.py)
)
say() { echo "home assistant: $*"; }

if [ "${HOMECOG_CI_HOME_ASSISTANT:-1}" = 0 ]; then
    say "HOMECOG_CI_HOME_ASSISTANT=0: not installing; its tests will skip"
    exit 0
fi
# the stamp: the version, then the extras it was installed with; a venv of the same version
# whose extras differ gets the extras alone
WANT="$VERSION ${EXTRAS[*]}"
if [ -x "$VENV/bin/hass" ] && [ "$(cat "$STAMP" 2>/dev/null)" = "$WANT" ]; then
    say "$VERSION found in $VENV"
    exit 0
fi
if [ -x "$VENV/bin/hass" ] && [ "$(head -c ${#VERSION} "$STAMP" 2>/dev/null)" = "$VERSION" ]; then
    uv="$(command -v uv || true)"
    [ -n "$uv" ] || { [ -x .venv/bin/uv ] && uv="$PWD/.venv/bin/uv"; }
    constraints="$(ls "$VENV"/lib/python3*/site-packages/homeassistant/package_constraints.txt 2>/dev/null | head -n 1)"
    if [ -n "$uv" ] && [ -n "$constraints" ] &&
        "$uv" pip install --quiet --python "$VENV/bin/python" --constraint "$constraints" "${EXTRAS[@]}" >/dev/null 2>&1; then
        echo "$WANT" >"$STAMP"
        say "$VERSION found in $VENV; its extras brought up to date"
        exit 0
    fi
fi

python=""
for candidate in python3.11 python3.12 python3; do
    if command -v "$candidate" >/dev/null 2>&1 &&
        "$candidate" -c 'import sys; sys.exit(not ((3, 11) <= sys.version_info[:2] <= (3, 12)))' 2>/dev/null; then
        python="$(command -v "$candidate")"
        break
    fi
done
if [ -z "$python" ] && command -v apt-get >/dev/null 2>&1; then
    say "no Python 3.11 or 3.12; trying apt-get install python3.11-venv"
    run() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo -n "$@"; fi; }
    { run apt-get update -qq && run apt-get install -y -qq python3.11-venv; } >/dev/null 2>&1 &&
        command -v python3.11 >/dev/null 2>&1 && python="$(command -v python3.11)"
fi
if [ -z "$python" ]; then
    say "Home Assistant $VERSION needs Python 3.11 or 3.12, and there is none; its tests will skip"
    exit 0
fi

start=$(date +%s)
say "installing $VERSION with $python into $VENV ..."
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
# uv: on the PATH, from homecog's .venv (.ci/run makes it first), or bootstrapped with pip
uv="$(command -v uv || true)"
[ -n "$uv" ] || { [ -x .venv/bin/uv ] && uv="$PWD/.venv/bin/uv"; }
if [ -z "$uv" ]; then
    if "$python" -m venv "$tmp/uv" >"$tmp/log" 2>&1 &&
        "$tmp/uv/bin/python" -m pip install --quiet --disable-pip-version-check "uv==0.13.9" >>"$tmp/log" 2>&1; then
        uv="$tmp/uv/bin/uv"
    else
        say "could not get uv: $(tail -n 3 "$tmp/log"); its tests will skip"
        exit 0
    fi
fi
rm -rf "$VENV"
fail() { say "$1: $(tail -n 5 "$tmp/log"); its tests will skip"; rm -rf "$VENV"; exit 0; }
"$uv" venv --quiet --python "$python" "$VENV" >"$tmp/log" 2>&1 || fail "could not make $VENV"
# the constraints come inside the wheel: install it alone first (uv keeps the wheel), read them
"$uv" pip install --quiet --python "$VENV/bin/python" --no-deps "homeassistant==$VERSION" >"$tmp/log" 2>&1 ||
    fail "could not fetch homeassistant==$VERSION"
constraints="$(ls "$VENV"/lib/python3*/site-packages/homeassistant/package_constraints.txt 2>/dev/null | head -n 1)"
[ -n "$constraints" ] || fail "no package_constraints.txt in homeassistant==$VERSION"
"$uv" pip install --quiet --python "$VENV/bin/python" --constraint "$constraints" \
    "homeassistant==$VERSION" "${EXTRAS[@]}" >"$tmp/log" 2>&1 || fail "could not install it"
echo "$WANT" >"$STAMP"
say "installed $VERSION in $(($(date +%s) - start)) s"
