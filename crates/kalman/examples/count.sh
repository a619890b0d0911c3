#!/usr/bin/env bash
# Instructions per step of the benchmarked filters: callgrind totals for
# N and 2N steps of examples/steps.rs, differenced.
# Usage: count.sh [N [filter...]]  (filters: joseph standard srkf imm imm_into ukf ukf_one_set srukf ...)
set -euo pipefail
n=${1:-1000}
shift || true
filters=${*:-joseph standard srkf imm imm_into ukf ukf_one_set srukf ukf_runtime ukf_runtime_checked}
cd "$(dirname "$0")/../../.."
cargo build --release -q -p bayestrack-kalman --example steps
bin=${CARGO_TARGET_DIR:-target}/release/examples/steps
total() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bin" "$1" "$2" 2>&1 |
        sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
for f in $filters; do
    a=$(total "$f" "$n")
    b=$(total "$f" $((2 * n)))
    echo "$f $(((b - a) / n))"
done
