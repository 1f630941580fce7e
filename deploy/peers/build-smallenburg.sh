#!/bin/sh
# Builds Smallenburg's published hard-sphere EDMD ("Single" variant) as a `sweep` program job:
# target/peers/smallenburg/md-single (see smallenburg-main.c for its arguments and output), and
# md-single-file, the same started from a configuration file (smallenburg-file-main.c).
#
# The peer's code is not part of this repository: it is copied from PEER (default
# ../shared/peers/smallenburg-edmd beside the repository) into the build folder, where its main()
# is renamed and init()'s fixed seed replaced by ours; nothing else of it changes.
#
# usage: deploy/peers/build-smallenburg.sh [PEER_DIR]
set -eu
repo=$(cd "$(dirname "$0")/../.." && pwd)
peer=${1:-$repo/../shared/peers/smallenburg-edmd}
out=$repo/target/peers/smallenburg
[ -f "$peer/mdSingle.c" ] || { echo "no mdSingle.c in $peer" >&2; exit 1; }
mkdir -p "$out"
cp "$peer/mdSingle.c" "$peer/mdSingle.h" "$peer/mt19937ar.c" "$out/"
chmod u+w "$out"/*
sed -i \
    -e 's/^int main()$/int peer_main()/' \
    -e 's/unsigned long seed = 1;/unsigned long seed = sweep_seed;/' \
    "$out/mdSingle.c"
grep -q '^int peer_main()$' "$out/mdSingle.c" || { echo "main() not found: another version?" >&2; exit 1; }
grep -q 'seed = sweep_seed;' "$out/mdSingle.c" || { echo "the seed not found: another version?" >&2; exit 1; }
cp "$repo/deploy/peers/smallenburg-main.c" "$repo/deploy/peers/smallenburg-file-main.c" \
    "$repo/deploy/peers/smallenburg-clock.h" "$repo/deploy/peers/smallenburg-run.h" "$out/"
gcc -O3 -ffast-math -funroll-loops -march=native -w -I"$out" \
    "$out/smallenburg-main.c" -o "$out/md-single" -lm
# The same peer started from a configuration file with radii (polydisperse spheres, mixtures),
# with room for 48 neighbours instead of 24 (as its "Too many neighbors. Increase MAXNEIGH."
# asks: a small sphere among 12 % polydisperse ones at φ = 0.45 has more than 24).
sed -e 's/^#define MAXNEIGH 24$/#define MAXNEIGH 48/' "$out/mdSingle.c" > "$out/mdSingle-file.c"
grep -q '^#define MAXNEIGH 48$' "$out/mdSingle-file.c" || { echo "MAXNEIGH not found: another version?" >&2; exit 1; }
gcc -O3 -ffast-math -funroll-loops -march=native -w -I"$out" \
    "$out/smallenburg-file-main.c" -o "$out/md-single-file" -lm
echo "$out/md-single"
