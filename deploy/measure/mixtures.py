#!/usr/bin/env python3
"""Issue 30's measurements of sphere mixtures (MEASUREMENTS.md, "Sphere mixtures").

usage: mixtures.py physics SCENE_BIN            Z of binary mixtures and polydisperse spheres
       mixtures.py cost SCENE_BIN [OLD_BIN]     tau_c of one size, the mixture path, ratio 2

SCENE_BIN is `cargo build --release -p edmd --example scene`'s binary (target/release/examples/
scene); OLD_BIN the same example built before species existed, run interleaved with it.
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
    for nb in ("nnl", "ll"):
        keys = base + [f'neighbours="{nb}"'] + (["delta_nnl=0.15"] if nb == "ll" else [])
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


if __name__ == "__main__":
    what, binary = sys.argv[1], sys.argv[2]
    if what == "physics":
        physics(binary)
    else:
        cost(binary, sys.argv[3] if len(sys.argv) > 3 else None)
