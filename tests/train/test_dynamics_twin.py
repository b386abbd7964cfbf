#!/usr/bin/python3
"""The C++ dynamics model and its PyTorch twin (dynamics_twin.py) give the same forward outputs
and losses to 1e-5 on the same weights: dynamics_test_tool writes random weights, inputs and
its outputs into a tensor archive; the twin loads the weights (strict) and recomputes."""
import os
import subprocess
import sys
import tempfile

import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import dynamics_twin  # noqa: E402

TOL = 1e-5


def check_case(tool, flags, tmp):
    path = os.path.join(tmp, "ref%s.wmt" % "".join(flags))
    subprocess.run([tool, "reference", "--out", path, "--seed", "3"] + flags, check=True)
    tensors, meta = dynamics_twin.read_archive(path)
    config = meta["config"]
    model = dynamics_twin.load_world_model(tensors, config)
    t = {k[len("input/"):]: torch.from_numpy(v) for k, v in tensors.items() if k.startswith("input/")}
    mask = t["mask"].bool()
    k = config["model"]["num_codes"]
    failures = []

    def compare(name, got, want):
        err = float(np.max(np.abs(got.detach().numpy() - want)))
        print("%-28s %-22s max |diff| %.2e" % (" ".join(flags) or "(default)", name, err))
        if not err <= TOL:
            failures.append("%s %s: %.3g" % (flags, name, err))

    with torch.no_grad():
        z = model.dynamics_z(t["tokens"], t["actions"])
        inputs = t["tokens"] if model.dynamics.next_frame else t["tokens"].masked_fill(mask, k)
        logits, reward, terminal = model.dynamics(inputs, t["actions"], z)
        compare("logits", logits, tensors["output/logits"])
        compare("reward", reward, tensors["output/reward"])
        compare("terminal_logit", terminal, tensors["output/terminal_logit"])
        if model.policy is not None:
            compare("z (prior probs)", z, tensors["output/z"])
            post, prior, mean, log_std = model.policy(model.policy_tokens(t["tokens"]),
                                                      t["actions"], t["z_noise"])
            compare("posterior_logits", post, tensors["output/posterior_logits"])
            compare("prior_logits", prior, tensors["output/prior_logits"])
            compare("action_mean", mean, tensors["output/action_mean"])
            compare("action_log_std", log_std, tensors["output/action_log_std"])
        losses = model.losses(t["tokens"], t["actions"], t["rewards"], t["terminals"], mask,
                              t["z_noise"], t.get("action_mask"))
        for name, want in meta["losses"].items():
            compare("loss " + name, losses[name], np.float64(want))
    return failures


def main():
    tool = os.path.join(os.environ.get("WM_BIN_DIR", "build/bin"), "dynamics_test_tool")
    torch.set_num_threads(1)
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        for flags in ([], ["--rmsnorm"], ["--no-policy"], ["--tied"], ["--tied", "--copy-prior"],
                      ["--next-frame"], ["--tied", "--copy-prior", "--next-frame"],
                      ["--tied", "--copy-prior", "--next-frame", "--rope"],
                      ["--action-dim", "26"],  # a G1-wide joint action
                      ["--action-dim", "14", "--padded", "7"],  # a 7 + 14 mixture's padding
                      ["--levels", "3"],  # a residual tokenizer's codes per cell
                      ["--levels", "3", "--tied", "--copy-prior"],
                      ["--levels", "2", "--tied", "--copy-prior", "--next-frame", "--rope"],
                      ["--adaptive-norm", "identity"],  # adaLN on MaskGIT's shifted actions
                      ["--adaptive-norm", "zero", "--tied", "--next-frame", "--rope"]):
            failures += check_case(tool, flags, tmp)
    if failures:
        print("FAILED:\n  " + "\n  ".join(failures))
        return 1
    print("C++ and PyTorch twin agree to %g" % TOL)
    return 0


if __name__ == "__main__":
    sys.exit(main())
