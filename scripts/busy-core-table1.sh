#!/usr/bin/env bash
# Issue 26's must-show: a busy loop sharing the measuring core doubles Table 1 by its mean; the
# noise check must then flag every point (or the table must not move).
#
#   scripts/busy-core-table1.sh SWEEP OUT_DIR
#
# Runs a 2-point plan (R* = 0.05 and 5, 2·10^6 configurations, f32) pinned to core 1 (`--cores 1`)
# twice: on a quiet machine, and with a busy loop pinned to the same core. Prints Table 1 (mean)
# and the noise check's counts of each run. Run it when no build shares the machine.
set -euo pipefail
sweep=$(realpath "$1"); out=$2
mkdir -p "$out"
cat > "$out/busy.toml" <<PLAN
name = "busy-core"
[[overlap]]
l_star = 4
w_star = 4
r_star = [0.05, 5.0]
acceptance = 0.4
configurations = 2_000_000
repeats = 3
precision = "f32"
PLAN
spin=''
trap '[[ -n $spin ]] && kill "$spin" 2>/dev/null || true' EXIT
for condition in quiet busy; do
    rm -f "$out/$condition.db"
    if [[ $condition == busy ]]; then
        taskset -c 1 sh -c 'while :; do :; done' & spin=$!
    fi
    echo "## $condition"
    "$sweep" run "$out/busy.toml" --db "$out/$condition.db" --cores 1 | grep timing
    "$sweep" report table1 --db "$out/$condition.db"
    "$sweep" query "SELECT substr(disturbance, 1, 100) AS flag FROM overlap_measurements" --db "$out/$condition.db"
    [[ -n $spin ]] && kill "$spin" && wait "$spin" 2>/dev/null || true
    spin=''
done
