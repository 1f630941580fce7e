#!/usr/bin/env bash
# Is Table 1 (and 2) unchanged by a change of the timing protocol, on a quiet machine? Runs
# deploy/plans/quick.toml (96 points: 4 x 4 shapes x 3 R* x f32/f64, six algorithms) twice with
# each binary, interleaved (old, new, old, new), and prints per (precision, algorithm) the
# geometric mean over the 48 points of the ratio of the point estimates, with its 95 % interval
# (Student on the log ratios):
#   - new/old: each binary's two runs reported by itself (what a user sees change);
#   - old b/a, new b/a: the second run over the first (the machine's run-to-run noise);
#   - statistic only: every run reported by the new binary over the same run reported by the old
#     one (the estimator's change on the same blocks);
#   - measurement only: the new runs over the old runs, all reported by the old binary.
#
#   /work/bin/quiet scripts/quiet-table1.sh NEW_SWEEP OLD_SWEEP OUT_DIR
set -euo pipefail
new=$(realpath "$1"); old=$(realpath "$2"); out=$3
plan=$(cd "$(dirname "$0")/.." && pwd)/deploy/plans/quick.toml
mkdir -p "$out"
for run in old-a new-a old-b new-b; do
  binary=$old; [ "${run%-*}" = new ] && binary=$new
  rm -f "$out/$run.db"*
  t0=$(date +%s.%N)
  "$binary" run "$plan" --db "$out/$run.db" --cores 0,1 --format json > "$out/$run.log" 2>&1
  echo "$run wall_s $(echo "$(date +%s.%N) - $t0" | bc)"
done
for run in old-a new-a old-b new-b; do
  for by in old new; do
    binary=$old; [ "$by" = new ] && binary=$new
    for fig in fig2 fig3; do
      "$binary" report "$fig" --db "$out/$run.db" --format json > "$out/$run.by-$by.$fig.json"
    done
  done
done
python3 - "$out" <<'PY'
import json, math, os, statistics, sys
out = sys.argv[1]
T975 = {47: 2.012}

def points(run, by):
    rows = []
    for fig in ("fig2", "fig3"):
        rows += json.load(open(os.path.join(out, f"{run}.by-{by}.{fig}.json")))
    return {(r["precision"], r["algorithm"], r["r_star"], r["l_star"], r["w_star"]): r["ns_per_check"]
            for r in rows}

def ratios(a, b):
    """(precision, algorithm) -> geometric mean of a/b over the points and its 95 % interval."""
    groups = {}
    for key in a.keys() & b.keys():
        groups.setdefault(key[:2], []).append(math.log(a[key] / b[key]))
    result = {}
    for group, logs in groups.items():
        n = len(logs)
        mean, sd = statistics.fmean(logs), statistics.stdev(logs)
        half = T975.get(n - 1, 1.96 + 2.4 / (n - 1)) * sd / math.sqrt(n)
        result[group] = (math.exp(mean), math.exp(mean - half), math.exp(mean + half))
    return result

def mean_of_runs(*runs):
    """Per point, the geometric mean over runs (each a dict of point -> estimate)."""
    keys = set.intersection(*(set(r) for r in runs))
    return {k: math.exp(statistics.fmean(math.log(r[k]) for r in runs)) for k in keys}

def pooled(pairs):
    """The ratios of several (a, b) pairs of runs as one set of points."""
    merged_a, merged_b = {}, {}
    for i, (a, b) in enumerate(pairs):
        merged_a |= {(*k[:2], i, *k[2:]): v for k, v in a.items()}
        merged_b |= {(*k[:2], i, *k[2:]): v for k, v in b.items()}
    return ratios(merged_a, merged_b)

runs = ("old-a", "new-a", "old-b", "new-b")
columns = {
    "new/old": ratios(mean_of_runs(points("new-a", "new"), points("new-b", "new")),
                      mean_of_runs(points("old-a", "old"), points("old-b", "old"))),
    "old b/a": ratios(points("old-b", "old"), points("old-a", "old")),
    "new b/a": ratios(points("new-b", "new"), points("new-a", "new")),
    "statistic only": pooled([(points(r, "new"), points(r, "old")) for r in runs]),
    "measurement only": ratios(mean_of_runs(points("new-a", "old"), points("new-b", "old")),
                               mean_of_runs(points("old-a", "old"), points("old-b", "old"))),
}
fmt = lambda r: f"{r[0]:.3f} [{r[1]:.3f}, {r[2]:.3f}]"
print("precision algorithm  " + "".join(f"{c:>25}" for c in columns))
for group in sorted(columns["new/old"]):
    print(f"{group[0]:9} {group[1]:10} " + "".join(f"{fmt(columns[c][group]):>25}" for c in columns))
PY
