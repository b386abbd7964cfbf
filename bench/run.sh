#!/usr/bin/env bash
# `make bench`: each benchmark prints wmkit's speed beside a reference measured in the same run.
#   1. ingest throughput vs the OpenCV decode bound (generated 128x128 tabletop set), and HDF5
#      demo loading in a child process vs in-process (a generated LIBERO-sized file)
#   2. SSIM + PSNR vs scikit-image on 256x256 RGB pairs: in memory, and wm-metrics end to end
#      (process start, PNG reading) vs a scikit-image script
#   3. LPIPS vs the PyTorch reference on the same (random) weights
#   4. tokenizer training and encoding vs its PyTorch twin (needs tokenizer_ref_tool: tests on)
#   5. closed-loop imagination: the batched, cached path of wm-eval --policy vs one episode at a
#      time (needs the demo's models: make demo; DEMO_DIR, IMAGINE_THREADS), for the token model,
#      then the motion model with a success classifier (make wpe's: WPE_DIR)
#   6. the motion nets' upsampling (UpConv, phase by phase) vs ATen's conv_transpose2d, forward
#      and backward at the eraser's shapes on one thread
set -euo pipefail
BIN=${1:-build/bin}
WORK=${BENCH_DIR:-/tmp/wmkit-bench}
if [ ! -f "$WORK/raw/wm_tabletop/1.0.0/dataset_info.json" ]; then
  "$BIN/wm-gen-tabletop" --out "$WORK/raw" --train-episodes 96 --val-episodes 4 --size 128 \
    --max-steps 40 --seed 1 > /dev/null 2>&1
fi
echo "== ingest"
"$BIN/ingest_bench" --input "$WORK/raw/wm_tabletop/1.0.0" --threads "$(nproc)" --repeats 3
if [ ! -f "$WORK/libero_like.hdf5" ]; then
  /usr/bin/python3 - "$WORK/libero_like.hdf5" <<'PY'
import sys, h5py, numpy as np
rng = np.random.default_rng(0)
with h5py.File(sys.argv[1], "w") as f:  # 20 demos x 120 frames of 128x128 RGB, gzip as LIBERO
    for n in range(20):
        g = f.create_group(f"data/demo_{n}")
        g["actions"] = rng.uniform(-1, 1, (120, 7))
        ramp = np.linspace(0, 255, 128 * 128 * 3).reshape(128, 128, 3)
        frames = (ramp[None] + rng.integers(0, 40, (120, 1, 1, 3))).astype(np.uint8)
        g.create_dataset("obs/agentview_rgb", data=frames, compression="gzip")
PY
fi
"$BIN/hdf5_isolation_bench" --input "$WORK/libero_like.hdf5" --repeats 3
echo "== metrics: SSIM + PSNR"
/usr/bin/python3 bench/metrics_bench.py --bin "$BIN"
echo "== metrics: wm-metrics start and 120 PNG pairs end to end"
/usr/bin/python3 bench/metrics_startup_bench.py --bin "$BIN"
echo "== metrics: LPIPS"
/usr/bin/python3 bench/lpips_bench.py --bin "$BIN"
echo "== dynamics: training tokens/s vs the PyTorch twin"
/usr/bin/python3 bench/dynamics_bench.py --bin "$BIN"
echo "== tokenizer: wm-tokenize vs the PyTorch twin"
/usr/bin/python3 bench/tokenizer_bench.py --bin "$BIN"
echo "== imagination: closed-loop frames/s, batched + cached vs one episode at a time"
DEMO=${DEMO_DIR:-data/demo}/run
if [ -f "$DEMO/dynamics/checkpoint.wmt" ]; then
  "$BIN/imagination_bench" --checkpoint "$DEMO/dynamics" --tokenizer "$DEMO/tokenizer" \
    --tokens "$DEMO/tokens/val" --episodes 16 --horizon 40 --threads "${IMAGINE_THREADS:-2}"
else
  echo "skipped: no $DEMO/dynamics (run make demo first)"
fi
echo "== imagination: the motion model's closed-loop frames/s, batched vs one episode at a time"
SUCCESS=${WPE_DIR:-data/wpe}/success
if [ -f "$DEMO/motion/checkpoint.wmt" ] && [ -f "$SUCCESS/checkpoint.wmt" ]; then
  "$BIN/motion_imagination_bench" --checkpoint "$DEMO/motion" --success-model "$SUCCESS" \
    --data "${DEMO_DIR:-data/demo}/shards/val" --episodes 16 --horizon 40 \
    --threads "${IMAGINE_THREADS:-2}"
else
  echo "skipped: no $DEMO/motion or $SUCCESS (run make wpe first)"
fi
echo "== motion: UpConv vs ATen's conv_transpose2d (forward + backward, 1 thread)"
"$BIN/motion_blocks_bench"
