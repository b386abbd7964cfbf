#!/usr/bin/env bash
# Makes, on a full build, the datasets that scripts/gpu/run.sh needs on a GPU machine that has no
# wm-gen-tabletop / wm-ingest (WM_MODEL_ONLY builds): plain-look tabletop shards at 64x64 (meta64)
# and 256x256 (whale-x). Prints the total size,
# which must stay well under the 64 MiB a device call carries with the working tree.
#   [SETS=...] [EPISODES_256="TRAIN VAL"] scripts/gpu/make_data.sh [BIN] [OUT]
#   (defaults: build/bin gpu-data)
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-gpu-data}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

tabletop() {  # name size train val [more wm-gen-tabletop flags]
  local name=$1 size=$2 train=$3 val=$4
  shift 4
  [ -f "$OUT/$name/val/index.json" ] && return
  "$BIN/wm-gen-tabletop" --out "$TMP/$name" --seed 0 --size "$size" --train-episodes "$train" \
    --val-episodes "$val" --look plain "$@" > /dev/null
  for split in train val; do
    "$BIN/wm-ingest" --format rlds --input "$TMP/$name/wm_tabletop/1.0.0" --split "$split" \
      --output "$OUT/$name/$split" --log-level warn
  done
}

# SETS picks them (scripts/gpu/session.sh uses make demo's shards as tabletop64); EPISODES_256
# ("train val") shrinks the 256x256 set to fit beside them in one call's 64 MiB.
for set in ${SETS:-tabletop64 tabletop256}; do
  case $set in
    tabletop64) tabletop tabletop64 64 300 16 ;;
    tabletop256) tabletop tabletop256 256 ${EPISODES_256:-40 8} ;;
  esac
done
du -sh "$OUT"/* "$OUT"
