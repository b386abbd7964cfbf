#!/usr/bin/python3
"""Writes LPIPS v0.1 (AlexNet) weights as a wmkit tensor archive (WMTENSR1) for wm::metrics::Lpips.

  pip install lpips                                   # once, on a machine with internet
  python3 scripts/export_lpips_weights.py --out lpips-alex-v0.1.wmt
  python3 scripts/export_lpips_weights.py --random-seed 0 --out /tmp/lpips-rand0.wmt  # offline
  python3 scripts/export_lpips_weights.py --list lpips-alex-v0.1.wmt

Default mode builds lpips.LPIPS(net='alex', version='0.1') (its lin layers ship in the package;
the AlexNet trunk is torchvision's ImageNet alexnet, downloaded by torchvision), writes its state
dict, re-reads the archive, and checks a PyTorch LPIPS built from the archive against the
lpips package on random images (|diff| <= 1e-5) before it keeps the file.

--random-seed S needs neither the lpips package nor the internet: torch.manual_seed(S), AlexNet
features from torchvision.models.alexnet(weights=None), lin weights |default init| (>= 0). Same
seed, same torch/torchvision -> the same weights. The tests use this mode.

Format and tensor names: docs/metrics-lpips.md. Exit codes: 0 ok, 1 error, 2 usage.
"""
import argparse
import json
import os
import struct
import sys
import tempfile

import numpy as np

MAGIC = b"WMTENSR1"
FORMAT, VERSION, ALIGN = "wmkit-tensors", 1, 64
DTYPES = {"float32": "<f4", "float64": "<f8", "float16": "<f2", "int32": "<i4", "int64": "<i8",
          "uint8": "|u1"}
# lpips.pretrained_networks.alexnet: slice k holds torchvision alexnet().features[i] for these i;
# the convolution of slice k is the first index that has weights.
ALEX_CONV_INDEX = {1: 0, 2: 3, 3: 6, 4: 8, 5: 10}
ALEX_SLICES = {1: (0, 2), 2: (2, 5), 3: (5, 8), 4: (8, 10), 5: (10, 12)}  # [begin, end)
CHANNELS = [64, 192, 384, 256, 256]
SHIFT, SCALE = [-.030, -.088, -.188], [.458, .448, .450]  # lpips.ScalingLayer


def crc32c(data):
    """CRC32C of bytes: python3-crc32c when present, else a (slow) table fallback."""
    try:
        import crc32c as fast
        return fast.crc32c(data)
    except ImportError:
        table = [0] * 256
        for i in range(256):
            c = i
            for _ in range(8):
                c = (c >> 1) ^ 0x82F63B78 if c & 1 else c >> 1
            table[i] = c
        crc = 0xFFFFFFFF
        for b in bytes(data):
            crc = table[(crc ^ b) & 0xFF] ^ (crc >> 8)
        return crc ^ 0xFFFFFFFF


def expected_shapes():
    """Archive tensor name -> shape, for every tensor LPIPS-alex v0.1 needs."""
    shapes = {"scaling_layer.shift": [1, 3, 1, 1], "scaling_layer.scale": [1, 3, 1, 1]}
    cin = 3
    kernels = [11, 5, 3, 3, 3]
    for k in range(1, 6):
        cout = CHANNELS[k - 1]
        prefix = f"net.slice{k}.{ALEX_CONV_INDEX[k]}"
        shapes[prefix + ".weight"] = [cout, cin, kernels[k - 1], kernels[k - 1]]
        shapes[prefix + ".bias"] = [cout]
        shapes[f"lin{k - 1}.model.1.weight"] = [1, cout, 1, 1]
        cin = cout
    return shapes


