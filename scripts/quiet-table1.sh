#!/usr/bin/env bash
# Is Table 1 (and 2) unchanged by a change of the timing protocol, on a quiet machine? Runs
# deploy/plans/quick.toml (96 points: 4 x 4 shapes x 3 R* x f32/f64, six algorithms) twice with
# each binary, interleaved old, new, new, old (a drift of the machine during the four runs then
# weighs on both alike), each run reported by its own binary, and prints
# per (precision, algorithm):
#   - new/old: the geometric mean over the 48 points of the ratio of the point estimates (each
#     binary's two runs averaged), with its 95 % interval (Student on the log ratios);
#   - old b/a, new b/a: the second run over the first (the machine's run-to-run noise);
# then Table 1/2 itself: each cell (R*, algorithm) new/old, from `report table1|table2 --format
# json` (both runs averaged).
#
#   /work/bin/quiet scripts/quiet-table1.sh NEW_SWEEP OLD_SWEEP OUT_DIR
#
# NEW_ARGS / OLD_ARGS: extra `sweep report` flags of each binary (default: none, so each reports
# by its tables' default statistic; e.g. NEW_ARGS="--statistic median"). Points are read from
# `report fig2|fig3 --format json` with the same flags, so a binary whose figures default to
# another statistic than its tables needs it named: NEW_ARGS defaults to "--statistic mean".
# A binary that prints no points (before issue 18) gives the mean over repeats of its passes'
# ns/check, what its tables average. Also prints, for the new binary's two runs, how often
# their 95 % intervals agree.
set -euo pipefail
new=$(realpath "$1"); old=$(realpath "$2"); out=$3
new_args=${NEW_ARGS---statistic mean}; old_args=${OLD_ARGS-}
plan=$(cd "$(dirname "$0")/.." && pwd)/deploy/plans/quick.toml
mkdir -p "$out"
for run in old-a new-a new-b old-b; do
  binary=$old; [ "${run%-*}" = new ] && binary=$new
  rm -f "$out/$run.db"*
  t0=$(date +%s.%N)
  "$binary" run "$plan" --db "$out/$run.db" --cores 0,1 --format json > "$out/$run.log" 2>&1
  echo "$run wall_s $(echo "$(date +%s.%N) - $t0" | bc)"
done
for run in old-a new-a new-b old-b; do
  binary=$old; args=$old_args
  [ "${run%-*}" = new ] && { binary=$new; args=$new_args; }
  for report in table1 table2; do
    # shellcheck disable=SC2086
    "$binary" report "$report" --db "$out/$run.db" --format json $args > "$out/$run.$report.json"
  done
  for fig in fig2:f32 fig3:f64; do
    # A binary before issue 18 prints no points: its tables average the mean over repeats of
    # each pass's ns/check, which the query reads.
    # shellcheck disable=SC2086
    "$binary" report "${fig%:*}" --db "$out/$run.db" --format json $args > "$out/$run.${fig%:*}.json" 2>/dev/null ||
      "$binary" query "SELECT precision, algorithm, r_star, l_star, w_star, AVG(ns_per_check) AS ns_per_check
                       FROM overlap_timings WHERE precision = '${fig#*:}' GROUP BY 1, 2, 3, 4, 5" \
        --db "$out/$run.db" --format json > "$out/$run.${fig%:*}.json"
  done
done
python3 - "$out" <<'PY'
import json, math, os, statistics, sys
out = sys.argv[1]
T975 = {47: 2.012}

def load(run, *reports):
    return [r for report in reports for r in json.load(open(os.path.join(out, f"{run}.{report}.json")))]

def points(run):
    return {(r["precision"], r["algorithm"], r["r_star"], r["l_star"], r["w_star"]): r
            for r in load(run, "fig2", "fig3")}

def cells(run):
    return {(r["precision"], r["algorithm"], r["r_star"]): r["mean_ms"] for r in load(run, "table1", "table2")}

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
    """Per key, the geometric mean over runs (each a dict of key -> value)."""
    keys = set.intersection(*(set(r) for r in runs))
    return {k: math.exp(statistics.fmean(math.log(r[k]) for r in runs)) for k in keys}

estimate = lambda run: {k: p["ns_per_check"] for k, p in points(run).items()}
columns = {
    "new/old": ratios(mean_of_runs(estimate("new-a"), estimate("new-b")),
                      mean_of_runs(estimate("old-a"), estimate("old-b"))),
    "old b/a": ratios(estimate("old-b"), estimate("old-a")),
    "new b/a": ratios(estimate("new-b"), estimate("new-a")),
}
statistic = {p.get("statistic", "?") for p in points("new-a").values()}
print(f"points (new binary's statistic: {'+'.join(sorted(statistic))})")
fmt = lambda r: f"{r[0]:.3f} [{r[1]:.3f}, {r[2]:.3f}]"
print("precision algorithm  " + "".join(f"{c:>25}" for c in columns))
for group in sorted(columns["new/old"]):
    print(f"{group[0]:9} {group[1]:10} " + "".join(f"{fmt(columns[c][group]):>25}" for c in columns))

new_cells = mean_of_runs(cells("new-a"), cells("new-b"))
old_cells = mean_of_runs(cells("old-a"), cells("old-b"))
print("\nTable 1/2 cells, new/old (mean_ms, two runs each)")
for precision in sorted({k[0] for k in new_cells}):
    r_values = sorted({k[2] for k in new_cells if k[0] == precision})
    print(f"{precision:9} {'algorithm':10} " + "".join(f"{'R* = ' + str(r):>12}" for r in r_values))
    for algorithm in sorted({k[1] for k in new_cells if k[0] == precision}):
        row = [new_cells.get((precision, algorithm, r), math.nan) / old_cells.get((precision, algorithm, r), math.nan)
               for r in r_values]
        print(f"{'':9} {algorithm:10} " + "".join(f"{x:12.3f}" for x in row))

one, two = points("new-a"), points("new-b")
print("\nnew binary, its two runs' 95 % intervals agree (|a - b| <= hypot of the half-widths)")
agree = {}
for key in one.keys() & two.keys():
    a, b = one[key], two[key]
    if a.get("ci95_lo_ns_per_check") is None or b.get("ci95_lo_ns_per_check") is None:
        continue
    half = math.hypot((a["ci95_hi_ns_per_check"] - a["ci95_lo_ns_per_check"]) / 2,
                      (b["ci95_hi_ns_per_check"] - b["ci95_lo_ns_per_check"]) / 2)
    agree.setdefault(key[:2], []).append(abs(a["ns_per_check"] - b["ns_per_check"]) <= half)
for group in sorted(agree):
    print(f"{group[0]:9} {group[1]:10} {sum(agree[group]):3}/{len(agree[group])}")
PY
