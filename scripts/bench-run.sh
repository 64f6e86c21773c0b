#!/usr/bin/env bash
# bench_run: the whole sinew-run of the Colin27 demo (seed 1, 12 structures, error sampled every 10
# iterations) on each backend, side by side in one run, stage by stage (report.json's
# stage_seconds), with the process's wall time and peak host memory (wait4's rusage), the median of
# REPEATS runs per backend by wall time. Prints a Markdown table for docs/benchmarks.md.
# Usage: bash scripts/bench-run.sh BUILD_DIR OUT_DIR [BACKENDS] (default "cpu cuda"; REPEATS=3).
set -euo pipefail
build=$1 out=$2 backends=${3:-cpu cuda}
t=/usr/share/mricron/templates
mkdir -p "$out"
"$build/app/sinew-make-scene" --atlas $t/aal.nii.gz --labels $t/aal.nii.txt --training $t/ch2better.nii.gz \
  --target $t/ch2.nii.gz --seed 1 -o "$out/scene.json" >/dev/null 2>&1
python3 - "$build/app/sinew-run" "$out" "${REPEATS:-3}" $backends <<'PY'
import json, os, statistics, subprocess, sys, time
run, out, repeats, backends = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4:]
cols = {}
stages = []
for b in backends:
    runs = []
    for r in range(repeats):
        t0 = time.monotonic()
        p = subprocess.Popen([run, f"{out}/scene.json", "-q", "--backend", b, "-o", f"{out}/{b}-{r}"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        err = p.stderr.read()
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.monotonic() - t0
        if status != 0:
            sys.exit(f"sinew-run --backend {b} failed ({status}): {err.decode()}")
        runs.append((json.load(open(f"{out}/{b}-{r}/report.json")), wall, usage.ru_maxrss / 1024.0))
    runs.sort(key=lambda x: x[1])
    rep, wall, rss = runs[len(runs) // 2]
    cols[b] = dict(rep["stage_seconds"], total_seconds=rep["total_seconds"], process_wall_seconds=wall,
                   peak_host_memory_mb=rss, mean_assd_mm=statistics.mean(s["assd_mm"]["final"] for s in rep["structures"]))
    cols[b]["device"] = rep["device"]
    stages += [k for k in rep["stage_seconds"] if k not in stages]
print("| stage (s) | " + " | ".join(backends) + " |")
print("| --- |" + " ---: |" * len(backends))
for k in stages + ["total_seconds", "process_wall_seconds", "peak_host_memory_mb", "mean_assd_mm"]:
    print(f"| {k} | " + " | ".join(f"{cols[b].get(k, float('nan')):.3f}" for b in backends) + " |")
for b in backends:
    c = cols[b]
    print(f"\n{b}: {c['device']}; error sampling {100 * c.get('sample_error', 0.0) / c['total_seconds']:.1f} % of the run; "
          f"simulation {c.get('simulation', 0.0):.3f} s of {c['total_seconds']:.3f} s")
PY
