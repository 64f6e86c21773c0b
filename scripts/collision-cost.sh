#!/usr/bin/env bash
# What collisions cost on real data: the Colin27 demo scene (seed 1, 12 structures) at 3 to N
# levels of detail (the finest about 20 k vertices at 3 levels, x4 per level), run by sinew-run with
# and without the collision force on one backend, the finest level run for 10 and for 60
# iterations. The difference of the two gives the cost of a step; what is left of the 10-iteration
# run is the level's fixed cost (for collisions: the trees built, the check for a structure inside
# another, the first, unbounded, search). Also the overlap at the end and the mean ASSD (10
# iterations). docs/benchmarks.md.
# Usage: bash scripts/collision-cost.sh [BUILD_DIR] [OUT_DIR] [BACKEND] [MAX_LEVELS=5]
# EVERY="1 4" measures each value of the collision force's full_search_every (a row each).
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
out="${2:-collision-cost}"
backend="${3:-cpu}"
maxLevels="${4:-5}"
t=/usr/share/mricron/templates
mkdir -p "$out"
schedules=("150,80" "150,80,30" "150,80,30,20" "150,80,30,20,10")
every="${EVERY:-1}"
echo "| levels | finest vertices | full search every | ms/step without | with collisions | ratio | fixed cost of collisions per level (ms) | overlap without -> with (mm^3) | mean ASSD without -> with (mm) |"
echo "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |"
for s in "${schedules[@]}"; do
  levels=$(( $(tr -cd ',' <<< "$s" | wc -c) + 2 ))
  (( levels <= maxLevels )) || break
  for c in off $(for k in $every; do echo on$k; done); do
    weight=1; [ "$c" = off ] && weight=0
    for n in 10 60; do
      d="$out/levels-$levels-$c-$n"
      "$build/app/sinew-make-scene" --atlas "$t/aal.nii.gz" --labels "$t/aal.nii.txt" --training "$t/ch2better.nii.gz" \
        --target "$t/ch2.nii.gz" --seed 1 --iterations "$s,$n" --collision-weight "$weight" -o "$d/scene.json" >/dev/null
      if [ "$c" != off ]; then
        python3 -c 'import json,sys; p=sys.argv[1]; j=json.load(open(p)); j["forces"]["collision"]["full_search_every"]=int(sys.argv[2]); json.dump(j,open(p,"w"),indent=1)' "$d/scene.json" "${c#on}"
      fi
      "$build/app/sinew-run" "$d/scene.json" -o "$d/run" -q --backend "$backend" >/dev/null
    done
  done
  python3 - "$out/levels-$levels" "$levels" $every <<'PY'
import json, sys
base, levels, everies = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
def load(c, n):
    r = json.load(open(f"{base}-{c}-{n}/run/report.json"))
    st = r["structures"]
    finest = [x for x in r["stages"] if x["name"] == f"level {levels - 1}"][0]["seconds"]
    return 1e3 * finest, sum(x["vertices"] for x in st), r["overlaps"]["total_after_mm3"], sum(x["assd_mm"]["final"] for x in st) / len(st)
off10, off60 = load("off", 10), load("off", 60)
step_off = (off60[0] - off10[0]) / 50
for k in everies:
    on10, on60 = load(f"on{k}", 10), load(f"on{k}", 60)
    step_on = (on60[0] - on10[0]) / 50
    fixed = (on10[0] - 10 * step_on) - (off10[0] - 10 * step_off)
    print(f"| {levels} | {on10[1]} | {k} | {step_off:.3f} | {step_on:.3f} | {step_on / step_off:.2f} | {fixed:.1f} | "
          f"{off10[2]:.1f} -> {on10[2]:.1f} | {off10[3]:.3f} -> {on10[3]:.3f} |")
PY
done
