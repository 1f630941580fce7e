#!/usr/bin/env python3
"""Agreement of two runs' QRI/QRF surfaces (see hog-experiment.sh): Spearman rho and the median
relative difference |a - b| / ((a + b) / 2) of the per-point ns/check of seeds 1 and 2.

- old-N.db (no protocol): the mean over sets of whole-pass times, as main reported them;
- new-N.db: the robust estimate, read from `sweep report fig2 --format json` (the same code
  the reports use), and, from the same passes, the whole-pass mean ("new runs, plain"), which
  isolates the estimator from the machine's state during the runs, and from the same blocks the
  median of the sets' median blocks (the estimate before the 5th percentile).
Also prints each new run's flagged and re-run point counts, sets per point and their cost.
"""
import json, os, sqlite3, statistics, subprocess, sys

out = sys.argv[1]
new_sweep = os.environ.get("NEW_SWEEP", "target/release/sweep")
ALGORITHMS = ("qri", "qrf", "ocsi", "sse")


def ranks(values):
    order = sorted(range(len(values)), key=lambda i: values[i])
    r = [0.0] * len(values)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and values[order[j + 1]] == values[order[i]]:
            j += 1
        for k in range(i, j + 1):
            r[order[k]] = (i + j) / 2 + 1
        i = j + 1
    return r


def spearman(a, b):
    ra, rb = ranks(a), ranks(b)
    ma, mb = statistics.fmean(ra), statistics.fmean(rb)
    cov = sum((x - ma) * (y - mb) for x, y in zip(ra, rb))
    return cov / (sum((x - ma) ** 2 for x in ra) * sum((y - mb) ** 2 for y in rb)) ** 0.5


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


def estimates(db):
    points = json.loads(subprocess.run(
        [new_sweep, "report", "fig2", "--db", db, "--format", "json"],
        check=True, capture_output=True, text=True).stdout)
    values = {(p["algorithm"], p["l_star"], p["w_star"]): p["ns_per_check"] for p in points}
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    quality = con.execute(
        "SELECT COUNT(*), SUM(disturbed), SUM(reruns > 0), SUM(reruns), AVG(repeats), "
        "SUM(stop = 'time_cap'), SUM(wall_s) FROM overlap_measurements").fetchone()
    return values, quality


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
agreement("new protocol (robust estimate)", e1, e2)
per_config = "total_ms * 1e6 / configurations"
agreement("new runs, plain whole-pass mean", whole_pass_means(db("new-1"), per_config),
          whole_pass_means(db("new-2"), per_config))
agreement("new runs, median of set medians", median_of_set_medians(db("new-1")),
          median_of_set_medians(db("new-2")))
for seed, (points, flagged, rerun, reruns, sets, capped, wall_s) in ((1, q1), (2, q2)):
    print(f"new-{seed}: {points} points, {flagged} flagged, {rerun} re-run ({reruns} re-runs), "
          f"{sets:.1f} sets per point on average, {capped} stopped by time_cap_s, "
          f"{wall_s:.0f} s of measuring in all")
