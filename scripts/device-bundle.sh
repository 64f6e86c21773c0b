#!/usr/bin/env bash
# Packs what the GPU checks need onto the device machine (an Ubuntu host without Debian's
# libraries): the CUDA build's programs and test plugins at their build paths, every library they
# load, Qt's offscreen platform plugin, fonts and the mricron-data templates, into
# .device/bundle.tar.xz (ignored by git; carried with the device tool). scripts/device-checks.sh
# unpacks and runs it there. Usage: [EXTRA="PROGRAM..."] [ONLY="PATH_IN_BUILD..."] bash
# scripts/device-bundle.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build="$(realpath "${1:-build/ci}")"
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
bins=("$build/app/sinew-run" "$build/app/sinew-cohort" "$build/app/sinew-make-scene" "$build/app/sinew-build-model" "$build/app/sinew-make-subject"
      "$build/tests/tst_cuda_parity" "$build/tests/tst_cuda_collision" "$build/tests/tst_cuda_profile" "$build/tests/tst_backend_demo" "$build/tests/tst_device_memory")
for b in bench_cuda bench_soak bench_autosave bench_error bench_steps; do
  [ -x "$build/tests/bench/$b" ] && bins+=("$build/tests/bench/$b")
done
# ONLY: just these programs (paths in the build tree), for a bundle under the device tool's carry limit.
if [ -n "${ONLY:-}" ]; then
  bins=()
  for f in $ONLY; do bins+=("$build/$f"); done
fi
# EXTRA: more programs to carry (an older build's, to time side by side), at their paths.
for f in ${EXTRA:-}; do bins+=("$(realpath "$f")"); done
shopt -s nullglob  # a build of a few programs has no test plugins
for f in "${bins[@]}" "$build"/core/libsinew_core.so* "$build"/tests/plugins/*/sinew-plugin-*.so; do
  mkdir -p "$stage/root$(dirname "$f")"
  cp -a "$f" "$stage/root$f"
done
# FUZZ=1: the libFuzzer harnesses of build/fuzz (scripts/fuzz.sh) too, without their debug
# information, for the long run (CHECKS=fuzz).
if [ "${FUZZ:-0}" = 1 ]; then
  fuzz="$(realpath build/fuzz)"
  for f in "$fuzz"/tests/fuzz/fuzz_{scene,image,mesh,model} "$fuzz"/core/libsinew_core.so*; do
    mkdir -p "$stage/root$(dirname "$f")"
    cp -a "$f" "$stage/root$f"
    [ -L "$f" ] || strip --strip-debug "$stage/root$f"
    [[ "$f" == */fuzz_* ]] && bins+=("$f")
  done
fi
mkdir -p "$stage/lib" "$stage/qt/platforms" "$stage/fonts" "$stage/data"
for f in "${bins[@]}"; do ldd "$f" | awk '/=> \//{print $3}'; done | sort -u |
  grep -v -E '/(libc|libm|libdl|librt|libpthread|ld-linux-x86-64|libstdc\+\+|libgcc_s)\.so' |
  grep -v libsinew_core | while read -r l; do cp -L "$l" "$stage/lib/"; done
cp -L /usr/lib/x86_64-linux-gnu/qt6/plugins/platforms/libqoffscreen.so "$stage/qt/platforms/"
cp -L /usr/lib/x86_64-linux-gnu/libstdc++.so.6 /usr/lib/x86_64-linux-gnu/libgcc_s.so.1 "$stage/lib/"
cp /usr/share/fonts/truetype/dejavu/DejaVuSans*.ttf "$stage/fonts/"
t=/usr/share/mricron/templates
cp "$t/aal.nii.gz" "$t/aal.nii.txt" "$t/ch2.nii.gz" "$t/ch2better.nii.gz" "$t/HarvardOxford-cort-maxprob-thr0-1mm.nii.gz" "$stage/data/"
echo "$build" > "$stage/BUILD"
mkdir -p .device
tar -C "$stage" -cf - . | xz -T2 -6 > .device/bundle.tar.xz
ls -la .device/bundle.tar.xz
