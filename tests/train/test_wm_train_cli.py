#!/usr/bin/python3
"""wm-train end to end: --help/--version/exit codes, config errors naming the key, fine-tuning
(--init-from, --freeze: provenance and the schema, one-line shape errors), and data
parallelism: `--nproc 2` (two processes, each sampling half of the global batch, gradients
all-reduced) follows the single-process loss curve and ends at the same weights within float
tolerance."""
import json
import os
import subprocess
import sys
import tempfile

import jsonschema
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import dynamics_twin  # noqa: E402
from check_list import CheckList, free_port  # noqa: E402

BIN = os.environ.get("WM_BIN_DIR", "build/bin")
SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
CONFIG = """model: {grid_h: 4, grid_w: 4, num_codes: 32, context_frames: 4, d_model: 32,
        num_layers: 2, num_heads: 4, mlp_ratio: 2}
policy: {d_model: 16, num_heads: 2, posterior_layers: 1, prior_layers: 1, decoder_layers: 1,
         categories: 4, classes: 4}
train: {batch_size: 4, steps: 30, warmup_steps: 3, max_lr: 3.0e-3, threads: 1, log_every: 1,
        checkpoint_every: 30}
"""
check = CheckList()


def run(args, **kw):
    return subprocess.run([os.path.join(BIN, "wm-train")] + args, capture_output=True, text=True,
                          **kw)


def losses(run_dir):
    rows = open(os.path.join(run_dir, "metrics.csv")).read().split("\n")[1:]
    return np.array([[float(x) for x in r.split(",")[1:8]] for r in rows if r])


