#!/usr/bin/env bash
# A preset for a short GPU run (docs/gpu.md): train.steps set to STEPS and train.warmup_steps to
# 10% of them, so that the loss can fall within them; with BATCH, train.batch_size too (a
# per-GPU batch that fits one card); everything else is the preset.
#   scripts/gpu/short_config.sh PRESET STEPS OUT [BATCH]
set -euo pipefail
batch=()
[ -n "${4:-}" ] && batch=(-e "s/^  batch_size: .*/  batch_size: $4/")
sed -e "s/^  steps: .*/  steps: $2/" -e "s/^  warmup_steps: .*/  warmup_steps: $(($2 / 10))/" \
  "${batch[@]}" "$1" > "$3"
