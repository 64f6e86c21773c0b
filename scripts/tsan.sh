#!/usr/bin/env bash
# ThreadSanitizer on whole runs: builds sinew-run with -fsanitize=thread in build/tsan (core, plugins
# and the program; CUDA, tests and benchmarks off), runs it on each scene given (CPU backend), and
# prints the distinct races whose stacks hold no TBB frame. TBB is not instrumented, so its own
# synchronisation is invisible and every report with TBB frames is left out: those need an
# instrumented TBB to judge (docs/reliability.md). Qt, fontconfig and harfbuzz are not instrumented
# either: races inside them (the pictures' text, drawn on two threads) are listed but may be their
# own atomics, unseen. A subject's run takes 10-15 minutes on two cores.
#   scripts/tsan.sh SCENE.json [SCENE.json...]
# Reports stay in build/tsan/runs/N.log; TIMEOUT (seconds, default 1800) bounds each run.
set -euo pipefail
cd "$(dirname "$0")/.."
(($#)) || { echo "usage: scripts/tsan.sh SCENE.json [SCENE.json...]" >&2; exit 2; }
build=build/tsan
[ -f "$build/build.ninja" ] || cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread -fno-omit-frame-pointer" -DCMAKE_C_FLAGS=-fsanitize=thread \
  -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread -DCMAKE_SHARED_LINKER_FLAGS=-fsanitize=thread \
  -DSINEW_ENABLE_CUDA=OFF -DSINEW_BUILD_TESTS=OFF -DSINEW_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$build" --target sinew-run
mkdir -p "$build/runs"
n=0
for scene in "$@"; do
  n=$((n + 1))
  log="$build/runs/$n.log"
  echo "== $scene ($log)"
  rc=0
  TSAN_OPTIONS="halt_on_error=0 history_size=4 report_signal_unsafe=0" timeout "${TIMEOUT:-1800}" \
    "$build/app/sinew-run" "$scene" -q --backend cpu -o "$build/runs/out-$n" > "$log" 2>&1 || rc=$?
  echo "exit $rc"
  python3 - "$log" <<'PY'
import re, sys
text = open(sys.argv[1], errors="replace").read()
reports = text.split("==================\nWARNING: ThreadSanitizer")[1:]
distinct = {}
for r in reports:
    if "tbb::" in r or "libtbb" in r:
        continue
    summary = re.search(r"SUMMARY: (.*)", r)
    distinct.setdefault(summary.group(1) if summary else r[:200], r)
print(f"{len(reports)} reports, {len(distinct)} distinct without TBB frames")
for key, r in distinct.items():
    print("##", key)
    for line in r.split("\n"):
        if re.match(r"\s+#[0-5] ", line) or re.match(r"  (Read|Write|Previous|Atomic|Location)", line):
            print(line[:200])
PY
done
