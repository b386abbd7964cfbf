#!/usr/bin/env bash
# `make wpe WPE_DIR=...`: policy evaluation in the world model (WPE, issue 21) end to end on the
# tabletop world: the demo's data and models (scripts/demo.sh, reused when already there), the
# true values of the policies in configs/policies/tabletop.yaml from the simulator
# (wm-sim-policy), their values estimated closed loop in the token world model and in the motion
# model (wm-eval --policy; the motion model's imagined frames scored by a success classifier,
# wm-success train, trained here on the same training frames), and each model's WPE table
# (wpe.csv) and summary (wpe_summary.json). 12.5 minutes on a quiet 2-core machine from nothing
# (753 s measured, session 58, OpenBLAS; 29 minutes with other jobs loading the cores).
#   scripts/wpe.sh BIN OUT
# Settings (environment): SIM_EPISODES (100: episodes per policy in the simulator), STARTS (16:
# held-out first frames the world models start from, the demo's whole val split), HORIZON (40:
# policy steps, as the simulator's), ROLLOUTS (1 per start), POLICIES (the policy list),
# DYN_THREADS (1: the token model's intra-op threads here and in scripts/demo.sh; 2 on a quiet
# machine), MOTION_CONFIG (the demo's: scripts/demo_motion_config.sh plain), SUCCESS_CONFIG
# (configs/success/tiny.yaml).
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-data/wpe}
SIM_EPISODES=${SIM_EPISODES:-100}
STARTS=${STARTS:-16}
HORIZON=${HORIZON:-40}
ROLLOUTS=${ROLLOUTS:-1}
POLICIES=${POLICIES:-configs/policies/tabletop.yaml}
MOTION_CONFIG=${MOTION_CONFIG:-$(bash scripts/demo_motion_config.sh plain)}
SUCCESS_CONFIG=${SUCCESS_CONFIG:-configs/success/tiny.yaml}
DEMO=$OUT/demo
start=$(date +%s)

echo "== 1/5 the demo's data and world models (scripts/demo.sh) -> $DEMO"
if [ ! -f "$DEMO/run/dynamics/checkpoint.wmt" ] || [ ! -f "$DEMO/reports/compare.csv" ]; then
  bash scripts/demo.sh "$BIN" "$DEMO"
else
  echo "already made"
fi

echo
echo "== 2/5 in the background on the other core: the motion model (kept when scripts/demo.sh made it)" \
  "and the success classifier -> $OUT/success (log: $OUT/models.log)"
mkdir -p "$OUT"
(
  set -e
  # Exactly scripts/demo.sh's motion model (same config, data and seed: the same bytes); a
  # finished one is kept as it is.
  MOTION_RESUME=()
  [ -f "$DEMO/run/motion/checkpoint.wmt" ] && MOTION_RESUME=(--resume)
  "$BIN/wm-motion" train --config "$MOTION_CONFIG" --data "$DEMO/shards/train" \
    --val-data "$DEMO/shards/val" --out "$DEMO/run/motion" --seed 0 --threads 1 \
    "${MOTION_RESUME[@]}"
  SUCCESS_RESUME=()
  [ -f "$OUT/success/checkpoint.wmt" ] && SUCCESS_RESUME=(--resume)
  "$BIN/wm-success" train --config "$SUCCESS_CONFIG" --data "$DEMO/shards/train" \
    --val-data "$DEMO/shards/val" --out "$OUT/success" --seed 0 --threads 1 "${SUCCESS_RESUME[@]}"
) > "$OUT/models.log" 2>&1 &
MODELS_PID=$!

echo
echo "== 3/5 true values: every policy closed loop in the simulator ($SIM_EPISODES val episodes)"
# The demo's data: seed 0, 64 px, plain look, val split; the same first frames the models get.
"$BIN/wm-sim-policy" --out "$OUT/truth" --size 64 --look plain --seed 0 --split val \
  --episodes "$SIM_EPISODES" --max-steps "$HORIZON" --policies "$POLICIES" --no-dataset

echo
echo "== 4/5 the same policies closed loop in the token world model ($STARTS starts x $ROLLOUTS)"
# Shared by both models' wm-eval runs: the starts, horizon, rollouts, policies and the truth.
LOOP=(--tokenizer "$DEMO/run/tokenizer" --data "$DEMO/shards/val" --tokens "$DEMO/run/tokens/val"
  --out "$OUT/reports" --episodes "$STARTS" --policy-horizon "$HORIZON"
  --policy-rollouts "$ROLLOUTS" --policies "$POLICIES" --true-values "$OUT/truth/policy_values.json")
"$BIN/wm-eval" --checkpoint "$DEMO/run/dynamics" --name dynamics "${LOOP[@]}" --temperature 0 \
  --threads "${DYN_THREADS:-1}"

echo
echo "== 5/5 the same policies closed loop in the motion model, success from the classifier"
if ! wait "$MODELS_PID"; then
  cat "$OUT/models.log" >&2
  echo "wpe: training the motion model or the success classifier failed (log above)" >&2
  exit 1
fi
grep -v " train .*%" "$OUT/models.log" | tail -n 3
echo "success classifier validation (step, loss, AUROC, accuracy, majority rule, episodes right," \
  "frames, success frames): $(tail -n 1 "$OUT/success/val.csv")"
"$BIN/wm-eval" --checkpoint "$DEMO/run/motion" --name motion --success-model "$OUT/success" \
  "${LOOP[@]}" --threads 1

for model in dynamics motion; do
  echo
  echo "WPE of the $model model ($OUT/reports/$model):"
  /usr/bin/python3 - "$OUT/reports/$model" <<'PY'
import csv, json, os, sys
report = sys.argv[1]
rows = list(csv.DictReader(open(os.path.join(report, "wpe.csv"))))
print("| policy | in distribution | true value [95%] | world-model value [95%] | gap |")
print("| --- | --- | --- | --- | ---: |")
for r in rows:
    f = lambda k: float(r[k])
    print(f"| {r['policy']} | {'yes' if r['in_distribution'] == 'true' else 'no'} | "
          f"{f('true_value'):.2f} [{f('true_ci_low'):.2f}, {f('true_ci_high'):.2f}] | "
          f"{f('wm_value'):.2f} [{f('wm_ci_low'):.2f}, {f('wm_ci_high'):.2f}] | {f('gap'):+.2f} |")
s = json.load(open(os.path.join(report, "wpe_summary.json")))
fmt = lambda v: "undefined" if v is None else f"{v:.3f}"
print()
print(", ".join(f"{k} {fmt(s[k])}" for k in ("spearman", "kendall", "pairwise_accuracy",
      "mean_abs_gap", "optimism", "optimism_in_distribution", "optimism_out_of_distribution")))
PY
done
echo
echo "wpe finished in $(( $(date +%s) - start )) s: truth $OUT/truth, reports $OUT/reports/dynamics" \
  "and $OUT/reports/motion (wpe.csv, wpe_summary.json, wm_values.csv, wm_episodes.csv, strips/)," \
  "success classifier $OUT/success"
