"""The distributions of the noise check's signals per condition and set size, from the JSON
lines of `crates/overlap/examples/noise.rs` (see scripts/noise-calibration.sh):

- core share: the thread's CPU time over the wall time of its timed passes;
- stream end/start: the slower of the two warm plain reads of a point over the faster;
- stream/baseline: the faster read over the fastest earlier read of sets of its size class;
- compute/baseline: the slower compute reference over the fastest earlier one (or the point's own);

each as min / 1st / 50th / 99th percentile / max, and how many points the check as built flagged.

    python3 scripts/noise_summary.py OUT_DIR
"""

import json
import sys
from pathlib import Path


def quantile(values, q):
    values = sorted(values)
    if not values:
        return float("nan")
    at = q * (len(values) - 1)
    i = int(at)
    return values[i] if i + 1 >= len(values) else values[i] + (at - i) * (values[i + 1] - values[i])


def spread(values):
    return " ".join(f"{quantile(values, q):.3f}" for q in (0, 0.01, 0.5, 0.99, 1))


def signals(row):
    s0, s1 = row["stream_before"], row["stream_after"]
    fast = min(s0, s1)
    compute = max(row["compute_before"], row["compute_after"])
    fastest = min(row["compute_before"], row["compute_after"])
    if row["compute_baseline"] is not None:
        fastest = min(fastest, row["compute_baseline"])
    return {
        "core share": row["core_share"],
        "stream end/start": max(s0, s1) / fast,
        "stream/baseline": fast / row["stream_baseline"] if row["stream_baseline"] else None,
        "compute/baseline": compute / fastest,
    }


def main(out):
    for path in sorted(Path(out).glob("*.jsonl")):
        rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
        print(f"## {path.stem}: {len(rows)} points, {sum(r['flagged'] for r in rows)} flagged")
        print("size (configurations) | signal | min p1 p50 p99 max")
        for size in sorted({r["configurations"] for r in rows}):
            of_size = [signals(r) for r in rows if r["configurations"] == size]
            flagged = sum(r["flagged"] for r in rows if r["configurations"] == size)
            for name in ("core share", "stream end/start", "stream/baseline", "compute/baseline"):
                values = [s[name] for s in of_size if s[name] is not None]
                print(f"{size:.0e} | {name} | {spread(values)}")
            print(f"{size:.0e} | flagged | {flagged} of {len(of_size)}")
        print()


if __name__ == "__main__":
    main(sys.argv[1])
