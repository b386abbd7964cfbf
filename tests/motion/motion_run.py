#!/usr/bin/python3
"""A wm-motion tensor archive as its PyTorch twin (any model.kind): a run directory's
checkpoint with the action normaliser the run trained with (what bench scripts score a C++ run
through), or motion_test_tool's references (test_warp_twin.py)."""
import os

import numpy as np
import torch

from dynamics_twin import read_archive
from layer_twin import LayerNet
from pose_twin import PoseNet
from warp_twin import WarpNet


def twin_of(model, action_dim):
    """An untrained twin of the checkpoint config's `model` section."""
    if model["kind"] == "layers":
        return LayerNet(action_dim, model["layers"], model["channels"], model["flow_scale"],
                        image_size=model["image_size"])
    if model["kind"] == "pose":
        return PoseNet(action_dim, model["pose_dim"], model["channels"], model["renderer_width"],
                       model["image_size"], model.get("dynamics_hidden", 128))
    return WarpNet(model, action_dim)


def load_weights(net, tensors):
    """`net` with a tensor archive's model/ tensors loaded strictly."""
    net.load_state_dict({k[len("model/"):]: torch.from_numpy(v) for k, v in tensors.items()
                         if k.startswith("model/")}, strict=True)
    return net


def load_run(run_dir, kind=None):
    """(twin with the run's weights, in eval mode; raw action -> normalised float32 action).
    `kind`, when given, is the model.kind the caller needs."""
    tensors, meta = read_archive(os.path.join(run_dir, "checkpoint.wmt"))
    model = meta["config"]["model"]
    if kind is not None and model["kind"] != kind:
        raise ValueError("%s holds a %s model, not %s" % (run_dir, model["kind"], kind))
    net = load_weights(twin_of(model, meta["action_dim"]), tensors)
    stats = next(iter(meta["action_norms"].values()))
    mean, std = (np.array(stats[k], np.float32) for k in ("mean", "std"))
    return net.eval(), lambda a: ((a - mean) / std).astype(np.float32)
