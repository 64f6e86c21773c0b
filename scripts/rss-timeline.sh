#!/usr/bin/env bash
# A command's resident memory over time: runs it, samples its VmRSS about every 5 ms, and prints the
# largest RSS in each 50 ms and the peak; with a sinew-run output folder, also its report's stages,
# to place the peak among them (docs/benchmarks.md, "The demo's host memory").
# Usage: bash scripts/rss-timeline.sh [OUT_DIR_OF_SINEW_RUN] -- COMMAND ARGS...
set -uo pipefail
report=""
if [ "${1:-}" != "--" ]; then report="$1/report.json"; shift; fi
shift  # --
samples=$(mktemp)
t0=$(date +%s%N)
"$@" > /dev/null 2>&1 &
pid=$!
while kill -0 $pid 2>/dev/null; do
  r=$(awk '/VmRSS/{print $2}' /proc/$pid/status 2>/dev/null)
  [ -n "$r" ] && echo "$(( ($(date +%s%N) - t0) / 1000000 )) $((r / 1024))" >> "$samples"
  sleep 0.005
done
wait $pid
rc=$?
python3 - "$samples" "$report" <<'PY'
import json, os, sys
rows = [tuple(map(int, l.split())) for l in open(sys.argv[1]) if len(l.split()) == 2]
worst = {}
for t, r in rows: worst[t // 50] = max(worst.get(t // 50, 0), r)
print('RSS (MB), the largest in each 50 ms:', ' '.join('%.2f:%d' % (k * 0.05, v) for k, v in sorted(worst.items())))
if rows: print('peak RSS %d MB at %.3f s' % max((r, t / 1000) for t, r in rows))
if sys.argv[2] and os.path.exists(sys.argv[2]):
    print('stages (s):', ' '.join('%s %.3f' % kv for kv in json.load(open(sys.argv[2]))['stage_seconds'].items()))
PY
rm -f "$samples"
exit $rc