def write_archive(path, tensors, meta):
    """Writes {name: ndarray} + meta as a WMTENSR1 archive, atomically (temp file + rename)."""
    entries, chunks, offset = {}, [], 0
    for name in sorted(tensors):
        a = np.ascontiguousarray(tensors[name])
        little = a.dtype.newbyteorder("<").str
        dtype = next((k for k, v in DTYPES.items() if np.dtype(v).str == little), None)
        if dtype is None:
            raise ValueError(f"{name}: unsupported dtype {a.dtype}")
        raw = a.astype(little, copy=False).tobytes()
        entries[name] = {"dtype": dtype, "shape": list(a.shape), "offset": offset,
                         "length": len(raw), "crc32c": crc32c(raw)}
        pad = -len(raw) % ALIGN
        chunks += [raw, b"\0" * pad]
        offset += len(raw) + pad
    header = json.dumps({"format": FORMAT, "version": VERSION, "data_length": offset,
                         "tensors": entries, "meta": meta}, separators=(",", ":")).encode()
    header += b" " * (-(16 + len(header)) % ALIGN)  # JSON whitespace: aligns the data section
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix="." + os.path.basename(path) + ".")
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would hide the weights from other users
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(MAGIC + struct.pack("<Q", len(header)) + header)
            for c in chunks:
                f.write(c)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def read_archive(path):
    """({name: ndarray}, meta) of a WMTENSR1 archive, every check the C++ reader makes."""
    with open(path, "rb") as f:
        blob = f.read()
    if len(blob) < 16 or blob[:8] != MAGIC:
        raise ValueError(f"{path}: not a wmkit tensor archive")
    (n,) = struct.unpack_from("<Q", blob, 8)
    header = json.loads(blob[16:16 + n])
    if header.get("format") != FORMAT or header.get("version") != VERSION:
        raise ValueError(f"{path}: format/version is not {FORMAT} {VERSION}")
    data = memoryview(blob)[16 + n:]
    if len(data) != header["data_length"]:
        raise ValueError(f"{path}: {len(data)} data bytes, header says {header['data_length']}")
    tensors = {}
    for name, e in header["tensors"].items():
        raw = data[e["offset"]:e["offset"] + e["length"]]
        if len(raw) != e["length"] or crc32c(raw) != e["crc32c"]:
            raise ValueError(f"{path}: tensor '{name}': bad bounds or CRC32C")
        tensors[name] = np.frombuffer(raw, DTYPES[e["dtype"]]).reshape(e["shape"])
    return tensors, header.get("meta", {})


def reference_lpips(tensors):
    """A PyTorch LPIPS-alex v0.1 (eval mode, spatial=False) from archive tensors, built on
    torchvision's alexnet().features: module(x0, x1) -> [B, 5] per-layer terms, inputs [-1, 1]."""
    import torch
    import torchvision

    class Reference(torch.nn.Module):
        def __init__(self):
            super().__init__()
            features = torchvision.models.alexnet().features
            t = {k: torch.from_numpy(np.array(v, np.float32)) for k, v in tensors.items()}
            for k, i in ALEX_CONV_INDEX.items():
                features[i].weight.data.copy_(t[f"net.slice{k}.{i}.weight"])
                features[i].bias.data.copy_(t[f"net.slice{k}.{i}.bias"])
            self.slices = torch.nn.ModuleList(
                [features[b:e] for b, e in (ALEX_SLICES[k] for k in range(1, 6))])
            self.lins = torch.nn.ParameterList(
                [torch.nn.Parameter(t[f"lin{k}.model.1.weight"]) for k in range(5)])
            self.register_buffer("shift", t["scaling_layer.shift"])
            self.register_buffer("scale", t["scaling_layer.scale"])

        def forward(self, x0, x1):
            h = (torch.cat([x0, x1]) - self.shift) / self.scale
            terms = []
            for sl, w in zip(self.slices, self.lins):
                h = sl(h)
                f = h / (torch.sqrt(torch.sum(h ** 2, dim=1, keepdim=True)) + 1e-10)
                d = (f[:x0.shape[0]] - f[x0.shape[0]:]) ** 2
                terms.append(torch.nn.functional.conv2d(d, w).mean([2, 3])[:, 0])
            return torch.stack(terms, 1)

    return Reference().eval()


def random_state(seed):
    import torch
    import torchvision
    torch.manual_seed(seed)
    try:
        features = torchvision.models.alexnet(weights=None).features
    except TypeError:  # torchvision < 0.13
        features = torchvision.models.alexnet(pretrained=False).features
    state = {"scaling_layer.shift": np.array(SHIFT, np.float32).reshape(1, 3, 1, 1),
             "scaling_layer.scale": np.array(SCALE, np.float32).reshape(1, 3, 1, 1)}
    for k, i in ALEX_CONV_INDEX.items():
        state[f"net.slice{k}.{i}.weight"] = features[i].weight.detach().numpy()
        state[f"net.slice{k}.{i}.bias"] = features[i].bias.detach().numpy()
    for k, c in enumerate(CHANNELS):
        lin = torch.nn.Conv2d(c, 1, 1, bias=False)
        state[f"lin{k}.model.1.weight"] = lin.weight.detach().abs().numpy()
    meta = {"source": "random", "seed": seed}
    return state, meta


