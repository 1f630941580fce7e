#!/usr/bin/env bash
# The noise check's calibration (issue 26): the distributions of what it compares, on a quiet
# machine and beside each disturbance, from which the tolerances in crates/overlap/src/noise.rs
# are set.
#
#   scripts/noise-calibration.sh OUT_DIR [ROUNDS]
#
# Runs `cargo run --release -p overlap --example noise -- measure ROUNDS` (points of 10^5, 10^6
# and 10^7 configurations, f32 and f64, one thread's calibration carried along) pinned to core 1:
#   quiet   nothing else running (run it when no build shares the machine),
#   spin    a busy loop pinned to the same core 1,
#   memory  a loop streaming through 1 GiB pinned to the other core, 0,
# each into OUT_DIR/CONDITION.jsonl, then prints the summary of scripts/noise_summary.py.
set -euo pipefail
out=$1; rounds=${2:-20}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
cargo build --release -q -p overlap --example noise
noise=$(cd "$here/.." && pwd)/target/release/examples/noise

hog=''
stop_hog() { [[ -n $hog ]] && kill "$hog" 2>/dev/null; wait "$hog" 2>/dev/null || true; hog=''; }
trap stop_hog EXIT

for condition in quiet spin memory; do
    case $condition in
        spin) taskset -c 1 "$noise" spin & hog=$! ;;
        memory) taskset -c 0 "$noise" memory & hog=$! ;;
    esac
    echo "$condition: $rounds rounds" >&2
    taskset -c 1 "$noise" measure "$rounds" > "$out/$condition.jsonl"
    stop_hog
done
python3 "$here/noise_summary.py" "$out"
