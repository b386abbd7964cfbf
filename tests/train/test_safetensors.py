#!/usr/bin/python3
"""wm-checkpoint export|import against a safetensors reader and writer written here from the
format's description (no pip package): a real wm-train checkpoint exports to the same tensors the
WMTENSR1 reader sees (vqvae_twin.read_archive, which checks every CRC32C), the header validates
against schemas/safetensors-header.schema.json, the exported dict loads into the PyTorch twin
with load_state_dict(strict=True), and a file this script writes (the twin's own state_dict,
other order, no padding) imports back into a checkpoint byte-identical to the original."""
import json
import os
import struct
import subprocess
import sys
import tempfile
import unittest

import jsonschema
import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tokenize"))
import dynamics_twin  # noqa: E402
import test_wm_train_cli  # noqa: E402  (its tiny config)
import vqvae_twin  # noqa: E402

BIN = os.environ.get("WM_BIN_DIR", "build/bin")
SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(HERE, "..", ".."))
DTYPES = {"F32": "<f4", "F64": "<f8", "F16": "<f2", "I32": "<i4", "I64": "<i8", "U8": "u1"}


def slurp(path):
    with open(path, "rb") as f:
        return f.read()


def read_safetensors(path):
    """{name: ndarray}, __metadata__ and the raw header; AssertionError on any spec violation."""
    blob = slurp(path)
    assert len(blob) >= 8, f"{path}: truncated"
    (n,) = struct.unpack_from("<Q", blob, 0)
    assert 8 + n <= len(blob), f"{path}: header length {n} past the end"
    header = json.loads(blob[8:8 + n].decode("utf-8"))
    buffer = blob[8 + n:]
    metadata = header.get("__metadata__", {})
    assert all(isinstance(v, str) for v in metadata.values()), f"{path}: metadata not str->str"
    tensors, spans = {}, []
    for name, e in header.items():
        if name == "__metadata__":
            continue
        begin, end = e["data_offsets"]
        dtype = np.dtype(DTYPES[e["dtype"]])
        assert end - begin == int(np.prod(e["shape"], dtype=np.int64)) * dtype.itemsize, name
        tensors[name] = np.frombuffer(buffer[begin:end], dtype).reshape(e["shape"]).copy()
        spans.append((begin, end))
    covered = 0
    for begin, end in sorted(spans):  # the buffer is tiled: no hole, no overlap
        assert begin == covered, f"{path}: hole or overlap at {begin}"
        covered = end
    assert covered == len(buffer), f"{path}: unindexed bytes after {covered}"
    return tensors, metadata, header, n


def write_safetensors(path, tensors, metadata):
    """The simplest valid file: tensors in reverse name order, header not padded."""
    header, offset, data = {"__metadata__": metadata}, 0, []
    codes = {np.dtype(v): k for k, v in DTYPES.items()}
    for name in sorted(tensors, reverse=True):
        a = np.ascontiguousarray(tensors[name])
        header[name] = {"dtype": codes[a.dtype], "shape": list(a.shape),
                        "data_offsets": [offset, offset + a.nbytes]}
        offset += a.nbytes
        data.append(a.tobytes())
    text = json.dumps(header).encode("utf-8")
    with open(path, "wb") as f:
        f.write(struct.pack("<Q", len(text)) + text + b"".join(data))


def wm_checkpoint(*args):
    return subprocess.run([os.path.join(BIN, "wm-checkpoint")] + list(args), capture_output=True,
                          text=True)


