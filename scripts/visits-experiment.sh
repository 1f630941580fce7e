#!/usr/bin/env bash
# Issue 18's visits: do two independent runs (seeds 1 and 2) of a small (L*, W*) grid, R* = 5,
# f32, agree within their intervals when every point is measured in 3 visits spread over the
# campaign, against 1 visit, with a CPU hog (`yes`, one per core) on the same cores?
#
#   SEEDS="1" scripts/visits-experiment.sh SWEEP OUT_DIR    # one seed per call (one quiet section)
#   SEEDS="2" scripts/visits-experiment.sh SWEEP OUT_DIR    # ... prints the agreement at the end
#
# The same cap on measuring per point: 1 visit with time_cap_s = CAP1 (default 3), or 3 visits
# with time_cap_s = CAP3 (default 1) each; ci_target = CI1 (default 0.01) for the single visit
# (a small one makes it use its whole cap: the same wall time as 3 visits), 0.01 for visits. Runs are local-mode campaigns on both cores; the hogs are
# pinned there too. Wall times go to OUT_DIR/wall.txt; scripts/visits_agreement.py compares.
set -euo pipefail
sweep=$(realpath "$1"); out=$2
here=$(cd "$(dirname "$0")" && pwd)
grid=${GRID:-"[1, 4, 8, 12, 16, 20]"}; configurations=${CONFIGURATIONS:-500000}
mkdir -p "$out"

plan() { # name seed visits time_cap_s ci_target
  cat > "$out/$1.toml" <<PLAN
name = "$1"
exclusive = false
seed = $2

[[overlap]]
l_star = $grid
w_star = $grid
r_star = 5.0
acceptance = 0.4
configurations = $configurations
repeats = 3
precision = "f32"
algorithms = ["qri", "qrf", "ocsi", "sse"]
ci_target = $5
time_cap_s = $4
visits = $3
PLAN
}

hogs=()
start_hogs() { for core in 0 1; do taskset -c "$core" yes > /dev/null & hogs+=($!); done; }
stop_hogs() { for pid in "${hogs[@]}"; do kill "$pid" 2>/dev/null || true; done; hogs=(); }
trap stop_hogs EXIT

run() { # name
  rm -f "$out/$1.db"*
  local t0; t0=$(date +%s.%N)
  "$sweep" run "$out/$1.toml" --db "$out/$1.db" --cores 0,1 --format json > "$out/$1.log" 2>&1
  echo "$1 wall_s $(echo "$(date +%s.%N) - $t0" | bc)" | tee -a "$out/wall.txt"
}

for seed in ${SEEDS:-1 2}; do
  plan "v1-$seed" "$seed" 1 "${CAP1:-3}" "${CI1:-0.01}"
  plan "v3-$seed" "$seed" 3 "${CAP3:-1}" 0.01
done
start_hogs
for seed in ${SEEDS:-1 2}; do   # interleaved, so a slow phase of the machine hits both protocols
  run "v1-$seed"
  run "v3-$seed"
done
stop_hogs
if [ -f "$out/v1-1.db" ] && [ -f "$out/v1-2.db" ] && [ -f "$out/v3-1.db" ] && [ -f "$out/v3-2.db" ]; then
  SWEEP="$sweep" python3 "$here/visits_agreement.py" "$out" | tee "$out/agreement.txt"
fi
