#!/usr/bin/env bash
# Builds and checks wmkit on a GPU machine that cannot install packages (docs/gpu.md): the model
# stages only (WM_MODEL_ONLY, no OpenCV/PCL/Ceres/HDF5/protobuf), against the CUDA LibTorch of the
# machine's PyTorch. Stages run in the order given; each writes LOG_DIR/<stage>.log and a line to
# LOG_DIR/summary.txt, and a failed stage does not stop the later ones.
#
#   scripts/gpu/run.sh [--logs DIR] [--data DIR] STAGE...
#     build   configure + build into build-gpu (ninja if present); TARGETS=... builds only those
#     test    ctest of that build
#     bench   scripts/gpu/bench.sh: meta64 tokenizer frames/s, dynamics tokens/s, two attentions
#     check   scripts/gpu/check.py: CUDA vs CPU numerics; FLOPs per step and a profile (MFU), on
#             `bench`'s runs or CHECK_TOKENIZER / CHECK_DYNAMICS
#     train   scripts/gpu/train_presets.sh: presets on CUDA bf16, resume, eval, CPU load-back
#     nccl    wm-train through NCCL as a launcher starts one rank (WORLD_SIZE=1), after `train`
#     motion  scripts/gpu/motion_runs.sh: motion model variants on make demo's shards (MOTION_S s)
#     gdb     backtraces (cuda-gdb) of the tests that crashed in `test`
# DATA (default gpu-data) is what scripts/gpu/make_data.sh wrote on a full build.
set -uo pipefail
LOG_DIR=${OUT:-gpu-logs}
DATA=gpu-data
while [[ $# -gt 0 && $1 == --* ]]; do
  case $1 in
    --logs) LOG_DIR=$2; shift 2 ;;
    --data) DATA=$2; shift 2 ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$LOG_DIR"
DATA=$(realpath -m "$DATA")
BUILD=build-gpu
PYTHON=${WM_GPU_PYTHON:-$(command -v python3)}
export PYTHONUNBUFFERED=1

stage_build() {
  local torch_prefix generator=()
  torch_prefix=$("$PYTHON" -c 'import torch; print(torch.utils.cmake_prefix_path)') || return 1
  command -v ninja > /dev/null && generator=(-G Ninja)
  "$PYTHON" -c 'import torch; print("torch", torch.__version__, "cuda", torch.version.cuda,
    "cxx11 abi", torch.compiled_with_cxx11_abi(), torch.cuda.get_device_name(0))'
  cmake --version | head -1; c++ --version | head -1; nvcc --version | tail -1
  cmake -S . -B "$BUILD" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DWM_MODEL_ONLY=ON \
    -DWM_BUILD_BENCH=OFF -DCMAKE_PREFIX_PATH="$torch_prefix" -DWM_PYTHON="$PYTHON" \
    -DTORCH_CUDA_ARCH_LIST=9.0 || return 1
  cmake --build "$BUILD" -j "$(nproc)" ${TARGETS:+--target $TARGETS} -- -k 0
}

# The image's Python has no jsonschema and cannot install it: Debian's pure-Python package
# (scripts/gpu/make_data.sh carries its .debs in DATA/pydebs) is unpacked and put on PYTHONPATH.
python_test_deps() {
  "$PYTHON" -c 'import jsonschema' 2> /dev/null && return
  local debs=("$DATA"/pydebs/*.deb) prefix=$PWD/$BUILD/pydeps
  [ -f "${debs[0]}" ] || { echo "no jsonschema and no $DATA/pydebs: 7 tests will fail"; return; }
  for deb in "${debs[@]}"; do dpkg -x "$deb" "$prefix"; done
  export PYTHONPATH=$prefix/usr/lib/python3/dist-packages${PYTHONPATH:+:$PYTHONPATH}
  "$PYTHON" -c 'import jsonschema; print("jsonschema from", jsonschema.__file__)'
}

stage_test() {
  python_test_deps
  ctest --test-dir "$BUILD" -j 8 --output-on-failure --timeout 600 ${TESTS:+-R "$TESTS"}
}

stage_gdb() {
  grep -o '[A-Za-z]*Test\.[A-Za-z]* (SEGFAULT)' "$LOG_DIR/test.log" | head -n 2 |
    while read -r name _; do
      local binary
      binary=$(ctest --test-dir "$BUILD" -N -V -R "^$name\$" | grep -o '/[^ ]*/bin/[a-z_]*' | head -1)
      cuda-gdb -batch -ex run -ex bt --args "$binary" --gtest_filter="$name" 2>&1 | tail -n 40
    done
}

stage_bench() { bash scripts/gpu/bench.sh "$BUILD/bin" "$DATA" "$LOG_DIR"; }

stage_train() { bash scripts/gpu/train_presets.sh "$BUILD/bin" "$DATA" "$LOG_DIR"; }

# A process group of one, as torchrun makes for --nproc-per-node 1: NCCL's all-reduce runs every
# step (the log names the backend), and the time per step phase (WM_STEP_TIMES) says where the
# MFU goes. Uses the meta64 tokens that `train` wrote.
stage_nccl() {
  local run=gpu-runs/nccl
  rm -rf "$run"
  WORLD_SIZE=1 RANK=0 LOCAL_RANK=0 MASTER_ADDR=127.0.0.1 MASTER_PORT=29531 WM_STEP_TIMES=1 \
    "$BUILD/bin/wm-train" --config configs/dynamics/meta64.yaml \
    --tokens gpu-runs/meta64/tokens/train --out "$run" --device cuda --steps 10 2>&1 | grep -v '%'
}

stage_motion() {
  bash scripts/gpu/motion_runs.sh "$BUILD/bin" "${TABLETOP64:-data/demo/shards}" "$LOG_DIR" \
    "${MOTION_S:-300}"
}

stage_check() {
  "$PYTHON" scripts/gpu/check.py --bin "$BUILD/bin" --out "$LOG_DIR" \
    --tokenizer "${CHECK_TOKENIZER:-gpu-runs/bench/tokenizer}" \
    --dynamics "${CHECK_DYNAMICS:-gpu-runs/bench/dyn-fused/checkpoint.wmt}"
}

for stage in "$@"; do
  start=$SECONDS
  "stage_$stage" > "$LOG_DIR/$stage.log" 2>&1
  rc=$?
  echo "$stage: exit $rc in $((SECONDS - start)) s" | tee -a "$LOG_DIR/summary.txt"
  tail -n 40 "$LOG_DIR/$stage.log"
done
