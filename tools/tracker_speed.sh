#!/bin/bash
# Tracker-only fps (best of REPEATS native runs), box digest, and callgrind
# instructions per frame (tracker calls only) for each tracker on Crossing and Couple.
# usage: tools/tracker_speed.sh OUTFILE [trackers...]  (after `cargo build --release -p bayestrack-trackers --example profile_tracker`; NOCG=1 skips callgrind, REPEATS=n runs, BAYESTRACK_SIMD=avx2 caps the native runs at the AVX2 paths)
cd "$(dirname "$0")/.."
out=$1; shift
bin=target/release/examples/profile_tracker
trackers=${@:-mad pf-correlation ball-kf ball-ukf ball-pf ball-pf10 ball-pf30 ball-pf70 ncc-scale dcf dcf-staple pf-dcf hist-pf-scale hkpf ispf stpf condensation-points condensation-contour}
: > "$out"
for t in $trackers; do
  for s in Crossing Couple; do
    line=$($bin $s $t ${REPEATS:-3})
    frames=$(echo "$line" | sed -E 's/.*: ([0-9]+) frames.*/\1/')
    if [ -z "$NOCG" ]; then
      f=/tmp/tracker_speed_cg.$t.$s
      valgrind --tool=callgrind --callgrind-out-file=$f --toggle-collect='*run_tracker*' $bin $s $t 1 >/dev/null 2>&1
      ins=$(grep '^totals:' $f | awk '{print $2}'); rm -f $f
      ipf=$((ins / (frames - 1)))
    else ipf=-; fi
    echo "$t $s $line ipf=$ipf" | tee -a "$out"
  done
done
