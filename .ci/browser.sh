#!/usr/bin/env bash
# Debian's chromium for tests/test_browser.py (Playwright drives it; `playwright install` cannot
# download browsers here). Installed with apt-get where missing; without it the test skips,
# saying why. Nothing here fails CI.
set -uo pipefail
export DEBIAN_FRONTEND=noninteractive
if command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1; then
    echo "browser: chromium found"
    exit 0
fi
run() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo -n "$@"; fi; }
if command -v apt-get >/dev/null 2>&1; then
    echo "browser: installing chromium with apt-get ..."
    run apt-get install -y -q chromium >/dev/null 2>&1 \
        || { run apt-get update -q >/dev/null 2>&1 && run apt-get install -y -q chromium >/dev/null 2>&1; } \
        || echo "browser: could not install chromium; the browser test will skip"
else
    echo "browser: no apt-get; the browser test will skip"
fi
