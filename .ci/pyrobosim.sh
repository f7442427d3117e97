#!/usr/bin/env bash
# pyrobosim 5.0.1 for tests/test_pyrobosim.py: the [pyrobosim] extra installed into the test venv
# (.venv) beside homecog's own test install, which .ci/run makes first. It is never part of
# homecog's main install. Nothing here fails CI: where it cannot be had, its tests skip and say why.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
say() { echo "pyrobosim: $*"; }

if [ "${HOMECOG_CI_PYROBOSIM:-1}" = 0 ]; then
    say "HOMECOG_CI_PYROBOSIM=0: not installing; its tests will skip"
    exit 0
fi
start=$(date +%s)
if bash -c 'source bin/_venv.sh && ensure_venv test,pyrobosim'; then
    say "the [pyrobosim] extra is in .venv ($(($(date +%s) - start)) s)"
else
    say "could not install the [pyrobosim] extra; its tests will skip"
fi
exit 0
