#!/usr/bin/env python3
"""Reads a `sweep edmd --trajectory` file with the `gsd` package (HOOMD's reader) and checks
its last frame against the run's own `--dump` of the final state: positions (GSD's are wrapped
into a box centred on the origin, ours into [0, L)), unwrapped positions through the images,
and orientations (the quaternion's rotated x, y, z axes against the dump's body axes).

Usage: check-gsd.py TRAJECTORY.gsd DUMP.json [EXPECTED_FRAMES]
Prints the frame count, the types and the shapes; exits non-zero on any mismatch."""

import json
import sys

import gsd.hoomd
import numpy as np


def rotate(q, v):
    """The vectors v (n x 3) rotated by the unit quaternions q (n x 4, w x y z)."""
    w, u = q[:, :1], q[:, 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def main():
    path, dump_path = sys.argv[1], sys.argv[2]
    dump = json.load(open(dump_path))
    with gsd.hoomd.open(path, "r") as traj:
        frames = len(traj)
        first, last = traj[0], traj[frames - 1]
        print(f"{path}: {frames} frames, steps {first.configuration.step}..{last.configuration.step}")
        print(f"types {first.particles.types}, N {last.particles.N}")
        for shape in first.particles.type_shapes:
            summary = {k: (f"{len(v)} vertices" if k == "vertices" else v) for k, v in shape.items()}
            print(f"type_shapes {summary}")
        if len(sys.argv) > 3 and frames != int(sys.argv[3]):
            sys.exit(f"expected {sys.argv[3]} frames, found {frames}")
        box = last.configuration.box
        l = dump["box"][0]
        assert abs(box[0] - l) < 1e-5 * l, (box, l)
        parts = dump["particles"]
        n = len(parts)
        assert last.particles.N == n, (last.particles.N, n)
        ours = np.array([p["position"] for p in parts])
        pos = last.particles.position.astype(np.float64)
        img = last.particles.image.astype(np.float64)
        assert np.all(np.abs(pos) <= 0.5 * l * (1 + 1e-6)), "positions outside the box"
        # Wrapped positions, compared modulo L (a body on the face may wrap either way in f32).
        d = (pos + 0.5 * l) - ours
        d -= l * np.round(d / l)
        err_pos = np.abs(d).max()
        unwrapped = pos + img * l + 0.5 * l
        d2 = unwrapped - ours
        assert np.allclose(d2 / l, np.round(d2 / l), atol=1e-5), "images do not unwrap"
        q = last.particles.orientation.astype(np.float64)
        assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6)
        axes = np.array([p["orientation"] for p in parts])  # rows = body axes
        err_rot = 0.0
        for k in range(3):
            e = np.zeros((n, 3))
            e[:, k] = 1.0
            err_rot = max(err_rot, np.abs(rotate(q, e) - axes[:, k, :]).max())
        vel = last.particles.velocity.astype(np.float64)
        err_vel = np.abs(vel - np.array([p["velocity"] for p in parts])).max()
        print(f"max |Δposition| {err_pos:.2e}, max |Δaxis| {err_rot:.2e}, max |Δvelocity| {err_vel:.2e}")
        if not (err_pos < 1e-5 * l and err_rot < 1e-5 and err_vel < 1e-4):
            sys.exit("the trajectory's last frame is not the dumped final state")
    print("gsd check: ok")


if __name__ == "__main__":
    main()
