#!/usr/bin/env bash
# Issue 18's must-show: do two independent runs (seeds 1 and 2) of an 8 x 8 (L*, W*) grid, R* = 5,
# f32, agree on the QRI and QRF surfaces while a CPU hog (`yes`, one per core) shares the cores?
#
#   scripts/hog-experiment.sh NEW_SWEEP OLD_SWEEP OUT_DIR [CONFIGURATIONS]
#
# NEW_SWEEP: this branch's binary (blocks, a statistic per report, references, re-runs, ci_target).
# OLD_SWEEP: a binary without the protocol (e.g. main before issue 18: one whole-pass time per set,
#            the mean over sets), or the same binary to repeat the new protocol.
# Each run is a local-mode campaign on both cores (`--cores 0,1`); the hogs are pinned there
# too, so every timed loop shares its core with a busy loop. Prints one line per protocol:
# Spearman rho and the median relative difference of the per-point ns/check between the two
# seeds, for QRI, QRF, OCSI and SSE, by each statistic, how often the two runs' intervals agree,
# and each run's wall time. Run it inside /work/bin/quiet on a shared
# machine so that other builds do not add noise nobody controls.
set -euo pipefail
new=$(realpath "$1"); old=$(realpath "$2"); out=$3; configurations=${4:-2000000}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"

plan() { # name seed repeats extra-keys
  cat > "$out/$1.toml" <<PLAN
name = "$1"
exclusive = false
seed = $2

[[overlap]]
l_star = [1, 3, 5, 8, 11, 14, 17, 20]
w_star = [1, 3, 5, 8, 11, 14, 17, 20]
r_star = 5.0
acceptance = 0.4
configurations = $configurations
repeats = $3
precision = "f32"
algorithms = ["qri", "qrf", "ocsi", "sse"]
$4
PLAN
}

hogs=()
start_hogs() { for core in 0 1; do taskset -c "$core" yes > /dev/null & hogs+=($!); done; }
stop_hogs() { for pid in "${hogs[@]}"; do kill "$pid" 2>/dev/null || true; done; hogs=(); }
trap stop_hogs EXIT

run() { # binary name
  rm -f "$out/$2.db"*
  local t0; t0=$(date +%s.%N)
  "$1" run "$out/$2.toml" --db "$out/$2.db" --cores 0,1 --format json > "$out/$2.log" 2>&1
  echo "$2 wall_s $(echo "$(date +%s.%N) - $t0" | bc)" | tee -a "$out/wall.txt"
}

# SEEDS="1" then SEEDS="2" runs the two seeds in separate calls (each in its own quiet section);
# the agreement is printed once both seeds' databases are there.
seeds=${SEEDS:-1 2}
[ -z "${SEEDS:-}" ] && : > "$out/wall.txt"
for seed in $seeds; do
  plan "old-$seed" "$seed" 1 ""
  plan "new-$seed" "$seed" 3 $'ci_target = 0.01\ntime_cap_s = 5'
done
start_hogs
for seed in $seeds; do   # interleaved, so a slow phase of the machine hits both protocols
  run "$old" "old-$seed"
  run "$new" "new-$seed"
done
stop_hogs
if [ -f "$out/new-1.db" ] && [ -f "$out/new-2.db" ] && [ -f "$out/old-1.db" ] && [ -f "$out/old-2.db" ]; then
  python3 "$here/surface_agreement.py" "$out" | tee "$out/agreement.txt"
fi
