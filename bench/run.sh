#!/usr/bin/env bash
# `make bench`: ingest throughput vs the OpenCV decode bound on a generated 128x128 tabletop set.
set -euo pipefail
BIN=${1:-build/bin}
WORK=${BENCH_DIR:-/tmp/wmkit-bench}
if [ ! -f "$WORK/raw/wm_tabletop/1.0.0/dataset_info.json" ]; then
  "$BIN/wm-gen-tabletop" --out "$WORK/raw" --train-episodes 96 --val-episodes 4 --size 128 \
    --max-steps 40 --seed 1 > /dev/null 2>&1
fi
"$BIN/ingest_bench" --input "$WORK/raw/wm_tabletop/1.0.0" --threads "$(nproc)" --repeats 3
