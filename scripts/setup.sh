#!/usr/bin/env bash
# Installs every Debian 12 package vinci's build, tests, benchmarks and scripts need.
# Idempotent; run as root (or with sudo available) on a fresh Debian 12.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  clang  # scripts/fuzz.sh: libFuzzer targets (-DVINCI_FUZZ=ON)
  libeigen3-dev libyaml-cpp-dev libcli11-dev libqhull-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libmujoco-dev libsiconos-numerics-dev
  libnlopt-cxx-dev coinor-libipopt-dev libmumps-seq-dev libceres-dev
  libompl-dev libboost-serialization-dev libboost-filesystem-dev libboost-system-dev
  libopenmpi-dev openmpi-bin
  python3-numpy python3-scipy python3-matplotlib
  libjs-three chromium  # vinci view: three.js embedded at build time; its test runs Chromium
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if ! command -v sudo >/dev/null 2>&1; then
    echo "setup: missing packages: ${missing[*]}" >&2
    echo "setup: installing them needs root; run as root or install sudo" >&2
    exit 1
  fi
  SUDO="sudo"
fi
echo "setup: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
