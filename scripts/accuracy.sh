#!/usr/bin/env bash
# The new-subject accuracy protocol of docs/accuracy.md: one model built from Colin27's atlas
# (aal.nii.gz on ch2better.nii.gz), new subjects made from ch2.nii.gz by sinew-make-subject (seeded
# warp, affine, bias, contrast, noise), each segmented as a user would (sinew-make-scene --model,
# initialised by registration) and scored against its own moved labels.
# Usage: [INIT=bspline|affine|rigid] bash scripts/accuracy.sh [BUILD_DIR] [OUT_DIR] [BACKEND] [SEEDS...]
# INIT: sinew-make-scene's --initialise (default: its own, "bspline"); its runs go to run-BACKEND-INIT.
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
out="${2:-accuracy-output}"
backend="${3:-cpu}"
shift $(( $# < 3 ? $# : 3 ))
seeds=("$@")
((${#seeds[@]})) || seeds=(201 202 203 204 205)
t=/usr/share/mricron/templates
app="$build/app"
mkdir -p "$out"
[ -f "$out/model/model.json" ] || "$app/sinew-build-model" --atlas "$t/aal.nii.gz" --labels "$t/aal.nii.txt" \
  --training "$t/ch2better.nii.gz" -o "$out/model" -q
for seed in "${seeds[@]}"; do
  s="$out/subject-$seed"
  [ -f "$s/image.nii.gz" ] || "$app/sinew-make-subject" --image "$t/ch2.nii.gz" --labels "$t/aal.nii.gz" --seed "$seed" -o "$s"
  "$app/sinew-make-scene" --model "$out/model" --target "$s/image.nii.gz" --ground-truth "$s/labels.nii.gz" \
    ${INIT:+--initialise "$INIT"} -o "$s/scene${INIT:+-$INIT}.json" 2>/dev/null
  "$app/sinew-run" "$s/scene${INIT:+-$INIT}.json" -o "$s/run-$backend${INIT:+-$INIT}" -q --backend "$backend"
done
python3 scripts/accuracy_table.py "$out" "$backend${INIT:+-$INIT}" "${seeds[@]}"
