#!/usr/bin/env bash
# Set-up, build and every test: what CI runs on a fresh Debian 12 machine.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset ci
cmake --build --preset ci
ctest --preset ci
# Every fuzz harness, 30 s each from its seeds (clang, ASan, UBSan; docs/reliability.md).
bash scripts/fuzz.sh 30
# The packages, installed and removed with apt (needs root, as on CI).
if [ "$(id -u)" = 0 ]; then
  bash scripts/package-test.sh build/ci
else
  echo "test.sh: skipping the package install test (it needs root)"
fi
