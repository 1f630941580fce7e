#!/usr/bin/env python3
"""Agreement of two runs' QRI/QRF surfaces (see hog-experiment.sh): Spearman rho and the median
relative difference |a - b| / ((a + b) / 2) of the per-point ns/check of seeds 1 and 2.

- old-N.db (no protocol): the mean over sets of whole-pass times, as main reported them;
- new-N.db: each statistic of the blocks (`sweep report fig2 --statistic S --format json`, the
  same code the reports use: p5, the figures' default; median; mean, the tables' default), and,
  from the same passes, the whole-pass mean ("new runs, plain"), which isolates the estimator
  from the machine's state during the runs, and from the same blocks the median of the sets'
  median blocks (the estimate before the 5th percentile).
For each statistic of the new runs, how often the intervals mean what they say: the share of
points where one run's 95 % interval holds the other run's estimate (each way; below 95 % even
for honest intervals, since the other estimate has its own error: about 83 % for two equally
precise ones), and where the two runs agree within their intervals (|a - b| <= hypot of the
half-widths: 95 % for honest intervals).
Also prints each new run's flagged and re-run point counts, sets per point and their cost.
"""
import json, math, os, sqlite3, statistics, subprocess, sys

from rank_correlation import spearman

out = sys.argv[1]
new_sweep = os.environ.get("NEW_SWEEP", "target/release/sweep")
ALGORITHMS = ("qri", "qrf", "ocsi", "sse")


def whole_pass_means(db, column):
    """(algorithm, L*, W*) -> mean over sets of a whole pass's ns/check."""
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    rows = con.execute(
        f"SELECT algorithm, l_star, w_star, AVG({column}) FROM overlap_timings "
        "WHERE precision = 'f32' GROUP BY algorithm, l_star, w_star").fetchall()
    return {(a, l, w): v for a, l, w, v in rows}


def median_of_set_medians(db):
    """(algorithm, L*, W*) -> the median over sets of each set's median block."""
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    sets = {}
    for a, l, w, blocks in con.execute(
            "SELECT algorithm, l_star, w_star, block_ns_per_check FROM overlap_timings "
            "WHERE precision = 'f32'"):
        sets.setdefault((a, l, w), []).append(statistics.median(json.loads(blocks)))
    return {k: statistics.median(v) for k, v in sets.items()}


def estimates(db, statistic="p5"):
    """(algorithm, L*, W*) -> (estimate, lo, hi) by `statistic`, and the run's noise counts."""
    points = json.loads(subprocess.run(
        [new_sweep, "report", "fig2", "--db", db, "--format", "json", "--statistic", statistic],
        check=True, capture_output=True, text=True).stdout)
    values = {(p["algorithm"], p["l_star"], p["w_star"]):
              (p["ns_per_check"], p["ci95_lo_ns_per_check"], p["ci95_hi_ns_per_check"]) for p in points}
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    quality = con.execute(
        "SELECT COUNT(*), SUM(disturbed), SUM(reruns > 0), SUM(reruns), AVG(repeats), "
        "SUM(stop = 'time_cap'), SUM(wall_s) FROM overlap_measurements").fetchone()
    return values, quality


def coverage(name, one, two):
    cells = []
    for algorithm in ALGORITHMS:
        keys = sorted(k for k in one if k[0] == algorithm and k in two)
        holds = sum((a[1] <= b[0] <= a[2]) + (b[1] <= a[0] <= b[2])
                    for a, b in ((one[k], two[k]) for k in keys))
        agree = sum(abs(a[0] - b[0]) <= math.hypot((a[2] - a[1]) / 2, (b[2] - b[1]) / 2)
                    for a, b in ((one[k], two[k]) for k in keys))
        width = statistics.median(
            (v[2] - v[1]) / 2 / v[0] for run in (one, two) for k in keys for v in [run[k]])
        cells.append(f"{algorithm.upper()} holds {holds}/{2 * len(keys)}, agree {agree}/{len(keys)}, "
                     f"half-width {100 * width:.2f} %")
    print(f"{name:32} " + " | ".join(cells))


def agreement(name, one, two):
    cells = []
    for algorithm in ALGORITHMS:
        keys = sorted(k for k in one if k[0] == algorithm and k in two)
        a, b = [one[k] for k in keys], [two[k] for k in keys]
        diff = statistics.median(abs(x - y) / ((x + y) / 2) for x, y in zip(a, b))
        cells.append(f"{algorithm.upper()} rho = {spearman(a, b):.2f}, "
                     f"median diff = {100 * diff:.1f} % ({len(keys)} points)")
    print(f"{name:32} " + " | ".join(cells))


db = lambda name: os.path.join(out, name + ".db")
agreement("old protocol (main binary)", whole_pass_means(db("old-1"), "ns_per_check"),
          whole_pass_means(db("old-2"), "ns_per_check"))
(e1, q1), (e2, q2) = estimates(db("new-1")), estimates(db("new-2"))
value = lambda e: {k: v[0] for k, v in e.items()}
agreement("new protocol (robust estimate)", value(e1), value(e2))
per_config = "total_ms * 1e6 / configurations"
agreement("new runs, plain whole-pass mean", whole_pass_means(db("new-1"), per_config),
          whole_pass_means(db("new-2"), per_config))
agreement("new runs, median of set medians", median_of_set_medians(db("new-1")),
          median_of_set_medians(db("new-2")))
for statistic in ("median", "mean"):
    one, two = estimates(db("new-1"), statistic)[0], estimates(db("new-2"), statistic)[0]
    agreement(f"new runs, {statistic} of the blocks", value(one), value(two))
for statistic, (one, two) in (("p5", (e1, e2)),) + tuple(
        (s, (estimates(db("new-1"), s)[0], estimates(db("new-2"), s)[0])) for s in ("median", "mean")):
    coverage(f"intervals, {statistic}", one, two)
for seed, (points, flagged, rerun, reruns, sets, capped, wall_s) in ((1, q1), (2, q2)):
    print(f"new-{seed}: {points} points, {flagged} flagged, {rerun} re-run ({reruns} re-runs), "
          f"{sets:.1f} sets per point on average, {capped} stopped by time_cap_s, "
          f"{wall_s:.0f} s of measuring in all")
