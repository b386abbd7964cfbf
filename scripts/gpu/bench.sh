#!/usr/bin/env bash
# GPU speed (docs/gpu.md): meta64 tokenizer training and encoding frames/s, and meta64 dynamics
# training tokens/s with bf16 autocast, with fused attention (the default on CUDA) and with
# WM_ATTENTION=explicit (the written-out attention). Rates come from the tools' own summary
# lines; a variant that fails (out of memory) is reported and the next one runs.
#   scripts/gpu/bench.sh BIN DATA LOG_DIR [RUNS]
set -euo pipefail
BIN=$1 DATA=$2 RUNS=${4:-gpu-runs}/bench
DYN_STEPS=${DYN_STEPS:-20}
mkdir -p "$RUNS"
data=$DATA/tabletop64
bash scripts/gpu/short_config.sh configs/tokenizer/meta64.yaml 100 "$RUNS/tokenizer.yaml"
[ -f "$RUNS/tokenizer/checkpoint.wmt" ] ||
  "$BIN/wm-tokenize" train --config "$RUNS/tokenizer.yaml" --data "$data/train" \
    --device cuda --out "$RUNS/tokenizer" 2>&1 | grep -v '%'
echo "tokenizer training: $(tail -n 1 "$RUNS/tokenizer/metrics.csv")  (last column frames/s)"
rm -rf "$RUNS/tokens"
start=$(date +%s%N)
"$BIN/wm-tokenize" encode --checkpoint "$RUNS/tokenizer" --data "$data/train" \
  --out "$RUNS/tokens" --device cuda 2>&1 | grep -v '%'
echo "encode wall time: $((($(date +%s%N) - start) / 1000000)) ms (start-up and PNG decoding included)"
for attention in fused explicit; do
  rm -rf "$RUNS/dyn-$attention"
  echo "== meta64 dynamics, $attention attention, $DYN_STEPS steps"
  WM_ATTENTION=$attention "$BIN/wm-train" --config configs/dynamics/meta64.yaml \
    --tokens "$RUNS/tokens" --out "$RUNS/dyn-$attention" --device cuda --steps "$DYN_STEPS" \
    2>&1 | grep -v '%' | tail -n 2 || echo "$attention attention failed"
done
