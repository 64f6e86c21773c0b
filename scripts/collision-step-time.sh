#!/usr/bin/env bash
# GPU wall time of a step with and without collisions (tests/bench/bench_steps): the demo scene
# (seed 1, 12 structures) at each of LEVELS levels of detail, the finest run for 60 iterations,
# then rounds of STEPS steps timed on each scene in turn in one process. Unlike
# scripts/collision-kernel-time.sh (Nsight Compute's serialised kernel durations) this sees the
# step as a run does: its kernels back to back in a graph, the collision branch beside the other
# forces. EVERY: values of the collision force's full_search_every, a scene each (default 1).
# BENCH: other bench_steps binaries to run after this build's on the same scenes (an older
# build's, side by side). MAKE_SCENE_ARGS: more sinew-make-scene options (e.g. another
# --structures list); SCHEDULE: iterations per level instead; BENCH_FLAGS: --cpu for the CPU
# backend, --warmup N for N untimed steps before each round. ALSO: collision parameters as JSON
# (e.g. '{"reaction": 0}'), merged into a copy of each collision scene, timed beside it.
# docs/benchmarks.md.
# Usage: bash scripts/collision-step-time.sh BUILD_DIR OUT_DIR ["3 4"]
set -euo pipefail
cd "$(dirname "$0")/.."
build="$1"; out="$2"; levels="${3:-3 4}"
t=/usr/share/mricron/templates
schedules=("" "" "" "150,80" "150,80,30" "150,80,30,20")
mkdir -p "$out"
for l in $levels; do
  scenes=()
  for c in off $(for k in ${EVERY:-1}; do echo "every$k"; done); do
    weight=1; [ "$c" = off ] && weight=0
    "$build/app/sinew-make-scene" --atlas "$t/aal.nii.gz" --labels "$t/aal.nii.txt" --training "$t/ch2better.nii.gz" \
      --target "$t/ch2.nii.gz" --seed 1 --iterations "${SCHEDULE:-${schedules[$l]},60}" --collision-weight "$weight" \
      ${MAKE_SCENE_ARGS:-} -o "$out/levels-$l-$c/scene.json" >/dev/null
    [ "$c" = off ] || python3 -c 'import json,sys; p=sys.argv[1]; j=json.load(open(p)); j["forces"]["collision"]["full_search_every"]=int(sys.argv[2]); json.dump(j,open(p,"w"),indent=1)' \
      "$out/levels-$l-$c/scene.json" "${c#every}"
    scenes+=("$out/levels-$l-$c/scene.json")
    if [ "$c" != off ] && [ -n "${ALSO:-}" ]; then
      python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); j["forces"]["collision"].update(json.loads(sys.argv[2])); json.dump(j,open(sys.argv[3],"w"),indent=1)' \
        "$out/levels-$l-$c/scene.json" "$ALSO" "$out/levels-$l-$c/also.json"
      scenes+=("$out/levels-$l-$c/also.json")
    fi
  done
  for bench in "$build/tests/bench/bench_steps" ${BENCH:-}; do
    echo "$bench, $l levels:"
    "$bench" ${BENCH_FLAGS:-} "${STEPS:-64}" "${ROUNDS:-15}" "${scenes[@]}"
    echo
  done
done
