#!/usr/bin/env python3
"""Issue 29's ratio target (MEASUREMENTS.md, "EDMD round 3"): the ellipsoids' τ_c (X0 2, φ 0.5,
N 256, Δ_NNL 0.085) over the spheres' τ_c at the same N and φ, in the same run.

SCENE is a `cargo build --release -p edmd --example scene` binary. Each round runs the spheres,
the ellipsoids and the spheres again, one after the other, and divides the ellipsoids' CPU time
per collision by the mean of the two sphere runs around it: on a shared machine whose speed
drifts by tens of percent from minute to minute, only times taken this close together compare.
Printed: every round, then the median of the rounds' ratios with a 95 % bootstrap interval
(percentile, 10,000 resamples, seeded), the quartiles, how many rounds are at or under 12 ×,
the median over the median and the fastest run over the fastest.
"""
import argparse
import random
import statistics
import sys

from round3 import ELLIPSOID_TUNED, SPHERES, run

TARGET = 12.0


def tau(binary, spec):
    try:
        r = run(binary, spec)
    except OSError as e:
        sys.exit(f"{binary}: {e}")
    if "error" in r:
        sys.exit(f"{binary} {spec}: {r['error']}")
    if r["overlaps"] or r["solver_failures"]:
        sys.exit(f"{spec}: {r['overlaps']} overlaps, {r['solver_failures']} solver failures")
    return r["tau_c_cpu_us"]


def bootstrap_median(xs, resamples=10_000, seed=0):
    rng = random.Random(seed)
    medians = sorted(statistics.median(rng.choices(xs, k=len(xs))) for _ in range(resamples))
    return medians[int(0.025 * resamples)], medians[int(0.975 * resamples) - 1]


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene", help="an `examples/scene` binary of the edmd crate")
    parser.add_argument("--rounds", type=int, default=30, help="paired rounds (at least 2; default 30)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the bootstrap's resampling")
    args = parser.parse_args(argv)
    if args.rounds < 2:
        parser.error(f"--rounds {args.rounds}: at least 2 rounds, for the quartiles and the interval")
    binary, rounds, seed = args.scene, args.rounds, args.seed
    rows = []
    for k in range(rounds):
        before = tau(binary, SPHERES)
        ell = tau(binary, ELLIPSOID_TUNED)
        after = tau(binary, SPHERES)
        spheres = 0.5 * (before + after)
        rows.append((spheres, ell, min(before, after)))
        print(f"round {k + 1:3}: spheres {before:.3f} / {after:.3f} µs, ellipsoids {ell:.2f} µs, "
              f"{ell / spheres:.2f} ×", flush=True)
    ratios = [e / s for s, e, _ in rows]
    lo, hi = bootstrap_median(ratios, seed=seed)
    q = statistics.quantiles(ratios, n=4)
    at_most = sum(r <= TARGET for r in ratios)
    spheres_med = statistics.median(s for s, _, _ in rows)
    ell_med = statistics.median(e for _, e, _ in rows)
    fastest = min(e for _, e, _ in rows) / min(f for _, _, f in rows)
    print(f"rounds {rounds}: median ratio {statistics.median(ratios):.2f} × "
          f"(95 % bootstrap {lo:.2f}–{hi:.2f}; quartiles {q[0]:.2f} / {q[2]:.2f}); "
          f"{at_most} of {rounds} at or under {TARGET:g} ×")
    print(f"median over median {ell_med / spheres_med:.2f} × "
          f"(ellipsoids {ell_med:.2f} µs, spheres {spheres_med:.3f} µs); "
          f"fastest over fastest {fastest:.2f} ×")


if __name__ == "__main__":
    main(sys.argv[1:])
