#!/usr/bin/env bash
# The packages as a user gets them: builds the .deb and .tar.gz packages of a build directory,
# installs the .debs with apt, runs the installed sinew-run (--version, then the example plugin's
# scene with the plugin built out of tree against the installed SDK), removes the packages and
# checks that nothing is left behind. Run as root on Debian 12: bash scripts/package-test.sh [BUILD]
set -euo pipefail
cd "$(dirname "$0")/.."
build=$(realpath "${1:-build/ci}")
export DEBIAN_FRONTEND=noninteractive
fail() { echo "package-test: $*" >&2; exit 1; }

work=$(mktemp -d)
plugins=""
cleanup() {
  [ -n "$plugins" ] && rm -f "$plugins/sinew-plugin-balloon.so"
  apt-get remove --purge -y -qq sinew-dev sinew >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT
apt-get remove --purge -y -qq sinew-dev sinew >/dev/null 2>&1 || true  # left by an earlier run

echo "== packages"
rm -f "$build"/sinew*.deb "$build"/sinew-*.tar.gz
(cd "$build" && cpack -G "DEB;TGZ" >/dev/null)
runtime=$(ls "$build"/sinew_*.deb) dev=$(ls "$build"/sinew-dev_*.deb)
ls -l "$runtime" "$dev" "$build"/sinew-*.tar.gz
dpkg-deb -f "$runtime" Package Version Depends Recommends
dpkg-deb -f "$dev" Package Depends
dpkg-deb -c "$runtime" > "$work/runtime-contents.txt"
dpkg-deb -c "$dev" > "$work/dev-contents.txt"
for f in usr/bin/sinew-run usr/bin/sinew usr/bin/sinew-build-model usr/bin/sinew-make-subject usr/share/applications/io.github.sinew.Sinew.desktop \
         usr/share/icons/hicolor/scalable/apps/io.github.sinew.Sinew.svg \
         usr/share/metainfo/io.github.sinew.Sinew.metainfo.xml usr/share/mime/packages/io.github.sinew.Sinew.xml \
         usr/share/man/man1/sinew-run.1.gz usr/share/doc/sinew/plugins.md; do
  grep -q " \./$f\$" "$work/runtime-contents.txt" || fail "$f is not in $(basename "$runtime")"
done
for f in cmake/Sinew/SinewConfig.cmake include/sinew/core/plugin_api.h include/sinew/cuda/device_force.h \
         usr/share/sinew/examples/force-plugin/CMakeLists.txt; do
  grep -q "$f\$" "$work/dev-contents.txt" || fail "$f is not in $(basename "$dev")"
done

echo "== the .tar.gz runs where it is unpacked"
mkdir "$work/tgz" && tar -xzf "$build"/sinew-*.tar.gz -C "$work/tgz"
unpacked=$(echo "$work"/tgz/sinew-*)
"$unpacked/bin/sinew-run" --version
listing=$("$unpacked/bin/sinew-run" --list-plugins)
grep -q "^plugin search path:.* $unpacked/lib/sinew/plugins" <<<"$listing" ||
  fail "the unpacked sinew-run does not search $unpacked/lib/sinew/plugins"

echo "== install"
apt-get install -y -qq --no-install-recommends "$runtime" "$dev" >/dev/null
test "$(command -v sinew-run)" = /usr/bin/sinew-run || fail "sinew-run is not /usr/bin/sinew-run"
sinew-run --version
sinew-build-model --version
sinew-make-subject --version
[ ! -d /usr/share/mricron/templates ] || {
  # The installed model builder finds its libraries and plugins: a one-structure model, loaded back.
  t=/usr/share/mricron/templates
  sinew-build-model --atlas $t/aal.nii.gz --labels $t/aal.nii.txt --training $t/ch2.nii.gz --structures Putamen_L \
    --levels 2 -o "$work/model" -q
  grep -q '"name": "Putamen_L"' "$work/model/model.json" || fail "the installed sinew-build-model wrote no model"
}

echo "== example plugin, out of tree against the installed SDK"
export XDG_DATA_HOME="$work/data"  # no user plugins
example=/usr/share/sinew/examples/force-plugin
cmake -S "$example" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/build" >/dev/null
ctest --test-dir "$work/build" --output-on-failure
SINEW_PLUGIN_PATH="$work/build" sinew-run --list-plugins | grep "^plugin balloon"
SINEW_PLUGIN_PATH="$work/build" sinew-run "$example/balloon_scene.sinew.json" -o "$work/out" -q
test -s "$work/out/Thalamus_L.vtp" || fail "no mesh written"
test -s "$work/out/report.json" || fail "no report written"
# The installed plugin directory is searched too.
core=$(dpkg -L sinew | grep '/libsinew_core\.so' | head -1 || true)
[ -n "$core" ] || fail "libsinew_core is not in the sinew package"
plugins=$(dirname "$core")/plugins
test -d "$plugins" || fail "$plugins is missing"
cp "$work/build/sinew-plugin-balloon.so" "$plugins/"
sinew-run "$example/balloon_scene.sinew.json" -o "$work/out2" -q
rm "$plugins/sinew-plugin-balloon.so"
cmp "$work/out/Thalamus_L.vtp" "$work/out2/Thalamus_L.vtp"

echo "== remove"
apt-get remove --purge -y -qq sinew-dev sinew >/dev/null
status=$(dpkg -l sinew sinew-dev 2>/dev/null || true)
if grep -q '^ii' <<<"$status"; then fail "still installed"; fi
for p in /usr/bin/sinew-run /usr/bin/sinew /usr/include/sinew "$plugins" /usr/share/doc/sinew /usr/share/sinew \
         /usr/share/applications/io.github.sinew.Sinew.desktop; do
  [ ! -e "$p" ] || fail "$p is left after removal"
done
echo "package-test: passed"
