#!/usr/bin/env python3
"""Issue 30's measurements of mixtures (MEASUREMENTS.md, "Sphere mixtures").

usage: mixtures.py physics SCENE_BIN            Z of binary mixtures and polydisperse spheres
       mixtures.py cost SCENE_BIN [OLD_BIN]     tau_c of one size, the mixture path, ratio 2
       mixtures.py peer SWEEP_BIN PEER_BIN      polydisperse spheres against Smallenburg's EDMD
       mixtures.py rigid SCENE_BIN              rigid mixtures against their pure systems

SCENE_BIN is `cargo build --release -p edmd --example scene`'s binary (target/release/examples/
scene); OLD_BIN the same example built before species existed, run interleaved with it.
SWEEP_BIN is target/release/sweep; PEER_BIN deploy/peers/build-smallenburg.sh's md-single-file.
The peer starts from our final configuration of the same scene (`sweep edmd --dump`), lengths
divided by the largest diameter (its cells are 1.5 long), with unit masses and its own random
velocities: Z is the same (it does not depend on the masses), and tau_c is the CPU time per
collision on either side (ours with masses ∝ σ³, which changes the dynamics but not the
statistics of the configurations).
BMCSL: Mansoori et al., J. Chem. Phys. 54, 1523 (1971), from the moments of the diameters.
"""
import json
import math
import subprocess
import sys


