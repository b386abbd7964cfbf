#!/usr/bin/env bash
# Prints the demo's motion-model config for a look (plain | varied), so that scripts/demo.sh and
# scripts/wpe.sh (which reuses the demo's motion model) train the same one.
# Plain: the pose kind at the demo's budget (docs/motion.md, "The pose kind"). Varied: the
# layered kind with the motion prior, without which it copies on textured tables
# (docs/motion.md, "The motion prior").
#   scripts/demo_motion_config.sh LOOK
set -euo pipefail
case "${1:-plain}" in
  plain) echo configs/motion/pose_demo.yaml ;;
  varied) echo configs/motion/textured.yaml ;;
  *) echo "demo_motion_config.sh: unknown look '$1' (expected plain or varied)" >&2; exit 2 ;;
esac
