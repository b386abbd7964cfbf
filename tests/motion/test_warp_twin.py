#!/usr/bin/python3
"""The C++ motion model (motion/warp_net.cc) and its PyTorch twin (warp_twin.py) give the same
flow, gate, next frame and 3-step imagination to 1e-5 on the same weights: motion_test_tool
writes random weights (a non-zero head, so flows are pixels long), inputs and its outputs into a
tensor archive; the twin loads the weights strictly and recomputes."""
import os
import subprocess
import sys
import tempfile

import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "train"))
import warp_twin  # noqa: E402
from dynamics_twin import read_archive  # noqa: E402

TOL = 1e-5


def check_case(tool, flags, tmp):
    path = os.path.join(tmp, "ref%s.wmt" % "".join(flags))
    subprocess.run([tool, "reference", "--out", path, "--seed", "3"] + flags, check=True)
    tensors, meta = read_archive(path)
    net = warp_twin.WarpNet(meta["config"]["model"], meta["action_dim"])
    state = {k[len("model/"):]: torch.from_numpy(v) for k, v in tensors.items()
             if k.startswith("model/")}
    net.load_state_dict(state, strict=True)
    t = {k[len("input/"):]: torch.from_numpy(v) for k, v in tensors.items()
         if k.startswith("input/")}
    failures = []

    def compare(name, got, want):
        err = float(np.max(np.abs(got.detach().numpy() - want)))
        print("%-22s %-10s max |diff| %.2e" % (" ".join(flags) or "(default)", name, err))
        if not err <= TOL:
            failures.append("%s %s: %.3g" % (flags, name, err))

    with torch.no_grad():
        nxt, flow, gate = net(t["current"], t["previous"], t["action"])
        compare("next", nxt, tensors["output/next"])
        compare("flow", flow, tensors["output/flow"])
        compare("gate", gate, tensors["output/gate"])
        compare("imagined", warp_twin.imagine(net, t["current"], t["actions"]),
                tensors["output/imagined"])
    # The check must be able to fail: the flows are far from zero, so a twin that ignored them
    # (or the action) would differ by much more than TOL.
    moved = float(np.abs(tensors["output/flow"]).mean())
    if moved < 0.5:
        failures.append("%s: reference flows too small (%.3f px) to test the warp" % (flags, moved))
    return failures


def main():
    tool = os.path.join(os.environ.get("WM_BIN_DIR", "build/bin"), "motion_test_tool")
    torch.set_num_threads(1)
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        for flags in ([], ["--no-jacobian"], ["--action-dim", "26"]):
            failures += check_case(tool, flags, tmp)
    if failures:
        print("FAIL:", "; ".join(failures))
        return 1
    print("OK: the C++ motion model equals its PyTorch twin")
    return 0


if __name__ == "__main__":
    sys.exit(main())
