#!/usr/bin/env bash
# The GPU presets on CUDA with bf16 (docs/gpu.md): for meta64 (64x64 frames, 16x16 tokens) and
# whale-x / whale-x-small (256x256 frames), a tokenizer and a dynamics model each trained for a
# few hundred steps, stopped half-way and resumed (--resume on CUDA), the tokens encoded on the
# GPU, wm-eval on the GPU, and the GPU-trained checkpoints loaded back on the CPU.
#   scripts/gpu/train_presets.sh BIN DATA LOG_DIR [RUNS]
# The presets' warm-up (10k / 5k steps) is shortened to 10% of the steps run here, so that the
# loss can fall within them; everything else is the preset.
set -euo pipefail
BIN=$1 DATA=$2 LOGS=$3 RUNS=${4:-gpu-runs}
TOK_STEPS=${TOK_STEPS:-400} DYN_STEPS=${DYN_STEPS:-400}
# whale-x-small's batch 64 did not fit one H200 (docs/gpu.md): WHALE_BATCH sets a per-GPU batch.
mkdir -p "$RUNS" "$LOGS"

# Trains half the steps, then resumes to the end: the second process continues from the
# checkpoint the first wrote on the GPU.
train_twice() {  # tool... (ends with --out DIR)
  "$@" --stop-after "$HALF"
  "$@" --resume
}

run_preset() {  # name tokenizer-preset dynamics-preset data [dynamics batch]
  local name=$1 tok=$2 dyn=$3 data=$4 dyn_batch=${5:-} run=$RUNS/$1
  mkdir -p "$run"
  bash scripts/gpu/short_config.sh "$tok" "$TOK_STEPS" "$run/tokenizer.yaml"
  bash scripts/gpu/short_config.sh "$dyn" "$DYN_STEPS" "$run/dynamics.yaml" "$dyn_batch"
  echo "== $name tokenizer ($tok, $TOK_STEPS steps, cuda)"
  HALF=$((TOK_STEPS / 2)) train_twice "$BIN/wm-tokenize" train --config "$run/tokenizer.yaml" \
    --data "$data/train" --val-data "$data/val" --device cuda --out "$run/tokenizer"
  for split in train val; do
    "$BIN/wm-tokenize" encode --checkpoint "$run/tokenizer" --data "$data/$split" \
      --out "$run/tokens/$split" --device cuda
  done
  echo "== $name: the GPU tokenizer encodes val on the CPU"
  "$BIN/wm-tokenize" encode --checkpoint "$run/tokenizer" --data "$data/val" \
    --out "$run/tokens/val-cpu" --device cpu --threads 16
  echo "== $name dynamics ($dyn, $DYN_STEPS steps, cuda, bf16)"
  HALF=$((DYN_STEPS / 2)) train_twice "$BIN/wm-train" --config "$run/dynamics.yaml" \
    --tokens "$run/tokens/train" --val-tokens "$run/tokens/val" --device cuda --out "$run/dynamics"
  echo "== $name wm-eval on the GPU, then the same checkpoint on the CPU"
  for device in cuda cpu; do
    "$BIN/wm-eval" --checkpoint "$run/dynamics" --tokenizer "$run/tokenizer" \
      --data "$data/val" --tokens "$run/tokens/val" --out "$run/eval-$device" --device "$device" \
      --horizon 2 --episodes 2 --temperature 0 --decode-steps 2 --videos 0 --masks files \
      --seg-config configs/segmentation/tabletop.yaml --resamples 200
  done
  cp "$run"/tokenizer/*.csv "$run"/dynamics/*.csv "$LOGS/" 2>/dev/null || true
  for f in "$run"/tokenizer/metrics.csv "$run"/dynamics/metrics.csv; do
    echo "$f: first and last rows"; sed -n '1,2p;$p' "$f"
  done
}

for preset in ${PRESETS:-meta64 whale-x-small}; do
  case $preset in
    meta64) run_preset meta64 configs/tokenizer/meta64.yaml configs/dynamics/meta64.yaml \
      "$DATA/tabletop64" ;;
    whale-x-small) run_preset whale-x-small configs/tokenizer/whale-x.yaml \
      configs/dynamics/whale-x-small.yaml "$DATA/tabletop256" "${WHALE_BATCH:-}" ;;
  esac
done
