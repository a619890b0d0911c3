#!/bin/bash
# Whole-run fps of `bayestrack track` (decoding, tracking, writing; the
# summary's "fps whole run") on Crossing and Couple, for each tracker and
# each decoding setting, RUNS rounds with the settings interleaved so that
# load changes hit them alike; also checks that every setting writes the
# same boxes. Prints one line per tracker, sequence and setting: the fps of
# each round, then the load average.
# usage: tools/whole_run_fps.sh [trackers...]   (after `cargo build --release --bin bayestrack`;
#   RUNS=n rounds (default 3); SETTINGS="0,1 4,1 4,2" as --decode-ahead,--decode-threads pairs;
#   SEQS="Crossing Couple"; PIN="taskset -c 0" runs on one core)
cd "$(dirname "$0")/.."
bin=target/release/bayestrack
root=${ROOT:-/work/shared/data/sequences}
trackers=${@:-mad ball-kf condensation-points ncc-scale dcf}
settings=${SETTINGS:-0,1 4,1 4,2}
tmp=$(mktemp -d)
for t in $trackers; do
  for s in ${SEQS:-Crossing Couple}; do
    declare -A fps=()
    for r in $(seq ${RUNS:-3}); do
      for set in $settings; do
        ahead=${set%,*}; threads=${set#*,}
        err=$($PIN $bin track --seq "$root/$s" --tracker "$t" --decode-ahead "$ahead" \
          --decode-threads "$threads" --out "$tmp/$set.txt" 2>&1 >/dev/null) || { echo "$t $s $set failed: $err"; exit 1; }
        f=$(echo "$err" | sed -nE 's/.* ([0-9]+) fps whole run.*/\1/p')
        fps[$set]="${fps[$set]} $f"
        first=${settings%% *}
        cmp -s "$tmp/$first.txt" "$tmp/$set.txt" || { echo "$t $s: boxes differ between $first and $set"; exit 1; }
      done
    done
    for set in $settings; do
      echo "$t $s ahead,threads=$set fps:${fps[$set]} load $(cut -d' ' -f1-3 /proc/loadavg)"
    done
    unset fps
  done
done
rm -rf "$tmp"
