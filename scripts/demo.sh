#!/usr/bin/env bash
# The main job: segment the 12 AAL subcortical structures of Colin27 (Debian's mricron-data).
# Reference shapes from aal.nii.gz, profiles trained on ch2better.nii.gz, each initial mesh moved
# by a seeded random similarity (<= 8 deg, <= 3 mm, scale 0.9-1.1), ch2.nii.gz segmented coarse to
# fine and scored against aal.nii.gz. Usage: bash scripts/demo.sh [SEED] [OUTPUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
seed="${1:-1}"
out="${2:-demo-output}"
bash scripts/install-deps.sh
cmake --preset release >/dev/null
cmake --build --preset release --target sinew-run sinew-make-scene sinew
t=/usr/share/mricron/templates
build/release/app/sinew-make-scene --atlas "$t/aal.nii.gz" --labels "$t/aal.nii.txt" \
  --training "$t/ch2better.nii.gz" --target "$t/ch2.nii.gz" --seed "$seed" -o "$out/scene.json"
build/release/app/sinew-run "$out/scene.json" -o "$out"
