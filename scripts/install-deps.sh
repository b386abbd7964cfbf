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
  # LibTorch's CPU matmuls call whatever libblas.so.3 update-alternatives points at; OpenBLAS's
  # OpenMP build takes it over from ATLAS's generic one and follows LibTorch's thread count:
  # the transformer trains about 2x faster on the demo (README, "Build notes": BLAS)
  libopenblas0-openmp
  # Python reference checks (run with /usr/bin/python3)
  python3 python3-numpy python3-scipy python3-skimage python3-torch python3-torchvision
  python3-opencv python3-h5py python3-jsonschema python3-crc32c python3-zstandard python3-yaml python3-matplotlib
  # scripts/openpi_policy.py: openpi-style (websocket + msgpack) policy servers
  python3-msgpack python3-websockets
)
# Packages only some targets need, named by them (make fuzz: clang libclang-rt-dev).
PACKAGES+=("$@")

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${#missing[@]} missing packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
# No package index means apt-get update never ran on this machine (an unmatched glob stays
# literal, so the first entry then does not exist).
indexes=(/var/lib/apt/lists/*_Packages*)
if [ ! -e "${indexes[0]}" ] ||
   ! apt-cache policy "${missing[0]}" 2>/dev/null | grep -q Candidate; then
  $SUDO apt-get update -q
fi
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
