#!/usr/bin/env bash
# The motion model (wm-motion, docs/motion.md) with GPU compute (docs/gpu.md): variants of the CPU
# preset configs/motion/tiny.yaml trained side by side on one GPU on make demo's shards, each for
# as many steps as fit SECONDS seconds at the rate a short probe of all of them together
# measured (capped at MAX_STEPS). The run directories come back to be scored on the CPU with
# wm-eval against the demo's own 1500-step run.
#   scripts/gpu/motion_runs.sh BIN DATA LOG_DIR SECONDS [RUNS]     (DATA: make demo's shards)
set -euo pipefail
BIN=$1 DATA=$2 LOGS=$3 SECONDS_LEFT=$4 RUNS=${5:-gpu-runs/motion}
MAX_STEPS=${MAX_STEPS:-30000} PROBE=${PROBE_STEPS:-100}  # DEVICE (default cuda) too
mkdir -p "$RUNS" "$LOGS"
declare -A EDITS=(
  [tiny]=''
  [unroll8]='s/^  unroll: .*/  unroll: 8/'
  [batch64]='s/^  batch_size: .*/  batch_size: 64/'
)
for v in "${!EDITS[@]}"; do
  sed -e "s/^  checkpoint_every: .*/  checkpoint_every: 1000/" -e "${EDITS[$v]:-s/^//}" \
    configs/motion/tiny.yaml > "$RUNS/$v.yaml"
done

train() {  # variant steps out [more flags]
  "$BIN/wm-motion" train --config "$RUNS/$1.yaml" --data "$DATA/train" --val-data "$DATA/val" \
    --device "${DEVICE:-cuda}" --steps "$2" --out "$3" "${@:4}"
}

start=$(date +%s)
for v in "${!EDITS[@]}"; do
  (
    t0=$(date +%s%N)
    train "$v" "$PROBE" "$RUNS/probe-$v" > "$LOGS/motion-probe-$v.log" 2>&1
    echo $((($(date +%s%N) - t0) / 1000000)) > "$RUNS/probe-$v.ms"
  ) &
done
wait
left_ms=$(((SECONDS_LEFT - ($(date +%s) - start)) * 1000))
for v in "${!EDITS[@]}"; do
  # PROBE steps took probe_ms with all variants on the GPU together, start-up included; 80% of
  # the time left, for the validation rollouts and the final checkpoint.
  if [ ! -s "$RUNS/probe-$v.ms" ]; then
    echo "$v: the probe failed:"; tail -n 5 "$LOGS/motion-probe-$v.log"; continue
  fi
  probe_ms=$(cat "$RUNS/probe-$v.ms")
  steps=$((left_ms * 8 / 10 * PROBE / probe_ms))
  steps=$((steps > MAX_STEPS ? MAX_STEPS : steps))
  if ((steps < 2 * PROBE)); then echo "$v: no time left for a run ($steps steps)"; continue; fi
  echo "$v: $steps steps ($PROBE-step probe beside the others: $probe_ms ms)"
  rm -rf "$RUNS/probe-$v"
  train "$v" "$steps" "$RUNS/$v" > "$LOGS/motion-$v.log" 2>&1 &
done
wait
for v in "${!EDITS[@]}"; do
  echo "$v: $(grep -v '%' "$LOGS/motion-$v.log" | tail -n 1)"
  echo "  val.csv last row: $(tail -n 1 "$RUNS/$v/val.csv" 2>&1)"
done
