#!/usr/bin/env bash
# Makes, on a full build, the datasets that scripts/gpu/run.sh needs on a GPU machine that has no
# wm-gen-tabletop / wm-ingest (WM_MODEL_ONLY builds): plain-look tabletop shards at 64x64 (meta64)
# and 256x256 (whale-x), and the .debs of Debian's jsonschema for the tests. Prints the total size,
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
# Debian's pure-Python jsonschema (and what it imports) for the GPU image's Python, which lacks
# it and cannot install it: scripts/gpu/run.sh's `test` stage unpacks these when the import fails
# (7 tests need it; pyrsistent's C extension is for Debian's Python only and falls back to Python).
if ! ls "$OUT"/pydebs/python3-jsonschema_*.deb > /dev/null 2>&1; then
  mkdir -p "$OUT/pydebs"
  (cd "$OUT/pydebs" && apt-get download python3-jsonschema python3-attr python3-pyrsistent \
    > /dev/null 2>&1) || echo "make_data: could not fetch the jsonschema .debs (no apt?)" >&2
fi
du -sh "$OUT"/* "$OUT"
