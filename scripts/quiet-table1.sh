#!/usr/bin/env bash
# Is Table 1 unchanged by the timing protocol on a quiet machine? Runs deploy/plans/quick.toml
# with two binaries, one after the other, and prints each (R*, precision, algorithm) row's
# ns/check from both (each binary reports its own database) and their ratio.
#
#   /work/bin/quiet scripts/quiet-table1.sh NEW_SWEEP OLD_SWEEP OUT_DIR
set -euo pipefail
new=$(realpath "$1"); old=$(realpath "$2"); out=$3
plan=$(cd "$(dirname "$0")/.." && pwd)/deploy/plans/quick.toml
mkdir -p "$out"
for which in old new; do
  binary=$old; [ "$which" = new ] && binary=$new
  rm -f "$out/$which.db"*
  t0=$(date +%s.%N)
  "$binary" run "$plan" --db "$out/$which.db" --cores 0,1 --format json > "$out/$which.log" 2>&1
  echo "$which wall_s $(echo "$(date +%s.%N) - $t0" | bc)"
  "$binary" report table1 --db "$out/$which.db" --format json > "$out/$which-table1.json"
  "$binary" report table2 --db "$out/$which.db" --format json > "$out/$which-table2.json"
done
python3 - "$out" <<'PY'
import json, os, sys
out = sys.argv[1]
rows = lambda w: {(r["r_star"], r["precision"], r["algorithm"]): r["ns_per_check"]
                  for t in ("table1", "table2")
                  for r in json.load(open(os.path.join(out, f"{w}-{t}.json")))}
old, new = rows("old"), rows("new")
ratios = []
print("r_star precision algorithm  old_ns  new_ns  new/old")
for key in sorted(old):
    ratios.append(new[key] / old[key])
    print(f"{key[0]:6} {key[1]:9} {key[2]:10} {old[key]:7.2f} {new[key]:7.2f}  {ratios[-1]:.3f}")
ratios.sort()
print(f"new/old over {len(ratios)} rows: median {ratios[len(ratios) // 2]:.3f}, "
      f"range {ratios[0]:.3f}-{ratios[-1]:.3f}")
PY
