#!/usr/bin/env bash
# Builds the libFuzzer harnesses (clang, AddressSanitizer, UBSan) and fuzzes each one.
#   scripts/fuzz.sh [SECONDS] [HARNESS...]
# SECONDS per harness (default 30: the bounded run CI does); HARNESS: scene image mesh model (all by
# default). Each harness starts from its seed corpus (tests/fuzz/corpus/NAME, copied, never
# modified) and stops at the first crash, leaving the input as build/fuzz/crash-NAME-*; add it to
# tests/fuzz/regressions/NAME once fixed (docs/reliability.md). JOBS=N runs N workers per harness.
# The long run: FUZZ_RUNS=10000000 JOBS=16 scripts/fuzz.sh 0 (each harness until 10^7 inputs in
# all, shared over the JOBS workers).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
shift || true
harnesses=("$@")
((${#harnesses[@]})) || harnesses=(scene image mesh model)
jobs=${JOBS:-1}
runs=${FUZZ_RUNS:--1}
((runs > 0)) && runs=$(((runs + jobs - 1) / jobs))  # libFuzzer's -runs counts per job
# Fixed for the bounded run, so that it repeats; 0 (libFuzzer picks one per worker) with several
# workers, which would otherwise all run the same inputs.
default_seed=1
((jobs > 1)) && default_seed=0
seed=${FUZZ_SEED:-$default_seed}
build=${FUZZ_BUILD:-build/fuzz}

if [ "${FUZZ_PREBUILT:-0}" = 1 ]; then
  :  # the harnesses are already built in $build (the device machine: scripts/device-checks.sh fuzz)
elif ! command -v clang++ >/dev/null || [ ! -e "$(clang++ -print-resource-dir)/lib/linux/libclang_rt.fuzzer-x86_64.a" ]; then
  echo "fuzz.sh: clang++ with libFuzzer is needed (apt-get install clang libclang-rt-14-dev)" >&2
  exit 2
else
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
  [ -f "$build/build.ninja" ] || cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ "${launcher[@]}" -DSINEW_FUZZ=ON \
    -DSINEW_ENABLE_CUDA=OFF -DSINEW_BUILD_TESTS=OFF -DSINEW_BUILD_BENCHMARKS=OFF >/dev/null
  ninja -C "$build" "${harnesses[@]/#/fuzz_}"
fi

# ITK and VTK are not instrumented; their leaks at exit are not ours to fix. No single allocation
# over 2 GB: the inputs are at most 64 KB, and a reader that asks for more (VTK, in its child
# process) then fails at once instead of filling gigabytes.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:allocator_may_return_null=1:max_allocation_size_mb=2048}
# A mesh read's deadline in the reader server (plugins/mesh_io_vtk/isolated_read.cpp), 120 s for
# users: below libFuzzer's -timeout here, so that a hung server ends as users would see it, in an
# InputError (a server forked under ASan can hang on an allocator lock held at the fork).
export SINEW_MESH_READ_SECONDS=${SINEW_MESH_READ_SECONDS:-5}
# The harnesses write each input to a file (the readers take paths): on tmpfs where there is one.
if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then export TMPDIR=/dev/shm; fi
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
status=0
root=$(pwd)
buildAbs=$(cd "$build" && pwd)
for h in "${harnesses[@]}"; do
  work="$buildAbs/work-$h"  # libFuzzer's worker logs (fuzz-N.log) land here
  corpus="$work/corpus"
  mkdir -p "$corpus"
  cp -n tests/fuzz/corpus/"$h"/* "$corpus"/
  inputs=("$corpus")
  [ -d tests/fuzz/regressions/"$h" ] && inputs+=("$root/tests/fuzz/regressions/$h")
  echo "== fuzz_$h: ${seconds} s, $jobs worker(s), at most $runs inputs"
  log="$work/fuzz.log"
  if ! (cd "$work" && "$buildAbs/tests/fuzz/fuzz_$h" "${inputs[@]}" -max_total_time="$seconds" -runs="$runs" -seed="$seed" \
      -rss_limit_mb=4096 -malloc_limit_mb=65536 -timeout=20 -max_len=65536 -jobs="$jobs" -workers="$jobs" \
      -artifact_prefix="$buildAbs/crash-$h-" -print_final_stats=1 > "$log" 2>&1); then
    echo "fuzz_$h FAILED; the input: $build/crash-$h-*; the log: $log" >&2
    # The finding's input as Base64 (where libFuzzer printed it: small inputs) and the log's end, so
    # that a CI log alone reproduces it (echo ... | base64 -d > input). Stdout to stderr first, then
    # stderr away: the other order sent both to /dev/null, and CI printed no finding (2026-12-01).
    { grep -h -m1 "^Base64: " "$log" "$work"/fuzz-*.log; tail -n 40 "$log" "$work"/fuzz-*.log; } >&2 2>/dev/null || true
    status=1
  fi
  # Inputs run, in all (libFuzzer prints them per worker with JOBS > 1, and a worker's log may
  # repeat its own line).
  if ((jobs > 1)); then logs=("$work"/fuzz-*.log); else logs=("$log"); fi
  grep -h -m1 "stat::number_of_executed_units" "${logs[@]}" 2>/dev/null |
    awk -v h="$h" '{n += $2} END {printf "fuzz_%s: %d inputs in all\n", h, n}' || true
done
exit $status
