#!/usr/bin/env bash
# Issue 26's must-show for a memory-bandwidth hog: of the overlap points measured while a loop
# streaming through 1 GiB ran on the other core, how many does the noise check flag; and of the
# points measured on the quiet machine before and after it, how many?
#
#   scripts/bandwidth-hog-flags.sh SWEEP OUT_DIR [HOG_START_S] [HOG_LENGTH_S]
#
# Runs a campaign of 36 points of 10^6 configurations (48 MB in f32, 96 MB in f64: read from
# memory) pinned to core 1, starts the hog (crates/overlap/examples/noise.rs `memory`, pinned to
# core 0) HOG_START_S seconds in and stops it HOG_LENGTH_S seconds later, then counts flagged
# points by when they were measured. Run it when no build shares the machine.
set -euo pipefail
sweep=$(realpath "$1"); out=$2; start=${3:-8}; length=${4:-8}
here=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
(cd "$here" && cargo build --release -q -p overlap --example noise)
cat > "$out/hog.toml" <<PLAN
name = "bandwidth-hog"
seed = $(date +%s)
[[overlap]]
l_star = [1, 2, 4, 8, 12, 16]
w_star = [1, 4, 16]
r_star = 0.5
acceptance = 0.4
configurations = 1_000_000
repeats = 2
precision = ["f32", "f64"]
PLAN
rm -f "$out/hog.db"
"$sweep" run "$out/hog.toml" --db "$out/hog.db" --cores 1 --format json > "$out/run.json" &
run=$!
sleep "$start"
taskset -c 0 "$here/target/release/examples/noise" memory & hog=$!
from=$(date +%s.%N)
sleep "$length"
kill "$hog"; wait "$hog" 2>/dev/null || true
to=$(date +%s.%N)
wait "$run"
"$sweep" query "SELECT CASE WHEN j.finished_at - (json_extract(r.fields, '\$.wall_s')) >= $from AND j.finished_at <= $to THEN 'during the hog'
                            WHEN j.finished_at < $from OR j.finished_at - (json_extract(r.fields, '\$.wall_s')) > $to THEN 'quiet'
                            ELSE 'partly during' END AS measured,
                       count(*) AS points, total(m.disturbed) AS flagged, total(m.reruns > 0) AS rerun
                FROM overlap_measurements AS m JOIN jobs AS j ON j.id = m.job_id
                JOIN results AS r ON r.job_id = m.job_id AND r.row_index = (SELECT max(row_index) FROM results WHERE job_id = m.job_id)
                GROUP BY 1" --db "$out/hog.db"
