#!/usr/bin/env bash
# Downloads (Debian machine, no root needed) the .debs of exactly the small libraries that the
# model-only build (cmake -DWM_MODEL_ONLY=ON, docs/gpu.md) needs beyond LibTorch, CMake and a
# compiler, and prints their total size. For a GPU machine without them and without a package
# registry: carry the folder, then `for f in DIR/*.deb; do dpkg -x "$f" PREFIX; done` and add
# PREFIX/usr to CMAKE_PREFIX_PATH (and PREFIX/usr/lib/x86_64-linux-gnu to LD_LIBRARY_PATH).
#   scripts/gpu/fetch_debs.sh [DIR]      (default .debs)
set -euo pipefail
DIR=${1:-.debs}
PACKAGES=(
  nlohmann-json3-dev libcli11-dev libeigen3-dev           # header-only
  libspdlog-dev libspdlog1.10 libfmt-dev libfmt9          # logging
  libyaml-cpp-dev libyaml-cpp0.7                          # configs
  libssl-dev libzstd-dev libpng-dev libjpeg62-turbo-dev   # hashes, shards, frames
  libgtest-dev libgmock-dev                               # tests
)
mkdir -p "$DIR"
(cd "$DIR" && apt-get download "${PACKAGES[@]}" > /dev/null)
du -ch "$DIR"/*.deb | tail -n 1 | sed "s|total|total for ${#PACKAGES[@]} packages in $DIR|"
