#!/usr/bin/env bash
# Installs every Debian package wmkit builds, tests or benchmarks with. Idempotent: when all
# packages are present it only checks and exits. Uses sudo when not root.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake pkg-config ccache clang-format clang-tidy
  # libraries
  libopencv-dev libeigen3-dev libpcl-dev libceres-dev libtorch-dev
  libprotobuf-dev protobuf-compiler libzstd-dev libhdf5-dev libssl-dev libpng-dev libjpeg-dev
  libsnappy-dev libavformat-dev libavcodec-dev libavutil-dev libswscale-dev libdav1d-dev
  libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev libyaml-cpp-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  # Python reference checks (run with /usr/bin/python3)
  python3 python3-numpy python3-scipy python3-skimage python3-torch python3-torchvision
  python3-opencv python3-h5py python3-jsonschema python3-crc32c python3-zstandard python3-yaml python3-matplotlib
)
# Packages only some targets need, named by them (make fuzz: clang libclang-rt-dev).
PACKAGES+=("$@")
# Speed only: tried, and a warning where they cannot be installed (no apt mirror reachable).
# OpenBLAS (OpenMP build, so it shares LibTorch's libgomp threads) replaces Debian's generic
# ATLAS as libblas.so.3 (update-alternatives priority 100 > 35): about 20% faster training of
# every model and imagination (README, "Build notes").
OPTIONAL=(libopenblas0-openmp)

installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

missing=() optional_missing=()
for p in "${PACKAGES[@]}"; do installed "$p" || missing+=("$p"); done
for p in "${OPTIONAL[@]}"; do installed "$p" || optional_missing+=("$p"); done
if [ ${#missing[@]} -eq 0 ] && [ ${#optional_missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
apt_install() {
  # An empty package list means apt-get update never ran on this machine.
  if [ -z "$(ls -A /var/lib/apt/lists 2>/dev/null | grep -v -e lock -e partial)" ] ||
     ! apt-cache policy "$1" 2>/dev/null | grep -q Candidate; then
    $SUDO apt-get update -q
  fi
  $SUDO apt-get install -y -q --no-install-recommends "$@"
}
if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${#missing[@]} missing packages: ${missing[*]}"
  apt_install "${missing[@]}"
fi
if [ ${#optional_missing[@]} -gt 0 ]; then
  echo "install-deps: installing optional speed packages: ${optional_missing[*]}"
  apt_install "${optional_missing[@]}" ||
    echo "install-deps: warning: could not install ${optional_missing[*]}; wmkit works without" \
      "them, slower (README, Build notes)" >&2
fi
