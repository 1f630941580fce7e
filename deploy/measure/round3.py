#!/usr/bin/env python3
"""Issue 29's table (MEASUREMENTS.md, "EDMD round 3"): the cost of rigid bodies against spheres
and the peer, before and after, in one session.

OLD_SCENE and NEW_SCENE are `cargo build --release -p edmd --example scene` binaries or `sweep`
binaries (a name containing "sweep": run as `sweep edmd SCENE.toml --format json`), built from main
before a change and after it; they run alternately, case by case, in R rounds (default 2).
PEER is deploy/peers/build-smallenburg.sh's md-single: spheres at the same N and φ.
Every case is seeded (seed 0) and on NNL; τ_c is CPU time per collision. Fallbacks are whole-run
counts (relaxation and equilibration included), also given per 10⁵ collisions of equilibration
and measurement: an upper bound of the measured rate.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

SPHERES = 'shape="sphere" n=256 phi=0.5 delta_nnl=0.25 equilibrate=100000 collisions=1000000'
ELLIPSOID = 'shape="ellipsoid" n=256 phi=0.5 x0=2.0 equilibrate=2000 collisions=100000'
# The issue's ratio case: Δ_NNL at the minimum of τ_c (Fig. 11's search).
ELLIPSOID_TUNED = ELLIPSOID + " delta_nnl=0.085"

CASES = [
    ("spheres φ 0.5", SPHERES),
    ("ellipsoids X0 2 φ 0.5", ELLIPSOID),
    ("ellipsoids X0 2 φ 0.5 Δ 0.085", ELLIPSOID_TUNED),
    ("X0 0.1 φ 0.3 N 128", 'shape="ellipsoid" n=128 phi=0.3 x0=0.1 equilibrate=200 collisions=10000'),
    ("X0 10 φ 0.2 N 512", 'shape="ellipsoid" n=512 phi=0.2 x0=10.0 equilibrate=200 collisions=10000'),
    ("HE X0 2 φ 0.256 N 512", 'shape="ellipsoid" n=512 phi=0.256 x0=2.0 equilibrate=400 collisions=4000'),
    ("SQ p 2 (same)", 'shape="superquadric" exponents=[2.0,2.0,2.0] n=512 phi=0.256 x0=2.0 equilibrate=400 collisions=4000'),
    ("SQ p 10 (same)", 'shape="superquadric" exponents=[2.0,2.0,10.0] n=512 phi=0.256 x0=2.0 equilibrate=400 collisions=4000'),
    ("init X0 2 φ 0.5 N 4096", 'shape="ellipsoid" n=4096 phi=0.5 x0=2.0 equilibrate=0 collisions=1000'),
]


def scene_keys(spec):
    keys = spec.split() + ['neighbours="nnl"', "seed=0"]
    if not any(k.startswith("delta_nnl") for k in keys):
        keys.append("delta_nnl=0.15")
    return keys


def run(binary, spec):
    if "sweep" in os.path.basename(binary):
        with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as f:
            f.write("\n".join(k.replace("=", " = ", 1) for k in scene_keys(spec)) + "\n")
        out = subprocess.run([binary, "edmd", f.name, "--format", "json"], capture_output=True, text=True)
        os.unlink(f.name)
    else:
        out = subprocess.run([binary] + scene_keys(spec), capture_output=True, text=True)
    if out.returncode != 0:
        last = out.stderr.strip().splitlines()[-1:]
        return {"error": f"exit status {out.returncode}" + (f": {last[0]}" if last else "")}
    return json.loads(out.stdout)


def peer(binary, n=256, phi=0.5, collisions=2_000_000):
    out = subprocess.run([binary, str(n), str(phi), str(collisions), "1"], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def counted(spec, r):
    keys = dict(k.split("=", 1) for k in spec.split())
    done = int(keys.get("equilibrate", 0)) + int(keys.get("collisions", 0))
    return 1e5 * r["distance_fallbacks"] / max(done, 1)


def line(name, side, spec, r, sphere_tau):
    if "error" in r:
        return f"| {name} | {side} | error: {r['error']} |"
    ratio = r["tau_c_cpu_us"] / sphere_tau if sphere_tau else float("nan")
    return (
        f"| {name} | {side} | {r['tau_c_cpu_us']:.3f} | {ratio:.1f} | {r['distance_calls_per_collision']:.2f} "
        f"| {r['nr_iterations_mean']:.2f} | {r['distance_fallbacks']} ({counted(spec, r):.0f}) "
        f"| {r['contact_nr_fallbacks']} | {r['overlaps']} / {r['solver_failures']} "
        f"| {r['pressure_z']:.3f} ± {r['pressure_z_err']:.3f} | {1e3 * r['init_s'] / r['n']:.3f} |"
    )


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("old", metavar="OLD_SCENE", help="the scene or sweep binary built before the change")
    parser.add_argument("new", metavar="NEW_SCENE", help="the scene or sweep binary built after it")
    parser.add_argument("peer", metavar="PEER", nargs="?", help="the peer's md-single, for spheres beside ours")
    parser.add_argument("--rounds", type=int, default=2, help="rounds, each case alternating old and new (default 2)")
    parser.add_argument("--only", type=lambda s: s.split(","), help="cases whose names contain one of NAME,NAME (spheres always run)")
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error(f"--rounds {args.rounds}: at least 1")
    for binary in filter(None, (args.old, args.new, args.peer)):
        if not os.access(binary, os.X_OK):
            parser.error(f"{binary}: not an executable file")
    old, new, peer_bin, rounds, only = args.old, args.new, args.peer, args.rounds, args.only
    print("| case | binary | τ_c CPU (µs) | / spheres | distance calls/coll. | NR it./solve "
          "| distance fallbacks (per 10⁵) | contact fallbacks | overlaps / failures | Z | init ms/body |")
    print("|---|---|---:|---:|---:|---:|---|---:|---|---|---:|")
    for rnd in range(rounds):
        sphere_tau = {}
        for name, spec in CASES:
            if only and not any(o in name for o in only) and name != CASES[0][0]:
                continue
            order = [("old", old), ("new", new)] if rnd % 2 == 0 else [("new", new), ("old", old)]
            for side, binary in order:
                r = run(binary, spec)
                if name == CASES[0][0] and "error" not in r:
                    sphere_tau[side] = r["tau_c_cpu_us"]
                print(line(name, f"{side} (round {rnd + 1})", spec, r, sphere_tau.get(side)), flush=True)
        if peer_bin:
            p = peer(peer_bin)
            print(f"| spheres φ 0.5, peer | md-single (round {rnd + 1}) | {p['tau_c_us']:.3f} | | | | | | | {p['z']:.3f} | |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
