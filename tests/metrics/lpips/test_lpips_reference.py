#!/usr/bin/python3
"""LPIPS reference check: wm::metrics::Lpips (through lpips_ref_tool) against PyTorch.

Weights: scripts/export_lpips_weights.py --random-seed 0. This file reads the archive with its own
numpy reader, written from docs/metrics-lpips.md, and builds LPIPS-alex v0.1 from torch.nn.functional
ops exactly as the lpips package computes it (ScalingLayer, alexnet slices, normalize_tensor,
lin 1x1 conv, spatial mean, sum). Checks, on random and structured 64x64 pairs, a 48x80 set
and a 144x176 set (the C++ trunk's channels-last path):
  - C++ distances and per-layer terms == PyTorch within 1e-5 absolute;
  - C++ relu1..relu5 == torchvision.models.alexnet().features cut after indices 1, 4, 7, 9, 11
    (the lpips slices), and the reference's own taps == torchvision's;
  - uint8 .npy, float32 [-1, 1] .npy and raw RGB inputs give the same distances;
  - the archive header validates against schemas/lpips-weights.schema.json.
"""
import json
import os
import struct
import subprocess
import sys
import tempfile

import crc32c
import jsonschema
import numpy as np
import torch
import torch.nn.functional as F
import torchvision

SOURCE = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "../../.."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SOURCE, "build/bin"))
TOOL = os.path.join(BIN, "lpips_ref_tool")
TOL = 1e-5
passed, failures = [], []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    (passed if ok else failures).append(what)


def read_archive(path):
    """Independent WMTENSR1 reader: magic, u64 header length, JSON, aligned CRC-checked data."""
    blob = open(path, "rb").read()
    assert blob[:8] == b"WMTENSR1", "magic"
    (n,) = struct.unpack_from("<Q", blob, 8)
    header = json.loads(blob[16:16 + n].decode("utf-8"))
    assert header["format"] == "wmkit-tensors" and header["version"] == 1
    start = 16 + n
    assert start % 64 == 0 and len(blob) - start == header["data_length"]
    out = {}
    for name, e in header["tensors"].items():
        assert e["offset"] % 64 == 0, name
        raw = blob[start + e["offset"]:start + e["offset"] + e["length"]]
        assert crc32c.crc32c(raw) == e["crc32c"], name
        out[name] = torch.from_numpy(np.frombuffer(raw, "<f4").reshape(e["shape"]).copy())
    return out, header


CONVS = [(1, 0, 4, 2), (2, 3, 1, 2), (3, 6, 1, 1), (4, 8, 1, 1), (5, 10, 1, 1)]  # slice, idx, s, p


def check_schema(header):
    """The exporter's header satisfies schemas/lpips-weights.schema.json, which rejects the
    mistakes it exists to catch."""
    with open(os.path.join(SOURCE, "schemas", "lpips-weights.schema.json")) as f:
        schema = json.load(f)
    jsonschema.validate(header, schema)
    check(True, "archive header validates against schemas/lpips-weights.schema.json")
    tensors = header["tensors"]
    bads = {
        "missing lin tensor": {**header, "tensors": {k: v for k, v in tensors.items()
                                                      if k != "lin2.model.1.weight"}},
        "transposed conv weight": {**header, "tensors": {**tensors, "net.slice2.3.weight": {
            **tensors["net.slice2.3.weight"], "shape": [64, 192, 5, 5]}}},
        "unaligned offset": {**header, "tensors": {**tensors, "extra": {
            "dtype": "float32", "shape": [1], "offset": 4, "length": 4, "crc32c": 0}}},
        "vgg meta": {**header, "meta": {**header["meta"], "net": "vgg"}},
    }
    for what, bad in bads.items():
        try:
            jsonschema.validate(bad, schema)
            check(False, f"schema rejects {what}")
        except jsonschema.ValidationError:
            check(True, f"schema rejects {what}")


def reference_features(w, x):
    """AlexNet relu1..relu5 of x ([N, 3, H, W], already scaled) from functional ops."""
    feats, h = [], x
    for k, i, stride, pad in CONVS:
        if k in (2, 3):
            h = F.max_pool2d(h, 3, 2)
        h = F.relu(F.conv2d(h, w[f"net.slice{k}.{i}.weight"], w[f"net.slice{k}.{i}.bias"],
                            stride=stride, padding=pad))
        feats.append(h)
    return feats


