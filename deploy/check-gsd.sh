#!/usr/bin/env bash
# The trajectories of `sweep edmd --trajectory` read by the `gsd` Python package (HOOMD's own
# reader): installs it in a venv under target/ (skipped, saying so, when pip cannot reach an
# index), runs an ellipsoid and a superquadric scene with a trajectory and a dump of the final
# state, and compares the last frame with the dump (deploy/check-gsd.py).
# Usage: deploy/check-gsd.sh path/to/sweep
set -euo pipefail
sweep=$(realpath "$1")
cd "$(dirname "$0")/.."
venv=target/pyenv
if [[ ! -x $venv/bin/python ]] || ! "$venv/bin/python" -c 'import gsd.hoomd, numpy' 2> /dev/null; then
    if ! command -v python3 > /dev/null || ! python3 -m venv "$venv"; then
        echo "check-gsd: SKIPPED: no python3 with venv on this machine"
        exit 0
    fi
    if ! "$venv/bin/pip" install -q gsd numpy; then
        echo "check-gsd: SKIPPED: pip could not install the gsd package (no package index reachable?)"
        exit 0
    fi
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$work/ellipsoids.toml" << 'SCENE'
shape = "ellipsoid"
n = 512
phi = 0.5
x0 = 2.0
equilibrate = 0
collisions = 20000
SCENE
cat > "$work/superquadrics.toml" << 'SCENE'
shape = "superquadric"
n = 256
phi = 0.3
x0 = 2.0
exponents = [2.0, 2.0, 4.0]
equilibrate = 0
collisions = 5000
SCENE
for scene in ellipsoids superquadrics; do
    "$sweep" edmd "$work/$scene.toml" --trajectory "$work/$scene.gsd" --every 2500 \
        --dump "$work/$scene.json" --format json > /dev/null
done
"$venv/bin/python" deploy/check-gsd.py "$work/ellipsoids.gsd" "$work/ellipsoids.json" 9
"$venv/bin/python" deploy/check-gsd.py "$work/superquadrics.gsd" "$work/superquadrics.json" 3
