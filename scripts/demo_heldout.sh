#!/usr/bin/env bash
# scripts/demo.sh's held-out episodes: EPISODES episodes of data seed SEED + 7 in the demo's look,
# never trained on, ingested and encoded with the demo's tokenizer. The demo scores its motion
# model on them beside its 8 val episodes, which cannot measure the block: their paired
# intervals are 1000-1600 wide (docs/motion.md, "A faster learning rate for the pose's
# dynamics"). About 10 s for 300 episodes; a finished set is reused (a partial one is remade).
#   scripts/demo_heldout.sh BIN OUT TOKENIZER SEED LOOK EPISODES
set -euo pipefail
if [ $# -ne 6 ]; then
  sed -n '2,7p' "$0" >&2
  exit 2
fi
BIN=$1 OUT=$2 TOKENIZER=$3 SEED=$4 LOOK=$5 EPISODES=$6
if [ -f "$OUT/tokens/index.json" ]; then
  echo "already made"
  exit 0
fi
rm -rf "$OUT"
# 16 training episodes: the generator needs some; the val split is what is scored.
"$BIN/wm-gen-tabletop" --out "$OUT/raw" --seed $((SEED + 7)) --size 64 --train-episodes 16 \
  --val-episodes "$EPISODES" --look "$LOOK"
"$BIN/wm-ingest" --format rlds --input "$OUT/raw/wm_tabletop/1.0.0" --split val \
  --output "$OUT/shards" --shard-size-mb 8
"$BIN/wm-tokenize" encode --checkpoint "$TOKENIZER" --data "$OUT/shards" --out "$OUT/tokens"
