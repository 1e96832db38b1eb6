#!/usr/bin/env bash
# Installs what sspc needs to build and test, from Debian's packages, and the packages named as
# arguments. Skips apt when all are
# present, so repeated runs cost nothing.
set -euo pipefail
packages=(build-essential cmake ninja-build pkg-config libeigen3-dev libnanoflann-dev libtbb-dev
          libzstd-dev libcli11-dev nlohmann-json3-dev libpng-dev libgtest-dev libbenchmark-dev
          python3-dev pybind11-dev python3-numpy python3-pytest  # the Python package, python/
          python3-distributed)  # sspc.distributed's Dask tasks
packages+=("$@")  # what a measuring script needs besides (draco, time, python3-matplotlib, ...)
# Embree 3, optional for the build: the example examples/embree_user_geometry.cpp (the test
# example.embree) and the reference renderer of scripts/bench_render.sh. Debian builds it for amd64.
if [ "$(dpkg --print-architecture)" = amd64 ]; then packages+=(libembree-dev); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "installing: ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO=sudo; fi
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