def reference_lpips(w, x0, x1):
    """[N, 5] per-layer LPIPS terms, lpips.LPIPS.forward with version 0.1, spatial=False."""
    shift, scale = w["scaling_layer.shift"], w["scaling_layer.scale"]
    f0 = reference_features(w, (x0 - shift) / scale)
    f1 = reference_features(w, (x1 - shift) / scale)
    terms = []
    for k, (a, b) in enumerate(zip(f0, f1)):
        na = a / (torch.sqrt(torch.sum(a ** 2, dim=1, keepdim=True)) + 1e-10)
        nb = b / (torch.sqrt(torch.sum(b ** 2, dim=1, keepdim=True)) + 1e-10)
        terms.append(F.conv2d((na - nb) ** 2, w[f"lin{k}.model.1.weight"]).mean([2, 3])[:, 0])
    return torch.stack(terms, 1)


def torchvision_taps(w, x):
    """relu1..relu5 from torchvision's alexnet().features with the archive's weights."""
    features = torchvision.models.alexnet().features.eval()
    for k, i, _, _ in CONVS:
        features[i].weight.data.copy_(w[f"net.slice{k}.{i}.weight"])
        features[i].bias.data.copy_(w[f"net.slice{k}.{i}.bias"])
    taps, h = [], x
    for i, layer in enumerate(features):
        h = layer(h)
        if i in (1, 4, 7, 9, 11):
            taps.append(h)
    return taps


def check_taps(label, w, images, feats_dir):
    """The C++ relu1..relu5 of `images` (written to feats_dir) == torchvision's taps."""
    x = (to_tensor(images) - w["scaling_layer.shift"]) / w["scaling_layer.scale"]
    tv, own = torchvision_taps(w, x), reference_features(w, x)
    for k in range(5):
        c = torch.from_numpy(np.load(os.path.join(feats_dir, f"relu{k + 1}.npy")))
        scale = float(tv[k].abs().max())
        check(c.shape == tv[k].shape and float((c - tv[k]).abs().max()) <= 1e-5 * scale,
              f"{label}relu{k + 1} {list(c.shape)}: C++ == torchvision alexnet.features tap")
        check(float((own[k] - tv[k]).abs().max()) <= 1e-6 * scale,
              f"{label}relu{k + 1}: reference == torchvision tap")


def to_tensor(images):  # uint8 [N, H, W, 3] -> float [N, 3, H, W] in [-1, 1]
    return torch.from_numpy(images).permute(0, 3, 1, 2).float() / 127.5 - 1


