#!/usr/bin/env bash
# `make demo`: the embedded synthetic tabletop dataset, in real RLDS TFRecord form, through the
# pipeline stages that exist so far: generate -> ingest (train, val) -> verify -> summary.
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-data/demo}
SEED=${SEED:-0}
RAW=$OUT/raw
SHARDS=$OUT/shards
start=$(date +%s)

echo "== 1/3 generate the synthetic tabletop dataset (RLDS/TFDS layout) -> $RAW"
if [ ! -f "$RAW/wm_tabletop/1.0.0/dataset_info.json" ]; then
  "$BIN/wm-gen-tabletop" --out "$RAW" --seed "$SEED"
else
  echo "already generated"
fi

echo "== 2/3 ingest train and val splits -> $SHARDS"
for split in train val; do
  "$BIN/wm-ingest" --format rlds --input "$RAW/wm_tabletop/1.0.0" --split "$split" \
    --output "$SHARDS/$split" --shard-size-mb 8
done

echo "== 3/3 verify every checksum, and cross-check with the independent Python reader"
for split in train val; do
  "$BIN/wm-shard" verify "$SHARDS/$split"
  /usr/bin/python3 scripts/wmshard.py "$SHARDS/$split" --verify
done

echo
echo "== summary"
/usr/bin/python3 - "$SHARDS" <<'PY'
import json, sys, os
root = sys.argv[1]
for split in ("train", "val"):
    ix = json.load(open(os.path.join(root, split, "index.json")))
    size = sum(s["bytes"] for s in ix["shards"])
    image = ix["features"]["image"]
    print(f"{split:5s}: {ix['num_episodes']} episodes, {ix['num_steps']} steps, "
          f"{len(ix['shards'])} shard(s), {size/1e6:.1f} MB, image {image['shape']} {image['encoding']}, "
          f"streams {sorted(k for k in ix['features'] if k != 'action')}")
    st = ix["action_stats"]
    print("       action mean " + " ".join(f"{v:+.3f}" for v in st["mean"]))
    print("       action std  " + " ".join(f"{v:.3f}" for v in st["std"]))
PY
echo "demo finished in $(( $(date +%s) - start )) s; datasets in $SHARDS (inspect: $BIN/wm-shard info $SHARDS/train)"
