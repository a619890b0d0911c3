#!/bin/bash
# Whole-process fps of two `bayestrack` binaries, alternated run by run: the
# wall clock around each process (start, decoding, tracking, writing), on
# Crossing and Couple. OLD runs with its defaults; main's binary runs with
# its defaults and with --decode-threads 1. Prints each setting's fps per
# round and whether OLD and main wrote the same boxes.
# usage: OLD=/path/to/old/bayestrack tools/whole_run_compare.sh [trackers...]
#   (e.g. git worktree add /tmp/old 421ef6d && (cd /tmp/old && cargo build --release --bin bayestrack);
#    OLD=/tmp/old/target/release/bayestrack; RUNS=n rounds, default 5)
cd "$(dirname "$0")/.."
root=${ROOT:-../shared/data/sequences}
old=${OLD:?set OLD to the other bayestrack binary}
new=target/release/bayestrack
tmp=$(mktemp -d)
wall() { local t0=$(date +%s%N); "$@" >/dev/null 2>&1 || echo "failed: $*" >&2; local t1=$(date +%s%N); echo $(( n * 1000000000 / (t1 - t0) )); }
for t in ${@:-mad pf-correlation ball-pf ball-kf condensation-points ncc-scale}; do
  for s in Crossing Couple; do
    n=$(ls "$root/$s/img" | wc -l)
    a=""; b=""; c=""
    for r in $(seq ${RUNS:-5}); do
      a="$a $(wall $old track --seq "$root/$s" --tracker $t --out $tmp/o.txt)"
      b="$b $(wall $new track --seq "$root/$s" --tracker $t --out $tmp/n.txt)"
      c="$c $(wall $new track --seq "$root/$s" --tracker $t --decode-threads 1 --out $tmp/n2.txt)"
    done
    cmp -s $tmp/o.txt $tmp/n.txt && same=same || same=differ
    echo "$t $s ($n frames) | old:$a | main:$b | main --decode-threads 1:$c | boxes $same | load $(cut -d' ' -f1 /proc/loadavg)"
  done
done
rm -rf "$tmp"
