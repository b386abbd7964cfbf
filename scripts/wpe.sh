#!/usr/bin/env bash
# `make wpe WPE_DIR=...`: policy evaluation in the world model (WPE, issue 21) end to end on the
# tabletop world: the demo's data and model (scripts/demo.sh, reused when already there), the
# true values of the policies in configs/policies/tabletop.yaml from the simulator
# (wm-sim-policy), their values estimated closed loop in the world model (wm-eval --policy), and
# the WPE table (wpe.csv) and summary (wpe_summary.json). About 12 minutes on 2 cores.
#   scripts/wpe.sh BIN OUT
# Settings (environment): SIM_EPISODES (100: episodes per policy in the simulator), STARTS (16:
# held-out first frames the world model starts from, the demo's whole val split), HORIZON (40:
# policy steps, as the simulator's), ROLLOUTS (1 per start), POLICIES (the policy list),
# DYN_THREADS (1: the model's intra-op threads here and in scripts/demo.sh; 2 on a quiet machine).
set -euo pipefail
BIN=${1:-build/bin}
OUT=${2:-data/wpe}
SIM_EPISODES=${SIM_EPISODES:-100}
STARTS=${STARTS:-16}
HORIZON=${HORIZON:-40}
ROLLOUTS=${ROLLOUTS:-1}
POLICIES=${POLICIES:-configs/policies/tabletop.yaml}
DEMO=$OUT/demo
start=$(date +%s)

echo "== 1/3 the demo's data and world model (scripts/demo.sh) -> $DEMO"
if [ ! -f "$DEMO/run/dynamics/checkpoint.wmt" ] || [ ! -f "$DEMO/reports/compare.csv" ]; then
  bash scripts/demo.sh "$BIN" "$DEMO"
else
  echo "already made"
fi

echo
echo "== 2/3 true values: every policy closed loop in the simulator ($SIM_EPISODES val episodes)"
# The demo's data: seed 0, 64 px, plain look, val split; the same first frames the model gets.
"$BIN/wm-sim-policy" --out "$OUT/truth" --size 64 --look plain --seed 0 --split val \
  --episodes "$SIM_EPISODES" --max-steps "$HORIZON" --policies "$POLICIES" --no-dataset

echo
echo "== 3/3 the same policies closed loop in the world model ($STARTS starts x $ROLLOUTS)"
"$BIN/wm-eval" --checkpoint "$DEMO/run/dynamics" --name dynamics \
  --tokenizer "$DEMO/run/tokenizer" --data "$DEMO/shards/val" --tokens "$DEMO/run/tokens/val" \
  --out "$OUT/reports" --episodes "$STARTS" --policy-horizon "$HORIZON" \
  --policy-rollouts "$ROLLOUTS" --temperature 0 --threads "${DYN_THREADS:-1}" --policies "$POLICIES" \
  --true-values "$OUT/truth/policy_values.json"

echo
/usr/bin/python3 - "$OUT/reports/dynamics" <<'PY'
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
echo
echo "wpe finished in $(( $(date +%s) - start )) s: truth $OUT/truth, report $OUT/reports/dynamics" \
  "(wpe.csv, wpe_summary.json, wm_values.csv, wm_episodes.csv, strips/)"
