#!/usr/bin/env bash
# A preset for a short GPU run (docs/gpu.md): train.steps set to STEPS and train.warmup_steps to
# 10% of them, so that the loss can fall within them; everything else is the preset.
#   scripts/gpu/short_config.sh PRESET STEPS OUT
set -euo pipefail
sed -e "s/^  steps: .*/  steps: $2/" -e "s/^  warmup_steps: .*/  warmup_steps: $(($2 / 10))/" "$1" > "$3"
