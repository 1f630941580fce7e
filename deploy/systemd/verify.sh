#!/usr/bin/env bash
# Offline checks of the systemd units, in a throw-away root (the units, this machine's system
# units, and the sweep binary at the path ExecStart names), no running systemd needed:
#   1. `systemd-analyze verify`: fails on any message, since it only warns (exit 0) on an unknown key;
#   2. `systemd-analyze security --offline`: the exposure score of each unit, at most 2.0 of 10.
# Usage: deploy/systemd/verify.sh [path/to/sweep]   (default: target/release/sweep)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
sweep=${1:-$here/../../target/release/sweep}
[[ -x $sweep ]] || { echo "no sweep binary at $sweep" >&2; exit 2; }

root=$(mktemp -d)
trap 'rm -rf "$root"' EXIT
mkdir -p "$root/etc/systemd/system" "$root/usr/lib/systemd" "$root/usr/local/bin"
cp -a /lib/systemd/system "$root/usr/lib/systemd/"
cp "$here"/*.service "$root/etc/systemd/system/"
cp "$sweep" "$root/usr/local/bin/sweep"

units=(sweep-coordinator.service sweep-worker.service)
messages=$(cd "$root" && systemd-analyze verify --root="$root" --man=no "${units[@]/#/etc/systemd/system/}" 2>&1) || {
    echo "$messages"; exit 1; }
[[ -z $messages ]] || { echo "systemd-analyze verify:"; echo "$messages"; exit 1; }
echo "systemd-analyze verify: ${units[*]}: no message"
for unit in "${units[@]}"; do
    systemd-analyze security --offline=true --threshold=20 --root="$root" "$root/etc/systemd/system/$unit" 2>&1 | tail -1
done