def structured_pairs(size):
    y, x = np.mgrid[0:size, 0:size].astype(np.float32)
    def img(r, g, b):
        return np.clip(np.stack([r, g, b], -1), 0, 255).astype(np.uint8)
    grad = img(4 * x, 4 * y, 2 * (x + y))
    checker = img(*(255.0 * (((x // 8) + (y // 8)) % 2),) * 3)
    disk = img(*(255.0 * ((x - 32) ** 2 + (y - 24) ** 2 < 200),) * 3)
    blur = (grad.astype(np.float32) * 0.5 + np.roll(grad, 3, axis=1) * 0.5).astype(np.uint8)
    flat_black, flat_white = np.zeros_like(grad), np.full_like(grad, 255)
    a = [grad, grad, checker, checker, disk, flat_black, grad, disk]
    b = [blur, np.roll(grad, 5, 0), np.roll(checker, 4, 1), checker.transpose(1, 0, 2).copy(), 255 - disk,
         flat_white, grad, disk]
    return np.stack(a), np.stack(b)


def run_tool(weights, a, b, tmp, extra=(), name="pairs"):
    pa, pb = os.path.join(tmp, name + "_a.npy"), os.path.join(tmp, name + "_b.npy")
    np.save(pa, a)
    np.save(pb, b)
    out = subprocess.run([TOOL, "--weights", weights, "--a", pa, "--b", pb, *extra],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def compare_distances(label, cpp, ref_layers):
    ref = ref_layers.sum(1).double().numpy()
    err = np.abs(np.array(cpp["distances"]) - ref).max()
    check(err <= TOL, f"{label}: C++ vs PyTorch LPIPS max |diff| {err:.2e} "
          f"(values {ref.min():.4f}..{ref.max():.4f})")
    if "layers" in cpp:
        lerr = np.abs(np.array(cpp["layers"]) - ref_layers.double().numpy()).max()
        check(lerr <= TOL, f"{label}: per-layer terms max |diff| {lerr:.2e}")


def main():
    torch.set_num_threads(2)
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        weights = os.path.join(tmp, "lpips-rand0.wmt")
        subprocess.run([sys.executable, os.path.join(SOURCE, "scripts/export_lpips_weights.py"),
                        "--random-seed", "0", "--out", weights], check=True, capture_output=True)
        w, header = read_archive(weights)
        check_schema(header)
        check(all((w[f"lin{k}.model.1.weight"] >= 0).all() for k in range(5)),
              "lin weights are non-negative")
        # lpips/lpips.py ScalingLayer: the exporter must write these exact constants.
        check(w["scaling_layer.shift"].flatten().tolist() == torch.tensor([-.030, -.088, -.188]).tolist()
              and w["scaling_layer.scale"].flatten().tolist() == torch.tensor([.458, .448, .450]).tolist(),
              "archive ScalingLayer shift/scale == lpips constants")

        sa, sb = structured_pairs(64)
        ra = rng.integers(0, 256, (8, 64, 64, 3), dtype=np.uint8)
        rb = rng.integers(0, 256, (8, 64, 64, 3), dtype=np.uint8)
        a, b = np.concatenate([ra, sa]), np.concatenate([rb, sb])
        feats_dir = os.path.join(tmp, "feats")
        cpp = run_tool(weights, a, b, tmp, ["--per-layer", "--features-dir", feats_dir,
                                            "--batch-size", "5"])
        with torch.no_grad():
            ref = reference_lpips(w, to_tensor(a), to_tensor(b))
            compare_distances("64x64 random + structured", cpp, ref)
            check(cpp["distances"][-1] == 0.0 and cpp["distances"][-2] == 0.0,
                  "identical structured pairs give exactly 0")
            check_taps("", w, a, feats_dir)

            # Non-square images catch any H/W mix-up; float and raw inputs share the path.
            na = rng.integers(0, 256, (3, 48, 80, 3), dtype=np.uint8)
            nb = np.clip(na.astype(int) + rng.integers(-40, 40, na.shape), 0, 255).astype(np.uint8)
            ref_n = reference_lpips(w, to_tensor(na), to_tensor(nb))
            compare_distances("48x80 noisy copies", run_tool(weights, na, nb, tmp, name="n"), ref_n)
            fa, fb = to_tensor(na).permute(0, 2, 3, 1).numpy(), to_tensor(nb).permute(0, 2, 3, 1).numpy()
            compare_distances("48x80 float32 input", run_tool(weights, fa, fb, tmp, name="f"), ref_n)

            # Above 128 x 128 pixels the C++ trunk runs channels-last (AlexNetTrunkImpl).
            la = rng.integers(0, 256, (3, 144, 176, 3), dtype=np.uint8)
            lb = np.clip(la.astype(int) + rng.integers(-40, 40, la.shape), 0, 255).astype(np.uint8)
            la, lb = np.concatenate([la, la[:1]]), np.concatenate([lb, la[:1]])
            large_dir = os.path.join(tmp, "large_feats")
            large = run_tool(weights, la, lb, tmp, ["--per-layer", "--features-dir", large_dir],
                             name="l")
            compare_distances("144x176 noisy copies", large,
                              reference_lpips(w, to_tensor(la), to_tensor(lb)))
            check(large["distances"][-1] == 0.0, "144x176 identical pair gives exactly 0")
            check_taps("144x176 ", w, la, large_dir)
        raw_a, raw_b = os.path.join(tmp, "a.rgb"), os.path.join(tmp, "b.rgb")
        na.tofile(raw_a)
        nb.tofile(raw_b)
        raw = json.loads(subprocess.run([TOOL, "--weights", weights, "--a", raw_a, "--b", raw_b,
                                         "--size", "48x80"], check=True, capture_output=True,
                                        text=True).stdout)
        compare_distances("48x80 raw RGB input", raw, ref_n)

        bad = subprocess.run([TOOL, "--weights", os.path.join(tmp, "absent.wmt"), "--a", raw_a,
                              "--b", raw_b, "--size", "48x80"], capture_output=True, text=True)
        check(bad.returncode == 1 and "absent.wmt" in bad.stderr, "missing weights: exit 1, named")
    print(f"{len(passed)} passed, {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
