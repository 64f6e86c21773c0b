#!/usr/bin/env bash
# GPU time per step with and without collisions, kernel by kernel (Nsight Compute's durations, so
# the dynamics of the run do not enter as they do in the differences of scripts/collision-cost.sh):
# the demo scene (seed 1) at LEVELS levels, the finest level run for 60 iterations; the last
# STEPS steps' kernels of each run are timed. EVERY: values of the collision force's
# full_search_every to measure. Needs ncu (CUDA toolkit) on the GPU machine. docs/benchmarks.md.
# MAKE_SCENE_ARGS: more sinew-make-scene options (e.g. another --structures list); SCHEDULE:
# iterations per level instead (the finest level must run more than STEPS); MASS_FLOOR: every
# structure's mass_floor; RUN: another sinew-run to time (an older build's, side by side); HOLD:
# the collision force's hold_mm (-1: the pull alone); NCU_ARGS: more ncu options (e.g.
# "--cache-control none --clock-control none": warm caches and the GPU's own clocks, nearer what a
# run sees; by default ncu flushes the caches before each kernel and locks the base clock).
# Usage: bash scripts/collision-kernel-time.sh BUILD_DIR OUT_DIR [LEVELS=3]
set -euo pipefail
cd "$(dirname "$0")/.."
build="$1"; out="$2"; levels="${3:-3}"; steps="${STEPS:-20}"
t=/usr/share/mricron/templates
schedules=("" "" "" "150,80" "150,80,30" "150,80,30,20")
mkdir -p "$out"
echo "| levels | finest vertices | collisions | kernels per step | GPU ms per step | collision kernels ms | ratio to without | overlap at the end (mm^3) | mean ASSD (mm) |"
echo "| ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |"
base=""
for c in off $(for k in ${EVERY:-1 4}; do echo "every$k"; done); do
  d="$out/$c"
  weight=1; [ "$c" = off ] && weight=0
  "$build/app/sinew-make-scene" --atlas "$t/aal.nii.gz" --labels "$t/aal.nii.txt" --training "$t/ch2better.nii.gz" \
    --target "$t/ch2.nii.gz" --seed 1 --iterations "${SCHEDULE:-${schedules[$levels]},60}" --collision-weight "$weight" ${MAKE_SCENE_ARGS:-} -o "$d/scene.json" >/dev/null
  python3 - "$d/scene.json" "${c#every}" "${MASS_FLOOR:-}" "${HOLD:-}" <<'PY'
import json, sys
p, every, floor, hold = sys.argv[1:]
j = json.load(open(p))
if every != "off": j["forces"]["collision"]["full_search_every"] = int(every)
if every != "off" and hold: j["forces"]["collision"]["hold_mm"] = float(hold)
for s in j["structures"]:
    if floor: s["mass_floor"] = float(floor)
json.dump(j, open(p, "w"), indent=1)
PY
  # Every kernel of the run, then the last `steps` steps' worth (a step starts with vertexGeometry).
  ncu --csv ${NCU_ARGS:-} --metrics gpu__time_duration.sum "${RUN:-$build/app/sinew-run}" "$d/scene.json" -o "$d/run" -q --backend cuda \
    > "$d/ncu.csv" 2>/dev/null || true
  python3 - "$d/ncu.csv" "$d/run/report.json" "$levels" "$c" "$steps" "${base:-0}" > "$d/row.txt" <<'PY'
import csv, json, sys
path, report, levels, label, steps, base = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], int(sys.argv[5]), float(sys.argv[6])
rows = [r for r in csv.reader(l for l in open(path) if l.startswith('"'))]
head, rows = rows[0], rows[1:]
k, m, v = head.index("Kernel Name"), head.index("Metric Name"), head.index("Metric Value")
kernels = [(r[k], float(r[v].replace(",", ""))) for r in rows if r[m] == "gpu__time_duration.sum"]
starts = [i for i, (name, _) in enumerate(kernels) if "vertexGeometry" in name]
window = kernels[starts[-steps - 1]:starts[-1]]  # the last full steps (the final one may be cut by a sample)
total = sum(t for _, t in window) / steps / 1e6  # ns -> ms
# The collision refit takes the BvhView (`refit` before 2026-11-25; since, `climbRefit` or
# `vertexBoxes` and `nodeBoxes`); the sampled error has a refit of its own.
# Since 2026-11-28 the response's force is added by addCollisionForce, or, where the collision is
# the last force, with the move and the hold by addMoveAndHold (counted here, the move with it).
coll = sum(t for n, t in window if "respond" in n or "Boxes" in n or "advance" in n or "holdOut" in n
           or "addCollisionForce" in n or "addMoveAndHold" in n
           or ("efit" in n and "BvhView" in n)) / steps / 1e6
r = json.load(open(report))
verts = sum(s["vertices"] for s in r["structures"])
assd = sum(s["assd_mm"]["final"] for s in r["structures"]) / len(r["structures"])
ratio = f"{total / base:.2f}" if base > 0 else "1"
print(f"| {levels} | {verts} | {label} | {len(window) // steps} | {total:.4f} | {coll:.4f} | {ratio} | "
      f"{r['overlaps']['total_after_mm3']:.1f} | {assd:.3f} |")
open(path.replace("ncu.csv", "total.txt"), "w").write(f"{total}\n")
by = {}
for n, t in window:
    name = n.split("(")[0].split("<")[0]  # the kernel's name without template arguments or parameters
    by[name] = by.get(name, 0.0) + t / steps / 1e3
open(path.replace("ncu.csv", "kernels.txt"), "w").write(", ".join(f"{n} {t:.1f} us" for n, t in sorted(by.items(), key=lambda kv: -kv[1])) + "\n")
PY
  cat "$d/row.txt"
  if [ "$c" = off ]; then base=$(cat "$d/total.txt"); fi
done