def run(binary, keys):
    out = subprocess.run([binary] + keys, check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def species(*spec):
    """spec: (diameter, fraction, polydispersity) per species."""
    parts = [
        f'{{shape="sphere", diameter={d}, fraction={x}, polydispersity={p}}}' for d, x, p in spec
    ]
    return "species=[" + ", ".join(parts) + "]"


def bmcsl(eta, xi):
    _, x1, x2, x3 = xi
    e = 1.0 - eta
    return 1 / e + 3 * x1 * x2 * eta / (x3 * e * e) + x2**3 * eta * eta * (3 - eta) / (x3 * x3 * e**3)


# Variance of a standard normal truncated at ±3: 1 - 6 φ(3) / (2 Φ(3) - 1).
TRUNC_VAR = 1 - 6 * math.exp(-4.5) / math.sqrt(2 * math.pi) / math.erf(3 / math.sqrt(2))


def moments(spec):
    """ξ_k of the population (diameters σ_i (1 + δ g), g truncated at ±3: symmetric, so the
    third central moment vanishes)."""
    xi = [0.0] * 4
    for d, x, p in spec:
        s2 = (p * d) ** 2 * TRUNC_VAR
        m = [1.0, d, d * d + s2, d**3 + 3 * d * s2]
        for k in range(4):
            xi[k] += x * m[k]
    return xi


def physics(binary):
    n, coll, eq = 4000, 2_000_000, 400_000
    cases = [((1.0, 0.5, 0), (r, 0.5, 0)) for r in (1.4, 2.0)]
    cases += [((1.0, 1.0, p),) for p in (0.08, 0.12)]
    print("| mixture | φ | Z | ± | BMCSL | dev (%) | overlaps | drift | τ_c (µs) | collisions 11 / 12 / 22 |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for spec in cases:
        for phi in (0.3, 0.4, 0.45):
            r = run(binary, ['shape="sphere"', f"n={n}", f"phi={phi}", f"collisions={coll}",
                             f"equilibrate={eq}", species(*spec)])
            z = bmcsl(phi, moments(spec))
            pairs = " / ".join(str(p["collisions"]) for p in r["species"]["pairs"])
            name = (f"σ2/σ1 = {spec[1][0]}, x = 0.5" if len(spec) == 2
                    else f"polydisperse δ = {spec[0][2]}")
            print(f"| {name} | {phi} | {r['pressure_z']:.4f} | {r['pressure_z_err']:.4f} | {z:.4f} | "
                  f"{100 * (r['pressure_z'] / z - 1):+.2f} | {r['overlaps']} | {r['energy_drift_rel']:.1e} | "
                  f"{r['tau_c_us']:.3f} | {pairs} |", flush=True)


def cost(binary, old):
    n, coll, eq = 4000, 1_000_000, 100_000
    base = ['shape="sphere"', f"n={n}", "phi=0.45", f"collisions={coll}", f"equilibrate={eq}"]
    variants = [("one size", binary, [])]
    if old:
        variants.insert(0, ("one size, before species", old, []))
    variants += [
        ("two species of one size (mixture path)", binary, [species((1, 0.5, 0), (1, 0.5, 0))]),
        ("σ2/σ1 = 2, x = 0.5", binary, [species((1, 0.5, 0), (2, 0.5, 0))]),
    ]
    ratio2_wide = ("σ2/σ1 = 2, x = 0.5, Δ_NNL = 0.5", binary,
                   [species((1, 0.5, 0), (2, 0.5, 0)), "delta_nnl=0.5"])
    for nb in ("nnl", "ll"):
        keys = base + [f'neighbours="{nb}"'] + (["delta_nnl=0.15"] if nb == "ll" else [])
        variants = [v for v in variants if v is not ratio2_wide] + ([ratio2_wide] if nb == "nnl" else [])
        times = {name: [] for name, _, _ in variants}
        extra = {}
        for _ in range(3):
            for name, b, more in variants:
                r = run(b, keys + more)
                times[name].append((r["tau_c_us"], r["tau_c_cpu_us"]))
                extra[name] = (r["pressure_z"], r["nnl_rebuilds"] / coll, r["overlaps"])
        for name, _, _ in variants:
            wall = ", ".join(f"{w:.3f}" for w, _ in times[name])
            cpu = min(c for _, c in times[name])
            z, rebuilds, overlaps = extra[name]
            print(f"| {nb} | {name} | {wall} | {cpu:.3f} | {z:.3f} | {rebuilds:.3f} | {overlaps} |", flush=True)


def rigid(binary, rounds=3, n=1000, coll=100_000):
    """Ellipsoid X0 0.5 + 2 and sphere + ellipsoid X0 2 mixtures beside their pure systems,
    alternated rounds; per pair of species the distance calls per collision."""
    base = [f"n={n}", "phi=0.4", 'neighbours="nnl"', "delta_nnl=0.15", f"collisions={coll}",
            f"equilibrate={coll // 5}", "seed=1"]
    ell = lambda x0: f'{{shape="ellipsoid", x0={x0}, fraction=0.5}}'
    cases = [
        ("spheres (sphere path)", ['shape="sphere"']),
        ("spheres as rigid ellipsoids of X0 = 1", ['shape="ellipsoid"', "x0=1.0"]),
        ("ellipsoids X0 = 0.5", ['shape="ellipsoid"', "x0=0.5"]),
        ("ellipsoids X0 = 2", ['shape="ellipsoid"', "x0=2.0"]),
        ("X0 = 0.5 and 2, x = 0.5", [f"species=[{ell(0.5)}, {ell(2.0)}]"]),
        ("spheres and X0 = 2, x = 0.5", [f'species=[{{shape="sphere", fraction=0.5}}, {ell(2.0)}]']),
    ]
    runs = {name: [] for name, _ in cases}
    for _ in range(rounds):
        for name, keys in cases:
            runs[name].append(run(binary, base + keys))
    for name, rs in runs.items():
        r = rs[0]
        cpu = ", ".join(f"{x['tau_c_cpu_us']:.2f}" for x in rs)
        pairs = " / ".join(f"{p['distance_calls'] / max(p['collisions'], 1):.2f}"
                           for p in (r.get("species") or {}).get("pairs", []))
        print(f"| {name} | {cpu} | {r['pressure_z']:.3f} | {r['pressure_z_err']:.3f} | "
              f"{max(x['energy_drift_rel'] for x in rs):.1e} | {sum(x['overlaps'] for x in rs)} | "
              f"{sum(x['solver_failures'] for x in rs)} | {r['distance_calls_per_collision']:.2f} | {pairs} |",
              flush=True)


def peer(sweep, md, phi=0.45):
    import os
    import tempfile

    work = tempfile.mkdtemp(prefix="mixtures-peer-")
    print("| δ | N | ours Z | ± | peer Z (2 seeds) | BMCSL | ours τ_c CPU (µs) | peer τ_c CPU (µs) | ratio | collisions ours / peer |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for delta in (0.08, 0.12):
        for n in (4000, 32000):
            coll = 500 * n if n <= 4000 else 125 * n
            scene = os.path.join(work, "scene.toml")
            with open(scene, "w") as f:
                f.write(f"n = {n}\nphi = {phi}\ncollisions = {coll}\nequilibrate = {coll // 5}\n"
                        f'[[species]]\nshape = "sphere"\nfraction = 1.0\npolydispersity = {delta}\n')
            dump = os.path.join(work, "final.json")
            out = subprocess.run([sweep, "edmd", scene, "--dump", dump, "--format", "json"],
                                 check=True, capture_output=True, text=True).stdout
            ours = json.loads(out)
            with open(dump) as f:
                state = json.load(f)
            radii = [p["semi_axes"][0] for p in state["particles"]]
            k = 1.0 / (2 * max(radii))
            init = os.path.join(work, "init.sph")
            with open(init, "w") as f:
                f.write(f"{n}\n" + " ".join(f"{x * k:.15f}" for x in state["box"]) + "\n")
                for p, r in zip(state["particles"], radii):
                    x, y, z = (c * k for c in p["position"])
                    f.write(f"a {x:.15f} {y:.15f} {z:.15f} {r * k:.15f}\n")
            # Time for about `coll` collisions, from a short run's rate.
            probe = json.loads(subprocess.run([md, init, "0.5", "0.5", "1"], check=True,
                                              capture_output=True, text=True).stdout.splitlines()[-1])
            time = coll / probe["collisions"] * 0.5
            theirs = [json.loads(subprocess.run([md, init, f"{time / 5}", f"{time}", str(seed)], check=True,
                                                capture_output=True, text=True).stdout.splitlines()[-1])
                      for seed in (1, 2)]
            zs = [t["z"] for t in theirs]
            z_bmcsl = bmcsl(phi, moments(((1.0, 1.0, delta),)))
            tau_peer = sum(t["tau_c_us"] for t in theirs) / 2
            print(f"| {delta} | {n} | {ours['pressure_z']:.4f} | {ours['pressure_z_err']:.4f} | "
                  f"{zs[0]:.4f}, {zs[1]:.4f} | {z_bmcsl:.4f} | {ours['tau_c_cpu_us']:.3f} | {tau_peer:.3f} | "
                  f"{ours['tau_c_cpu_us'] / tau_peer:.2f} | {ours['collisions']} / {theirs[0]['collisions']} |",
                  flush=True)


if __name__ == "__main__":
    what, binary = sys.argv[1], sys.argv[2]
    if what == "physics":
        physics(binary)
    elif what == "peer":
        peer(binary, sys.argv[3])
    elif what == "rigid":
        rigid(binary)
    else:
        cost(binary, sys.argv[3] if len(sys.argv) > 3 else None)
