#!/usr/bin/env bash
# An executable that links LibTorch must list libstdc++ before every libtorch*.so among its
# DT_NEEDED entries: pip's LibTorch 2.x exports its own copies of std::filesystem functions, and
# binding to its remove_all crashed every test's TempDir on the H200 machine (CMakeLists.txt,
# docs/gpu.md).
#   tests/link_order_test.sh EXECUTABLE
set -euo pipefail
needed=$(readelf -d "$1" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
first=$(grep -m1 -E '^(libstdc\+\+|libtorch)' <<< "$needed" || true)
echo "$1: DT_NEEDED" $needed
grep -q '^libtorch' <<< "$needed" || { echo "FAIL: links no libtorch*.so (wrong executable?)"; exit 1; }
[[ $first == libstdc++* ]] || { echo "FAIL: $first comes before libstdc++"; exit 1; }
echo "ok: libstdc++ comes before every libtorch*.so"