def fine_tune(tmp, cfg, tokens, parent):
    """--init-from PARENT --freeze policy: runs, records the parent, validates; shape errors and
    --freeze without --init-from are one-line errors."""
    ft = os.path.join(tmp, "ft")
    r = run(["--config", cfg, "--tokens", tokens, "--out", ft, "--steps", "5",
             "--init-from", parent, "--freeze", "policy"])
    check(r.returncode == 0, "--init-from --freeze policy runs" + r.stderr[-300:])
    if r.returncode != 0:
        return
    manifest = json.load(open(os.path.join(ft, "checkpoint.json")))
    schema = json.load(open(os.path.join(SRC, "schemas", "dynamics-checkpoint.schema.json")))
    try:
        jsonschema.validate(manifest, schema)
        check(True, "a fine-tune's checkpoint.json validates")
    except jsonschema.ValidationError as e:
        check(False, "fine-tune checkpoint.json: %s" % e.message)
    init = manifest.get("init_from", {})
    parent_json = json.load(open(os.path.join(parent, "checkpoint.json")))
    check(init.get("checkpoint_sha256") == parent_json["checkpoint"]["sha256"]
          and init.get("freeze") == ["policy"] and init.get("step") == 30,
          "init_from records the parent's checkpoint sha256, step and --freeze")
    wide = os.path.join(tmp, "wide.yaml")
    open(wide, "w").write(CONFIG.replace("d_model: 32", "d_model: 64"))
    r = run(["--config", wide, "--tokens", tokens, "--out", os.path.join(tmp, "w"),
             "--init-from", parent])
    check(r.returncode == 1 and r.stderr.count("\n") == 1 and
          "model.d_model is 32 in the parent, 64 here" in r.stderr,
          "shape mismatch: one line naming the key and both values (%r)" % r.stderr.strip())
    r = run(["--config", cfg, "--tokens", tokens, "--out", os.path.join(tmp, "f"),
             "--freeze", "policy"])
    check(r.returncode != 0 and "--init-from" in r.stderr, "--freeze needs --init-from")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        tokens, cfg = os.path.join(tmp, "tokens"), os.path.join(tmp, "cfg.yaml")
        subprocess.run([os.path.join(BIN, "dynamics_test_tool"), "make-tokens", "--out", tokens,
                        "--episodes", "12", "--steps", "10", "--grid", "4", "--codes", "32"],
                       check=True)
        open(cfg, "w").write(CONFIG)

        h = run(["--help"])
        check(h.returncode == 0 and "Example:" in h.stdout and "--nproc" in h.stdout, "--help")
        check(run(["--version"]).stdout.startswith("wm-train"), "--version")
        check(run(["--config", cfg]).returncode == 2, "missing --tokens is a usage error (exit 2)")
        r = run(["--config", cfg, "--tokens", tokens, "--out", os.path.join(tmp, "x"), "--steps", "0"])
        check(r.returncode == 2 and "--steps" in r.stderr, "--steps 0 is a usage error (exit 2)")
        bad = os.path.join(tmp, "bad.yaml")
        open(bad, "w").write("model:\n  num_heads: 0\n")
        r = run(["--config", bad, "--tokens", tokens, "--out", os.path.join(tmp, "bad")])
        check(r.returncode == 1 and "key 'model.num_heads'" in r.stderr and r.stderr.count("\n") == 1,
              "config error: exit 1, one line naming the key (%r)" % r.stderr.strip())
        r = run(["--config", cfg, "--tokens", tokens, "--out", os.path.join(tmp, "bad2")],
                env=dict(os.environ, WORLD_SIZE="x"))
        check(r.returncode == 1 and "WORLD_SIZE" in r.stderr, "malformed WORLD_SIZE names it")

        one, two = os.path.join(tmp, "one"), os.path.join(tmp, "two")
        r1 = run(["--config", cfg, "--tokens", tokens, "--out", one])
        r2 = run(["--config", cfg, "--tokens", tokens, "--out", two, "--nproc", "2"])
        ok = r1.returncode == 0 and r2.returncode == 0
        check(ok, "1- and 2-process runs succeed" + ("" if ok else r1.stderr[-300:] + r2.stderr[-300:]))
        if r1.returncode == 0 and r2.returncode == 0:
            a, b = losses(one), losses(two)
            err = np.max(np.abs(a - b) / np.maximum(1.0, np.abs(a)))
            check(a.shape == b.shape and err < 1e-4,
                  "2 processes follow the 1-process loss curve (max rel diff %.2e)" % err)
            ta, _ = dynamics_twin.read_archive(os.path.join(one, "checkpoint.wmt"))
            tb, _ = dynamics_twin.read_archive(os.path.join(two, "checkpoint.wmt"))
            werr = max(float(np.max(np.abs(ta[k] - tb[k]))) for k in ta if k.startswith("model/"))
            check(werr < 1e-4, "2-process weights equal 1-process weights (max diff %.2e)" % werr)
            check(not os.path.exists(os.path.join(two, ".checkpoint.wmt.tmp")), "no temp files")
            launched = os.path.join(tmp, "launched")
            r3 = run(["--config", cfg, "--tokens", tokens, "--out", launched],
                     env=dict(os.environ, WORLD_SIZE="1", RANK="0", MASTER_PORT=str(free_port()),
                              WM_STEP_TIMES="1"))
            check(r3.returncode == 0 and "data parallel: 1 rank, " in r3.stderr,
                  "WORLD_SIZE=1 makes a process group of one (%r)" % r3.stderr[-300:])
            check("step phases: batch " in r3.stderr and "optimizer" in r3.stderr
                  and "per step over 30 steps" in r3.stderr,
                  "WM_STEP_TIMES=1 logs the time per step phase")
            if r3.returncode == 0:
                check(np.array_equal(losses(launched), a),
                      "a process group of one follows the plain run's loss curve exactly")
            manifest = json.load(open(os.path.join(one, "checkpoint.json")))
            for part, name in ((manifest, "dynamics-checkpoint"),
                               (manifest["config"], "dynamics-config")):
                schema = json.load(open(os.path.join(SRC, "schemas", name + ".schema.json")))
                try:
                    jsonschema.validate(part, schema)
                    check(True, "checkpoint.json validates against %s.schema.json" % name)
                except jsonschema.ValidationError as e:
                    check(False, "checkpoint.json, %s.schema.json: %s" % (name, e.message))
            fine_tune(tmp, cfg, tokens, one)
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
