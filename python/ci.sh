#!/usr/bin/env bash
# CI step for the Python bindings: build the `bayestrack` wheel (dev profile,
# the workspace's target/), install it into a virtual environment under
# target/python-ci/ and run pytest on python/tests.
# Skips (exit 0, with a message) when python3, venv, numpy, pytest or
# maturin are not installed; fails when the build or a test fails.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/.." && pwd)"
PY="${PYTHON:-python3}"
skip() { echo "python/ci.sh: SKIPPED: $*"; exit 0; }

command -v "$PY" >/dev/null 2>&1 || skip "no $PY on this machine"
"$PY" -c 'import sys; sys.exit(sys.version_info < (3, 9))' || skip "$PY is older than 3.9"
venv="$root/target/python-ci/venv"
if [ ! -x "$venv/bin/python" ]; then
    # system site packages: numpy, pytest, filterpy and maturin if installed
    "$PY" -m venv --system-site-packages "$venv" >/dev/null 2>&1 || skip "$PY -m venv failed (python3-venv missing?)"
fi
vpy="$venv/bin/python"
# Nothing is downloaded: CI's time and result must not depend on the
# network (pip install numpy pytest maturin filterpy to run this step).
for mod in numpy pytest; do
    "$vpy" -c "import $mod" 2>/dev/null || skip "$mod is not installed (pip install numpy pytest maturin)"
done
if ! "$vpy" -m maturin --version >/dev/null 2>&1 && ! command -v maturin >/dev/null 2>&1; then
    skip "maturin is not installed (pip install maturin)"
fi
maturin_cmd=("$vpy" -m maturin)
"$vpy" -m maturin --version >/dev/null 2>&1 || maturin_cmd=(maturin)

start=$SECONDS
wheels="$root/target/python-ci/wheels"
rm -rf "$wheels"
(cd "$here" && "${maturin_cmd[@]}" build --profile dev --interpreter "$vpy" -o "$wheels" --quiet)
"$vpy" -m pip install -q --no-deps --force-reinstall "$wheels"/bayestrack-*.whl
echo "python/ci.sh: wheel built and installed in $((SECONDS - start)) s"
"$vpy" -c 'import filterpy' 2>/dev/null || echo "python/ci.sh: filterpy not installed: the filterpy agreement tests are skipped"
# --- trackers (pytrack) ---
# the CLI `cargo test --workspace` built: test_tracker.py compares its box
# files with the Python trackers' boxes (skipped, saying so, without it)
target_dir="${CARGO_TARGET_DIR:-$root/target}"
if [ -z "${BAYESTRACK_CLI:-}" ] && [ -x "$target_dir/debug/bayestrack" ]; then
    export BAYESTRACK_CLI="$target_dir/debug/bayestrack"
fi
# from tests/: python/bayestrack (sources without the compiled module) must
# not shadow the installed package
cd "$here/tests"
"$vpy" -m pytest -q -p no:cacheprovider .
echo "python/ci.sh: done in $((SECONDS - start)) s"
