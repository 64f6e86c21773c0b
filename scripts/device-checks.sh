#!/usr/bin/env bash
# On the device machine (run from the repository root with .device carried): unpacks the bundle of
# scripts/device-bundle.sh, then runs the GPU tests and the new-subject accuracy on the GPU.
# Variables: CHECKS (default "parity demo accuracy"), SEEDS (default 201-205). Results go to $OUT.
set -uo pipefail
mkdir -p /opt/sinew && tar -C /opt/sinew -xJf .device/bundle.tar.xz
cp -a /opt/sinew/root/. /
B=/opt/sinew
export LD_LIBRARY_PATH=$B/lib:/usr/local/nvidia/lib64:${LD_LIBRARY_PATH:-}
export QT_PLUGIN_PATH=$B/qt QT_QPA_FONTDIR=$B/fonts
printf '<?xml version="1.0"?><fontconfig><dir>%s</dir><cachedir>/tmp/fccache</cachedir></fontconfig>\n' "$B/fonts" > /tmp/fonts.conf
export FONTCONFIG_FILE=/tmp/fonts.conf
build=$(cat $B/BUILD)  # the programs sit at their build paths (their RUNPATH points there)
echo "build tree: $build"
mkdir -p /usr/share/mricron/templates && cp $B/data/* /usr/share/mricron/templates/
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
out=${OUT:-/tmp/out}
for c in ${CHECKS:-parity demo accuracy}; do
  case $c in
    parity) for t in tst_cuda_parity tst_cuda_collision tst_cuda_profile; do
        "$build/tests/$t" 2>&1 | tee "$out/$t.txt" | grep -E "PASS|FAIL|QINFO|Totals|SKIP"
      done ;;
    run) REPEATS=${RUN_REPEATS:-3} bash scripts/bench-run.sh "$build" /tmp/bench-run 2>&1 | tee "$out/bench-run.md"
      for b in cpu cuda; do "$build/app/sinew-run" /tmp/bench-run/scene.json -q -v --backend $b -o /tmp/bench-run/v-$b 2>&1 | tail -16; done ;;
    bench) "$build/tests/bench/bench_cuda" ${BENCH_ARGS:-5 2} 2>&1 | tee "$out/bench_cuda.txt" ;;
    collision)
      for backend in ${COST_BACKENDS:-cuda cpu}; do
        bash scripts/collision-cost.sh "$build" /tmp/ccost-$backend "$backend" ${COST_LEVELS:-5} 2>&1 | tee "$out/collision-cost-$backend.md"
      done ;;
    kernels)
      for l in ${KERNEL_LEVELS:-3 4 5}; do
        bash scripts/collision-kernel-time.sh "$build" /tmp/ktime-$l "$l" 2>&1 | tee -a "$out/collision-kernels.md"
      done ;;
    steps)
      # GPU wall time of a step with and without collisions, the branch overlapping (bench_steps);
      # STEPS_BENCH: older bench_steps binaries to time on the same scenes.
      BENCH="${STEPS_BENCH:-}" bash scripts/collision-step-time.sh "$build" /tmp/stime "${STEP_LEVELS:-3 4}" 2>&1 |
        tee "$out/collision-steps.md"
      # The 100 AAL regions of CHECKS=scaling (below), 1,269,152 vertices at the finest level.
      list=$(awk 'NR<=100{printf "%s%s", (NR>1?",":""), $2}' /usr/share/mricron/templates/aal.nii.txt)
      SCHEDULE=${SCALING_SCHEDULE:-20,10,25} BENCH="${STEPS_BENCH:-}" \
        MAKE_SCENE_ARGS="--structures $list --max-rotation-deg 0 --max-translation-mm 0 --scale-min 1 --scale-max 1" \
        bash scripts/collision-step-time.sh "$build" /tmp/sscale 3 2>&1 | tee "$out/collision-steps-scaling.md" ;;
    scaling)
      # 100 AAL regions placed as the atlas has them (no perturbation): the broad phase's scaling.
      list=$(awk 'NR<=100{printf "%s%s", (NR>1?",":""), $2}' /usr/share/mricron/templates/aal.nii.txt)
      SCHEDULE=${SCALING_SCHEDULE:-20,10,25} EVERY=1 \
        MAKE_SCENE_ARGS="--structures $list --max-rotation-deg 0 --max-translation-mm 0 --scale-min 1 --scale-max 1" \
        bash scripts/collision-kernel-time.sh "$build" /tmp/kscale "${SCALING_LEVELS:-3}" 2>&1 | tee "$out/collision-scaling.md" ;;
    shape)
      # The shape guard on the device: the demo with implicit Euler at time step 100 (docs/stability.md).
      t=/usr/share/mricron/templates
      "$build/app/sinew-make-scene" --atlas $t/aal.nii.gz --labels $t/aal.nii.txt --training $t/ch2better.nii.gz \
        --target $t/ch2.nii.gz --seed 1 -o /tmp/shape/scene.json >/dev/null
      python3 -c 'import json,sys; p=sys.argv[1]; j=json.load(open(p)); j["integrator"]={"name":"implicit_euler","time_step":100}; json.dump(j,open(p,"w"),indent=1)' /tmp/shape/scene.json
      "$build/app/sinew-run" /tmp/shape/scene.json -o /tmp/shape/run -q --backend cuda > "$out/shape.txt" 2>&1; echo "exit $?" >> "$out/shape.txt"
      python3 -c 'import json; r=json.load(open("/tmp/shape/run/report.json")); print(r["status"], r["backend"], r["stability"]["rollbacks"])' >> "$out/shape.txt"
      cat "$out/shape.txt" ;;
    cohort)
      # Subjects per minute over a cohort of new subjects (docs/benchmarks.md, "Cohorts").
      bash scripts/cohort-bench.sh "$build" /tmp/cohort ${COHORT_SUBJECTS:-24} 2>&1 | tee "$out/cohort.md" ;;
    split)
      # Harvard-Oxford's labels in parts on both sides, a model split by side, on a new subject, both
      # backends (docs/accuracy.md, "Models of labels split by side").
      t=/usr/share/mricron/templates; ho=$t/HarvardOxford-cort-maxprob-thr0-1mm.nii.gz; d=/tmp/split
      "$build/app/sinew-build-model" --atlas $ho --training $t/ch2better.nii.gz --structures 1,2,16 --split-parts -o $d/model -q
      "$build/app/sinew-make-subject" --image $t/ch2.nii.gz --labels $ho --seed 23 -o $d/subject >/dev/null
      "$build/app/sinew-make-scene" --model $d/model --target $d/subject/image.nii.gz --ground-truth $d/subject/labels.nii.gz \
        -o $d/scene.json 2>&1 | tee "$out/split.txt"
      for b in cuda cpu; do "$build/app/sinew-run" $d/scene.json -o $d/run-$b -q --backend $b 2>&1 | tail -9 | tee -a "$out/split.txt"; done ;;
    varied)
      # The varied subjects of scripts/varied_subjects.py (VARIED="FIRST END"), the model of the 12
      # structures, subject scenes as written, on CUDA (docs/accuracy.md, "Twenty varied subjects").
      t=/usr/share/mricron/templates; d=/tmp/varied
      "$build/app/sinew-build-model" --atlas $t/aal.nii.gz --labels $t/aal.nii.txt --training $t/ch2better.nii.gz -o $d/model -q
      python3 scripts/varied_subjects.py ${VARIED:-7401 7421} | while read -r seed opts; do
        s=$d/subject-$seed
        "$build/app/sinew-make-subject" --image $t/ch2.nii.gz --labels $t/aal.nii.gz --seed $seed $opts -o $s >/dev/null 2>&1
        "$build/app/sinew-make-scene" --model $d/model --target $s/image.nii.gz --ground-truth $s/labels.nii.gz \
          -o $s/scene.json 2>/dev/null
        "$build/app/sinew-run" $s/scene.json -o $s/run -q --backend ${VARIED_BACKEND:-cuda} >/dev/null 2>&1
        echo -n "$seed exit $? "
        python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); s=r["structures"]
print("ASSD %.4f Dice %.4f overlap %.3f total %.2f s" % (sum(x["assd_mm"]["final"] for x in s)/len(s),
      sum(x["dice"] for x in s)/len(s), r["overlaps"]["total_after_mm3"], r["total_seconds"]))' $s/run/report.json
      done | tee "$out/varied.txt" ;;
    demo) "$build/tests/tst_backend_demo" 2>&1 | tee "$out/demo.txt" | grep -E "PASS|FAIL|QINFO|Totals|SKIP" ;;
    memory) "$build/tests/tst_device_memory" 2>&1 | tee "$out/memory.txt" | grep -E "PASS|FAIL|QINFO|Totals|SKIP" ;;
    soak) "$build/tests/bench/bench_soak" ${SOAK_ARGS:---steps 1000000} 2>&1 | tee "$out/soak.txt" ;;
    fuzz)
      # The long fuzz run (docs/reliability.md): FUZZ_RUNS inputs in all per harness over the cores,
      # at most FUZZ_SECONDS each (the bundle made with FUZZ=1 scripts/device-bundle.sh).
      FUZZ_PREBUILT=1 FUZZ_BUILD="$(dirname "$build")/fuzz" JOBS=${FUZZ_JOBS:-$(nproc)} FUZZ_RUNS=${FUZZ_RUNS:-10000000} \
        bash scripts/fuzz.sh ${FUZZ_SECONDS:-0} ${FUZZ_HARNESSES:-scene image mesh model} 2>&1 | tee "$out/fuzz.txt"
      # What a finding left: its input (one file) and the end of its worker's log.
      crashes=$(ls "$(dirname "$build")"/fuzz/crash-* 2>/dev/null | head -3)
      for f in $crashes; do cp "$f" "$out/"; done
      [ -n "$crashes" ] && grep -l -E "ERROR|Deadly|crash" "$(dirname "$build")"/fuzz/work-*/fuzz-*.log 2>/dev/null | head -1 |
        xargs -r tail -n 60 > "$out/fuzz-finding.log" ;;
    autosave)
      # The autosave against the frame loop at about a million vertices (docs/reliability.md).
      t=/usr/share/mricron/templates
      "$build/app/sinew-make-scene" --atlas $t/aal.nii.gz --labels $t/aal.nii.txt --training $t/ch2.nii.gz \
        --target $t/ch2better.nii.gz --iterations 20,10,10,10,10,10 -o /tmp/big/scene.json >/dev/null
      "$build/tests/bench/bench_autosave" /tmp/big/scene.json --backend cuda ${AUTOSAVE_ARGS:---level 5} 2>&1 | tee "$out/autosave.txt"
      [ -n "${AUTOSAVE_ARGS2:-}" ] && "$build/tests/bench/bench_autosave" /tmp/big/scene.json --backend cuda $AUTOSAVE_ARGS2 2>&1 | tee "$out/autosave2.txt" ;;
    accuracy)
      for backend in ${ACC_BACKENDS:-cuda cpu}; do
        bash scripts/accuracy.sh "$build" /tmp/acc "$backend" ${SEEDS:-201 202 203 204 205} > "$out/accuracy-$backend.md" 2>"$out/accuracy-$backend.err"
        tail -25 "$out/accuracy-$backend.md"
      done
      for s in ${SEEDS:-201 202 203 204 205}; do cp /tmp/acc/subject-$s/run-cuda/report.json "$out/report-cuda-$s.json"; done 2>/dev/null ;;
  esac
done
