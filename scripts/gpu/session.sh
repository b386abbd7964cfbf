#!/usr/bin/env bash
# One lent GPU session in one device call (docs/gpu.md): ends by itself within BUDGET seconds
# and leaves its logs and runs in $OUT as a few archives (a call brings back at most 8 files).
# Work that shares nothing runs side by side: the motion model variants on the GPU from the
# moment wm-motion is built, the tests on the CPU cores, and the presets, NCCL and the numerics
# check one after another on the GPU.
#   [BUDGET=520] [MOTION_S=...] [TABLETOP64=data/demo/shards] bash scripts/gpu/session.sh
# (carry: TABLETOP64's folder and gpu-data). The demo's shards are 78 MB since it makes 1000
# training episodes, over a device call's 64 MiB carry: give a 200-episode set as TABLETOP64
# (docs/gpu.md, "What a next GPU session should run first").
set -uo pipefail
BUDGET=${BUDGET:-520}
OUT=${OUT:-gpu-out}
LOGS=/tmp/gpu-logs
mkdir -p "$OUT" "$LOGS" gpu-data
[ -e gpu-data/tabletop64 ] || ln -s "../${TABLETOP64:-data/demo/shards}" gpu-data/tabletop64
left() { echo $((BUDGET - SECONDS - 30)); }  # 30 s for the archives at the end
# run.sh's stages with logs in LOGS/NAME, stopped after CAP seconds or when the budget ends.
run() {  # CAP NAME STAGE...
  local s
  s=$(left)
  ((s > $1)) && s=$1
  ((s > 10)) && timeout "$s" bash scripts/gpu/run.sh --logs "$LOGS/$2" "${@:3}"
}

nvidia-smi --query-gpu=timestamp,utilization.gpu,memory.used --format=csv -l 5 \
  > "$LOGS/gpu-usage.csv" 2>&1 &
USAGE_PID=$!
TARGETS=wm-motion run 9999 motion-build build
# MOTION_S=0 skips the motion runs (the GPU then serves the presets alone); default: all the time
# left, beside everything else.
MOTION_S=${MOTION_S:-$(($(left) - 20))}
((MOTION_S > 0)) && MOTION_S=$MOTION_S run 9999 motion motion &
run 9999 all build
run 300 tests test &
PRESETS=meta64 TOK_STEPS=200 DYN_STEPS=60 run 9999 meta64 train nccl
CHECK_TOKENIZER=gpu-runs/meta64/tokenizer CHECK_DYNAMICS=gpu-runs/meta64/dynamics/checkpoint.wmt \
  run 9999 check check
PRESETS=whale-x-small TOK_STEPS=100 DYN_STEPS=20 WHALE_BATCH=${WHALE_BATCH:-8} \
  run 9999 whale train
kill "$USAGE_PID"
wait
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv > "$LOGS/gpu.txt" 2>&1
tar czf "$OUT/logs.tgz" -C "$LOGS" .
shopt -s nullglob
for r in gpu-runs/motion/*/; do
  tar czf "$OUT/motion-$(basename "$r").tgz" -C gpu-runs/motion "$(basename "$r")"
done
tar czf "$OUT/meta64-eval.tgz" gpu-runs/meta64/eval-* gpu-runs/meta64/dynamics/*.csv \
  gpu-runs/meta64/dynamics/*.json 2> /dev/null
ls -la "$OUT"; cat "$LOGS"/*/summary.txt
