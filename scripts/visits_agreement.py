#!/usr/bin/env python3
"""Agreement of two runs (seeds 1 and 2) of visits-experiment.sh, for 1 visit (v1-N.db) and for
3 visits (v3-N.db), from `sweep report fig2 --format json --statistic S` (what the reports give):
Spearman rho and the median relative difference |a - b| / ((a + b) / 2) of the per-point
estimates; the interval agreement rate: the share of points where the two runs' intervals
overlap, where they agree within their combined half-widths (|a - b| <= hypot(h_a, h_b), 95 % for
honest independent intervals), and where one run's interval holds the other run's estimate (each
way); the median relative half-width. "v3, first visit only" re-reads the 3-visit runs keeping
their first visits, i.e. one visit of a third of the budget. Then each run's measuring cost.
"""
import json, math, os, shutil, sqlite3, statistics, subprocess, sys, tempfile

from rank_correlation import spearman

out = sys.argv[1]
sweep = os.environ.get("SWEEP", "target/release/sweep")
ALGORITHMS = ("qri", "qrf", "ocsi", "sse")


def points(db, statistic):
    rows = json.loads(subprocess.run(
        [sweep, "report", "fig2", "--db", db, "--format", "json", "--statistic", statistic],
        check=True, capture_output=True, text=True).stdout)
    return {(p["algorithm"], p["l_star"], p["w_star"]):
            (p["ns_per_check"], p["ci95_lo_ns_per_check"], p["ci95_hi_ns_per_check"], p.get("visits"))
            for p in rows}


def first_visits(db, scratch):
    """A copy of `db` without the results of visits after the first."""
    copy = os.path.join(scratch, os.path.basename(db))
    src = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    dst = sqlite3.connect(copy)
    src.backup(dst)
    src.close()
    dst.execute("DELETE FROM results WHERE job_id IN "
                "(SELECT id FROM jobs WHERE json_extract(params, '$.visit') IS NOT NULL)")
    dst.commit()
    dst.close()
    return copy


def compare(name, one, two):
    cells = []
    for algorithm in ALGORITHMS:
        keys = sorted(k for k in one if k[0] == algorithm and k in two)
        pairs = [(one[k], two[k]) for k in keys]
        a, b = [p[0][0] for p in pairs], [p[1][0] for p in pairs]
        diff = statistics.median(abs(x - y) / ((x + y) / 2) for x, y in zip(a, b))
        overlap = sum(max(x[1], y[1]) <= min(x[2], y[2]) for x, y in pairs)
        agree = sum(abs(x[0] - y[0]) <= math.hypot((x[2] - x[1]) / 2, (y[2] - y[1]) / 2) for x, y in pairs)
        holds = sum((x[1] <= y[0] <= x[2]) + (y[1] <= x[0] <= y[2]) for x, y in pairs)
        width = statistics.median((v[2] - v[1]) / 2 / v[0] for x, y in pairs for v in (x, y))
        visits = sorted({v[3] for x, y in pairs for v in (x, y)})
        n = len(keys)
        cells.append(f"{algorithm.upper()} rho {spearman(a, b):.2f}, diff {100 * diff:.1f} %, "
                     f"overlap {100 * overlap / n:.0f} %, agree {100 * agree / n:.0f} %, "
                     f"holds {100 * holds / (2 * n):.0f} %, half-width {100 * width:.2f} % "
                     f"({n} pts, visits {visits})")
    print(f"{name}\n  " + "\n  ".join(cells))


db = lambda name: os.path.join(out, name + ".db")
with tempfile.TemporaryDirectory() as scratch:
    firsts = [first_visits(db(f"v3-{s}"), scratch) for s in (1, 2)]
    for statistic in ("p5", "mean"):
        compare(f"1 visit ({statistic})", points(db("v1-1"), statistic), points(db("v1-2"), statistic))
        compare(f"3 visits ({statistic})", points(db("v3-1"), statistic), points(db("v3-2"), statistic))
        compare(f"v3, first visit only ({statistic})", points(firsts[0], statistic),
                points(firsts[1], statistic))
for name in ("v1-1", "v1-2", "v3-1", "v3-2"):
    con = sqlite3.connect(f"file:{db(name)}?mode=ro", uri=True)
    jobs, flagged, rerun, sets, capped, wall_s, timed_s = con.execute(
        "SELECT COUNT(*), SUM(disturbed), SUM(reruns > 0), AVG(repeats), SUM(stop = 'time_cap'), "
        "SUM(wall_s), SUM(timed_s) FROM overlap_measurements").fetchone()
    print(f"{name}: {jobs} jobs, {flagged} flagged, {rerun} re-run, {sets:.1f} sets per job, "
          f"{capped} stopped by time_cap_s, {wall_s:.0f} s of measuring ({timed_s:.0f} s timed)")
