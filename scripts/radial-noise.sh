#!/usr/bin/env bash
# The radial force against image noise (docs/medial.md): new subjects made from Colin27 with Rician
# noise (sigma NOISE of the image range, default 0.05), segmented twice with the same model and
# scene, without and with the force `radial` on the tubular structures (caudate, hippocampus;
# weight WEIGHT, default 0.3), and the final ASSD of each compared. SHAPE_PRIOR=w sets the shape
# prior's weight in both scenes (default: as sinew-make-scene writes it).
# Usage: bash scripts/radial-noise.sh [BUILD_DIR] [OUT_DIR] [SEEDS...]
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
out="${2:-radial-noise-output}"
shift $(( $# < 2 ? $# : 2 ))
seeds=("$@")
((${#seeds[@]})) || seeds=(401 402 403)
noise=${NOISE:-0.05}
weight=${WEIGHT:-0.3}
t=/usr/share/mricron/templates
app="$build/app"
mkdir -p "$out"
[ -f "$out/model/model.json" ] || "$app/sinew-build-model" --atlas "$t/aal.nii.gz" --labels "$t/aal.nii.txt" \
  --training "$t/ch2better.nii.gz" -o "$out/model" -q
for seed in "${seeds[@]}"; do
  s="$out/subject-$seed"
  [ -f "$s/image.nii.gz" ] || "$app/sinew-make-subject" --image "$t/ch2.nii.gz" --labels "$t/aal.nii.gz" --seed "$seed" \
    --noise "$noise" -o "$s" >/dev/null
  "$app/sinew-make-scene" --model "$out/model" --target "$s/image.nii.gz" --ground-truth "$s/labels.nii.gz" \
    -o "$s/scene.json" 2>/dev/null
  # The same scene with the force on the tubular structures (scene-wide weight 0, per-structure 0.3).
  python3 - "$s/scene.json" "$s/scene-radial.json" "$weight" "${SHAPE_PRIOR:-}" <<'PY'
import json, sys
scene = json.load(open(sys.argv[1]))
if sys.argv[4]:
    scene["forces"]["shape_prior"]["weight"] = float(sys.argv[4])
    json.dump(scene, open(sys.argv[1], "w"), indent=1)
scene["forces"]["radial"] = {"weight": 0.0}
for s in scene["structures"]:
    if s["name"].startswith(("Caudate", "Hippocampus")):
        s.setdefault("forces", {})["radial"] = {"weight": float(sys.argv[3])}
json.dump(scene, open(sys.argv[2], "w"), indent=1)
PY
  "$app/sinew-run" "$s/scene.json" -o "$s/run-plain" -q --backend cpu >/dev/null
  "$app/sinew-run" "$s/scene-radial.json" -o "$s/run-radial" -q --backend cpu >/dev/null
done
python3 - "$out" "${seeds[@]}" <<'PY'
import json, sys
out, seeds = sys.argv[1], sys.argv[2:]
rows = {}
for seed in seeds:
    for run in ("plain", "radial"):
        report = json.load(open(f"{out}/subject-{seed}/run-{run}/report.json"))
        for s in report["structures"]:
            rows.setdefault(s["name"], {}).setdefault(run, []).append(s["assd_mm"]["final"])
print(f"| structure | ASSD without radial (mm) | with radial (mm) | change |")
print("| --- | ---: | ---: | ---: |")
for name, r in rows.items():
    a, b = sum(r["plain"]) / len(r["plain"]), sum(r["radial"]) / len(r["radial"])
    mark = " (radial)" if name.startswith(("Caudate", "Hippocampus")) else ""
    print(f"| {name}{mark} | {a:.3f} | {b:.3f} | {100 * (b - a) / a:+.1f} % |")
PY
