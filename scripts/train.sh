#!/usr/bin/env bash
# `make train`: tokenizer -> token datasets -> dynamics model, one run directory, rerunnable.
# Every stage resumes (a finished stage is a no-op), so a killed run continues where it stopped.
#   scripts/train.sh BIN RUN TRAIN_SHARDS VAL_SHARDS [TOKENIZER_CONFIG] [DYNAMICS_CONFIG]
# Extra flags: TOKENIZER_ARGS / DYNAMICS_ARGS in the environment (e.g. DYNAMICS_ARGS="--steps
# 300 --threads 2"); TOKENS_ONLY=1 stops after encoding (`make tokenize`).
# Layout: RUN/tokenizer, RUN/tokens/{train,val}, RUN/dynamics.
set -euo pipefail
if [ $# -lt 4 ]; then
  sed -n '2,8p' "$0" >&2
  exit 2
fi
BIN=$1 RUN=$2 TRAIN=$3 VAL=$4
TOK_CONFIG=${5:-configs/tokenizer/tiny.yaml}
DYN_CONFIG=${6:-configs/dynamics/tiny.yaml}
resume_flag() { if [ -f "$1/checkpoint.wmt" ]; then echo --resume; fi; }

echo "== tokenizer: $TOK_CONFIG on $TRAIN -> $RUN/tokenizer"
# shellcheck disable=SC2046,SC2086
"$BIN/wm-tokenize" train --config "$TOK_CONFIG" --data "$TRAIN" --val-data "$VAL" \
  --out "$RUN/tokenizer" $(resume_flag "$RUN/tokenizer") ${TOKENIZER_ARGS:-}

for split in train val; do
  src=$TRAIN
  [ "$split" = val ] && src=$VAL
  echo "== encode $src -> $RUN/tokens/$split"
  "$BIN/wm-tokenize" encode --checkpoint "$RUN/tokenizer" --data "$src" --out "$RUN/tokens/$split"
done
[ "${TOKENS_ONLY:-0}" = 1 ] && exit 0

echo "== dynamics: $DYN_CONFIG on $RUN/tokens/train -> $RUN/dynamics"
# shellcheck disable=SC2046,SC2086
"$BIN/wm-train" --config "$DYN_CONFIG" --tokens "$RUN/tokens/train" \
  --val-tokens "$RUN/tokens/val" --out "$RUN/dynamics" $(resume_flag "$RUN/dynamics") \
  ${DYNAMICS_ARGS:-}
