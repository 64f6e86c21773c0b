#!/usr/bin/env bash
# Installs the Debian 12 packages Sinew needs to build, test and run its demo. Run as root.
set -euo pipefail
packages=(
  cmake ninja-build g++ pkg-config dpkg-dev file
  libeigen3-dev libtbb-dev nlohmann-json3-dev libnanoflann-dev libcli11-dev zlib1g-dev libdeflate-dev
  qt6-base-dev libqt6opengl6-dev fonts-dejavu-core
  xvfb xauth libgl1-mesa-dri libglx-mesa0
  libinsighttoolkit5-dev libvtk9-dev
  libbenchmark-dev
  clang libclang-rt-14-dev
  slurm-wlm munge
  mricron-data
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
