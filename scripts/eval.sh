#!/usr/bin/env bash
# `make eval`: wm-eval every checkpoint on held-out data, then wm-report compare (CSV + markdown
# table printed) and wm-report plot.
#   scripts/eval.sh BIN REPORTS TOKENIZER VAL_SHARDS VAL_TOKENS CHECKPOINT...
# Extra wm-eval flags: EVAL_ARGS in the environment (e.g. EVAL_ARGS="--horizon 8 --masks files
# --seg-config configs/segmentation/tabletop.yaml"), extra wm-report compare flags in
# COMPARE_ARGS (e.g. COMPARE_ARGS="--metrics psnr,ssim"). The first checkpoint is the baseline.
# To score some checkpoints while others still train: REPORT=0 scores without comparing; a later
# call with SCORED="NAME..." (report names already in REPORTS) scores only the others, then
# compares and plots them all; a SCORED report must be of the checkpoint given now (the sha256
# its manifest records). EVAL_JOBS=N (default 1) scores as N shard jobs at once on this machine
# (wm-eval --shard-index i --num-shards N): the job that finishes last writes each report,
# byte-identical to one job's.
set -euo pipefail
if [ $# -lt 6 ]; then
  sed -n '2,13p' "$0" >&2
  exit 2
fi
BIN=$1 REPORTS=$2 TOKENIZER=$3 VAL=$4 VAL_TOKENS=$5
shift 5
names=() to_score=() score_names=()
# The sha256 of CHECKPOINT's file (a run directory's checkpoint.wmt), as wm-eval records it.
checkpoint_sha() {
  local file=$1
  [ -d "$file" ] && file=$file/checkpoint.wmt
  sha256sum "$file" | cut -d' ' -f1
}
# The checkpoint sha256 that the report manifest $1 records.
report_sha() {
  /usr/bin/python3 - "$1" <<'PY'
import json, sys
try:
    print(json.load(open(sys.argv[1]))["checkpoint"]["sha256"])
except (OSError, ValueError, KeyError, TypeError) as e:
    sys.exit(f"eval.sh: {sys.argv[1]}: no checkpoint sha256 ({e!r}): not a wm-eval manifest")
PY
}
for ckpt in "$@"; do
  name=$(basename "$ckpt")
  [ "$name" = dynamics ] && name=$(basename "$(dirname "$ckpt")")  # RUN/dynamics -> RUN
  names+=("$name")
  case " ${SCORED:-} " in
    *" $name "*)
      if [ ! -f "$REPORTS/$name/manifest.json" ]; then
        echo "eval.sh: SCORED names $name, but $REPORTS/$name/manifest.json is missing" >&2
        exit 1
      fi
      # A report left by an earlier run of the same name would be compared as this one's.
      scored=$(report_sha "$REPORTS/$name/manifest.json")
      now=$(checkpoint_sha "$ckpt")
      if [ "$scored" != "$now" ]; then
        echo "eval.sh: SCORED names $name, but $REPORTS/$name/manifest.json scored checkpoint" \
          "sha256 $scored, and $ckpt is now $now: drop $name from SCORED to score it again" >&2
        exit 1
      fi ;;
    *) to_score+=("$ckpt") score_names+=("$name") ;;
  esac
done
num_jobs=${EVAL_JOBS:-1}
if ! [[ $num_jobs =~ ^[1-9][0-9]*$ ]]; then
  echo "eval.sh: EVAL_JOBS must be a positive integer (shard jobs at once), got '$num_jobs'" >&2
  exit 2
fi
score() {
  # shellcheck disable=SC2086
  "$BIN/wm-eval" --checkpoint "${to_score[@]}" --name "${score_names[@]}" --tokenizer "$TOKENIZER" \
    --data "$VAL" --tokens "$VAL_TOKENS" --out "$REPORTS" ${EVAL_ARGS:-} "$@"
}
if [ ${#to_score[@]} -gt 0 ]; then
  echo "== wm-eval ${score_names[*]} on $VAL -> $REPORTS"
  if [ "$num_jobs" = 1 ]; then
    score
  else
    pids=()
    for ((i = 0; i < num_jobs; i++)); do
      score --shard-index "$i" --num-shards "$num_jobs" &
      pids+=($!)
    done
    failed=0
    for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
    if [ "$failed" = 1 ]; then
      echo "eval.sh: a wm-eval shard job failed (its error above)" >&2
      exit 1
    fi
  fi
fi
[ "${REPORT:-1}" = 0 ] && exit 0
dirs=()
for n in "${names[@]}"; do dirs+=("$REPORTS/$n"); done
echo "== wm-report compare -> $REPORTS/compare.csv"
# shellcheck disable=SC2086 # COMPARE_ARGS is a list of flags, split on purpose
"$BIN/wm-report" compare "${dirs[@]}" --baseline "${names[0]}" --out "$REPORTS/compare.csv" \
  --markdown "$REPORTS/compare.md" ${COMPARE_ARGS:-}
cat "$REPORTS/compare.md"
echo "== wm-report plot -> $REPORTS/plots"
"$BIN/wm-report" plot "${dirs[@]}" --out "$REPORTS/plots"