class Safetensors(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        tmp = cls.tmp.name
        tokens, cfg, cls.run_dir = (os.path.join(tmp, x) for x in ("tokens", "cfg.yaml", "run"))
        subprocess.run([os.path.join(BIN, "dynamics_test_tool"), "make-tokens", "--out", tokens,
                        "--episodes", "6", "--steps", "8", "--grid", "4", "--codes", "32"],
                       check=True, capture_output=True)
        with open(cfg, "w") as f:
            f.write(test_wm_train_cli.CONFIG)
        subprocess.run([os.path.join(BIN, "wm-train"), "--config", cfg, "--tokens", tokens,
                        "--out", cls.run_dir, "--steps", "3"], check=True, capture_output=True)
        cls.checkpoint = os.path.join(cls.run_dir, "checkpoint.wmt")
        cls.archive, cls.archive_header = vqvae_twin.read_archive(cls.checkpoint)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def path(self, name):
        return os.path.join(self.tmp.name, name)

    def export(self, name, *flags):
        r = wm_checkpoint("export", "--checkpoint", self.run_dir, "--out", self.path(name), *flags)
        self.assertEqual(r.returncode, 0, r.stderr)
        return read_safetensors(self.path(name))

    def test_export_equals_the_archive_and_validates(self):
        tensors, metadata, header, n = self.export("model.safetensors")
        model = {k[len("model/"):]: v for k, v in self.archive.items() if k.startswith("model/")}
        self.assertEqual(sorted(tensors), sorted(model))
        for name, a in model.items():
            self.assertEqual(tensors[name].dtype, a.dtype, name)
            np.testing.assert_array_equal(tensors[name], a, err_msg=name)
        self.assertEqual(json.loads(metadata["wmkit"]), self.archive_header["meta"])
        self.assertEqual((metadata["format"], metadata["wmkit_tensors"]), ("pt", "model"))
        self.assertEqual(n % 8, 0, "header padded to 8 bytes")
        with open(os.path.join(SRC, "schemas", "safetensors-header.schema.json")) as f:
            schema = json.load(f)
        jsonschema.validate(header, schema)
        with self.assertRaises(jsonschema.ValidationError):
            jsonschema.validate({**header, "x": {"dtype": "BF16", "shape": [1],
                                                 "data_offsets": [0, 2]}}, schema)

    def test_export_all_holds_the_optimizer_state(self):
        tensors, metadata, _, _ = self.export("all.safetensors", "--all")
        self.assertEqual(sorted(tensors), sorted(self.archive))
        self.assertTrue(any(k.startswith("adamw/") for k in tensors))
        self.assertEqual(metadata["wmkit_tensors"], "all")

    def test_exported_dict_loads_into_the_pytorch_twin(self):
        tensors, metadata, _, _ = self.export("twin.safetensors")
        model = dynamics_twin.WorldModel(json.loads(metadata["wmkit"])["config"])
        model.load_state_dict({k: torch.from_numpy(v) for k, v in tensors.items()}, strict=True)

    def test_a_python_written_state_dict_imports_byte_identically(self):
        tensors, metadata, _, _ = self.export("src.safetensors")
        model = dynamics_twin.WorldModel(json.loads(metadata["wmkit"])["config"])
        model.load_state_dict({k: torch.from_numpy(v) for k, v in tensors.items()}, strict=True)
        state = {k: v.numpy() for k, v in model.state_dict().items()}
        write_safetensors(self.path("py.safetensors"), state, {"format": "pt"})
        out = self.path("imported.wmt")
        r = wm_checkpoint("import", "--safetensors", self.path("py.safetensors"), "--like",
                          self.run_dir, "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(slurp(out), slurp(self.checkpoint))

    def test_changed_weights_import_and_mismatches_are_named(self):
        tensors, _, _, _ = self.export("base.safetensors")
        changed = {k: (v + 1 if v.dtype == np.float32 else v) for k, v in tensors.items()}
        write_safetensors(self.path("changed.safetensors"), changed, {})
        out = self.path("changed.wmt")
        r = wm_checkpoint("import", "--safetensors", self.path("changed.safetensors"), "--like",
                          self.checkpoint, "--out", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        got, header = vqvae_twin.read_archive(out)
        self.assertEqual(header["meta"], self.archive_header["meta"])
        for name, a in self.archive.items():
            want = changed[name[len("model/"):]] if name.startswith("model/") else a
            np.testing.assert_array_equal(got[name], want, err_msg=name)

        name = sorted(k for k, v in tensors.items() if v.ndim == 2)[0]
        bad = dict(tensors, **{name: tensors[name].T.copy()})
        write_safetensors(self.path("bad.safetensors"), bad, {})
        r = wm_checkpoint("import", "--safetensors", self.path("bad.safetensors"), "--like",
                          self.checkpoint, "--out", self.path("bad.wmt"))
        self.assertEqual(r.returncode, 1)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.assertIn("key '%s': shape" % name, r.stderr)
        self.assertFalse(os.path.exists(self.path("bad.wmt")))


if __name__ == "__main__":
    unittest.main()