def lpips_state():
    try:
        import lpips
    except ImportError as e:
        raise ImportError(f"{e}: run `pip install lpips` (needs internet for the AlexNet "
                          "weights too), or use --random-seed S for test weights") from e
    try:
        model = lpips.LPIPS(net="alex", version="0.1", verbose=False).eval()
    except TypeError:  # versions without `verbose`
        model = lpips.LPIPS(net="alex", version="0.1").eval()
    state = {k: v.detach().cpu().numpy() for k, v in model.state_dict().items()}
    # lpips >= 0.1.3 also registers the lin layers as nn.ModuleList `lins`: the same tensors
    # under a second name. Keep the linK names (the ones every version has).
    for k in range(5):
        dup = state.pop(f"lins.{k}.model.1.weight", None)
        if dup is not None and not np.array_equal(dup, state.get(f"lin{k}.model.1.weight")):
            raise ValueError(f"lins.{k}.model.1.weight differs from lin{k}.model.1.weight")
    meta = {"source": "lpips package", "lpips": getattr(lpips, "__version__", "unknown"),
            "trunk": "torchvision alexnet ImageNet weights"}
    return state, meta, model


def check_against_lpips(path, model):
    """The archive's reference LPIPS must match the lpips package itself."""
    import torch
    torch.manual_seed(1)
    x0, x1 = torch.rand(4, 3, 64, 64) * 2 - 1, torch.rand(4, 3, 64, 64) * 2 - 1
    tensors, _ = read_archive(path)
    with torch.no_grad():
        ours = reference_lpips(tensors)(x0, x1).sum(1)
        theirs = model(x0, x1).flatten()
    diff = float((ours - theirs).abs().max())
    print(f"check against lpips package: max |diff| = {diff:.3g} on 4 random 64x64 pairs")
    if diff > 1e-5:
        raise ValueError(f"archive LPIPS differs from the lpips package by {diff}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="\n".join(__doc__.split("\n")[1:]))
    ap.add_argument("--out", help="archive to write")
    ap.add_argument("--random-seed", type=int, help="fixed random weights, no lpips package")
    ap.add_argument("--list", metavar="ARCHIVE", help="print an archive's tensors and meta")
    args = ap.parse_args()
    try:
        if args.list:
            tensors, meta = read_archive(args.list)
            for name in sorted(tensors):
                print(f"{name}\t{tensors[name].dtype}\t{list(tensors[name].shape)}")
            print(json.dumps(meta, indent=1))
            return 0
        if not args.out:
            ap.error("--out is required")
        model = None
        if args.random_seed is not None:
            state, meta = random_state(args.random_seed)
        else:
            state, meta, model = lpips_state()
        shapes = expected_shapes()
        if set(state) != set(shapes):
            raise ValueError(f"state dict names differ: missing {sorted(set(shapes) - set(state))}"
                             f", unexpected {sorted(set(state) - set(shapes))}")
        for name, shape in shapes.items():
            if list(state[name].shape) != shape:
                raise ValueError(f"{name}: shape {list(state[name].shape)}, expected {shape}")
        import torch
        import torchvision
        meta = {"model": "lpips", "net": "alex", "version": "0.1",
                "input": "RGB [N, 3, H, W] in [-1, 1]; uint8 x -> x / 127.5 - 1",
                "torch": torch.__version__, "torchvision": torchvision.__version__, **meta}
        write_archive(args.out, {k: v.astype(np.float32) for k, v in state.items()}, meta)
        if model is not None:
            try:
                check_against_lpips(args.out, model)
            except BaseException:
                os.unlink(args.out)
                raise
        print(f"wrote {len(state)} tensors to {args.out}")
    except (OSError, ValueError, KeyError, ImportError) as e:
        print(f"export_lpips_weights: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
