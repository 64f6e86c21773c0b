#!/usr/bin/env bash
# Subjects per minute of sinew-cohort run (run and report, end to end) on this host, per
# configuration, for one cohort of new subjects (docs/benchmarks.md, "Cohorts").
#   scripts/cohort-bench.sh BUILD_DIR WORK_DIR [SUBJECTS]
# CONFIGS (default "gpu1x1 gpu1x2 gpu1x4 cpu"): gpuGxJ = G GPUs with J runs each; cpu = CPU workers
# (CPU_WORKERS; 0, the default, lets sinew-cohort choose); J = 0 lets it choose the runs per GPU. The model has the 12 AAL structures; subjects are
# made by sinew-make-subject with seeds 301, 302, ... and scored against their own labels.
set -euo pipefail
build=$(realpath "$1"); work=$(realpath -m "$2"); n=${3:-24}
t=/usr/share/mricron/templates
app=$build/app
mkdir -p "$work"
cd "$work"
[ -f model/model.json ] || "$app/sinew-build-model" --atlas $t/aal.nii.gz --labels $t/aal.nii.txt --training $t/ch2better.nii.gz -o model -q
seq 301 $((300 + n)) | xargs -P "$(nproc)" -I{} sh -c \
  "[ -f subject-{}/image.nii.gz ] || '$app/sinew-make-subject' --image $t/ch2.nii.gz --labels $t/aal.nii.gz --seed {} -o subject-{} >/dev/null 2>&1"
{ echo "subject,target,ground_truth"
  for s in $(seq 301 $((300 + n))); do echo "s$s,subject-$s/image.nii.gz,subject-$s/labels.nii.gz"; done; } > cohort.csv
echo "| configuration | subjects | completed | wall s (run + report) | subjects/min | median subject s | median ASSD mm |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
for c in ${CONFIGS:-gpu1x1 gpu1x2 gpu1x4 cpu}; do
  case $c in
    gpu*) g=${c#gpu}; args=(--gpus "${g%x*}" --jobs-per-gpu "${g#*x}") ;;
    cpu) args=(--gpus 0 --backend cpu --cpu-workers "${CPU_WORKERS:-0}") ;;
  esac
  rm -rf "c-$c"
  start=$(date +%s.%N)
  "$app/sinew-cohort" run cohort.csv --model model -o "c-$c" -q "${args[@]}" || true
  end=$(date +%s.%N)
  python3 - "$c" "c-$c" "$start" "$end" "$n" <<'PY'
import csv, json, statistics, sys
c, d, start, end, n = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
rows = list(csv.DictReader(open(f"{d}/report/subjects.csv")))
done = [r for r in rows if r["status"] == "completed"]
wall = end - start
med = statistics.median(float(r["wall_seconds"]) for r in done) if done else float("nan")
assd = statistics.median(float(r["mean_assd_mm"]) for r in done if r["mean_assd_mm"]) if done else float("nan")
print(f"| {c} | {n} | {len(done)} | {wall:.1f} | {60 * len(done) / wall:.1f} | {med:.2f} | {assd:.3f} |")
PY
done
