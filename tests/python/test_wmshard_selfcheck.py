#!/usr/bin/python3
"""Self-check of scripts/wmshard.py and the shard JSON schemas.

A tiny writer, written here from docs/shard-format.md alone, produces a 2-shard / 3-episode
dataset; the reader must return exactly what was written, the schemas must accept it, and every
kind of corruption must give exit status 1 with a message naming the problem (never a traceback).

Run: /usr/bin/python3 tests/python/test_wmshard_selfcheck.py
"""
import contextlib
import hashlib
import importlib.util
import io
import json
import shutil
import struct
import subprocess
import tempfile
import unittest
from pathlib import Path

import crc32c
import cv2
import jsonschema
import numpy as np
import zstandard

ROOT = Path(__file__).resolve().parents[2]
WMSHARD = ROOT / "scripts" / "wmshard.py"
SCHEMAS = ROOT / "schemas"
H, W = 4, 5


def encode_record(meta, arrays, blobs, mutate_meta=None):
    """One record per the doc: 'WMER', CRC32C(bytes 8..end), meta_length, body_length, meta, body.
    arrays: name -> (ndarray, codec); blobs: name -> (encoded images, encoding, dtype, shape).
    mutate_meta lets a test write a record whose meta lies while its CRC stays valid."""
    body, sections = bytearray(), []
    for name, (arr, codec) in arrays.items():
        raw = arr.tobytes()
        data = zstandard.ZstdCompressor(level=3).compress(raw) if codec == "zstd" else raw
        sections.append({"name": name, "kind": "array", "offset": len(body), "length": len(data),
                         "dtype": str(arr.dtype), "shape": list(arr.shape), "codec": codec,
                         "raw_length": len(raw)})
        body += data
    for name, (images, encoding, dtype, shape) in blobs.items():
        data = struct.pack(f"<{len(images)}Q", *map(len, images)) + b"".join(images)
        sections.append({"name": name, "kind": "blobs", "offset": len(body), "length": len(data),
                         "encoding": encoding, "dtype": dtype, "shape": shape,
                         "count": len(images)})
        body += data
    meta = dict(meta, sections=sections)
    if mutate_meta:
        mutate_meta(meta)
    meta_bytes = json.dumps(meta).encode("utf-8")
    payload = struct.pack("<QQ", len(meta_bytes), len(body)) + meta_bytes + bytes(body)
    return meta, b"WMER" + struct.pack("<I", crc32c.crc32c(payload)) + payload


def encode_shard(records):
    """Header, records back to back, footer index (24 B per record), 40-byte trailer."""
    header = b"WMKSHARD" + struct.pack("<I", 1)
    out = bytearray(header + struct.pack("<I", crc32c.crc32c(header)))
    index = bytearray()
    for steps, rec in records:
        index += struct.pack("<QQII", len(out), len(rec), steps, 0)
        out += rec
    trailer = struct.pack("<QQIII", len(out), len(records), crc32c.crc32c(bytes(index)), 1, 0)
    out += index + trailer + struct.pack("<I", crc32c.crc32c(trailer)) + b"WMKSHEND"
    return bytes(out)


def make_episode(n, steps):
    """Deterministic synthetic episode n: arrays, PNG RGB frames and 16-bit PNG depth frames."""
    rng = np.random.default_rng(n)
    action = rng.normal(size=(steps, 7)).astype("<f4")
    flags = lambda i: np.array([1 if t == i else 0 for t in range(steps)], dtype="u1")
    arrays = {"action": (action, "zstd"), "reward": (rng.random(steps).astype("<f4"), "zstd"),
              "discount": (np.ones(steps, "<f4"), "none"), "is_first": (flags(0), "zstd"),
              "is_last": (flags(steps - 1), "none"),
              "is_terminal": (flags(steps - 1 if n else -1), "zstd")}
    rgb = [cv2.imencode(".png", rng.integers(0, 256, (H, W, 3), dtype=np.uint8))[1].tobytes()
           for _ in range(steps)]
    depth = [cv2.imencode(".png", rng.integers(0, 5000, (H, W), dtype=np.uint16))[1].tobytes()
             for _ in range(steps)]
    blobs = {"image": (rgb, "png", "uint8", [H, W, 3]),
             "depth": (depth, "png", "uint16", [H, W, 1])}
    meta = {"episode_key": f"raw/ep{n}.h5#0", "source": {"file": f"raw/ep{n}.h5", "record": 0},
            "num_steps": steps, "language_instruction": "" if n == 1 else f"pick block {n}",
            "policy_id": "" if n == 2 else "scripted", "episode_seed": None if n == 1 else 1000 + n}
    return meta, arrays, blobs


def write_dataset(d, mutate_meta=None):
    """Write 2 shards (episodes 0,1 | 2) and index.json; return (index, [(meta, arrays, blobs)])."""
    layout, episodes, shards, n = [[2, 3], [2]], [], [], 0
    for s, lengths in enumerate(layout):
        records = []
        for steps in lengths:
            meta, arrays, blobs = make_episode(n, steps)
            full_meta, rec = encode_record(meta, arrays, blobs, mutate_meta if n == 1 else None)
            episodes.append((full_meta, arrays, blobs))
            records.append((steps, rec))
            n += 1
        data = encode_shard(records)
        name = f"shard-{s:05d}.wms"
        (Path(d) / name).write_bytes(data)
        shards.append({"file": name, "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest(),
                       "num_episodes": len(lengths), "num_steps": sum(lengths)})
    a = np.concatenate([ep[1]["action"][0] for ep in episodes]).astype(np.float64)
    config = {"resize": None, "shard_size_mb": 256, "zstd_level": 3}
    index = {
        "format": "wmkit-shard", "format_version": 1, "dataset": "selfcheck", "split": "train",
        "source": {"format": "hdf5", "inputs": [{"path": f"raw/ep{i}.h5", "bytes": 100 + i,
                                                 "sha256": hashlib.sha256(b"%d" % i).hexdigest()}
                                                for i in range(3)]},
        "features": {"action": {"dim": 7, "names": ["dx", "dy", "dz", "droll", "dpitch", "dyaw",
                                                    "gripper"]},
                     "image": {"encoding": "png", "shape": [H, W, 3], "dtype": "uint8"},
                     "depth": {"encoding": "png", "shape": [H, W, 1], "dtype": "uint16"}},
        "shards": shards, "num_episodes": 3, "num_steps": len(a),
        "action_stats": {"mean": a.mean(0).tolist(), "std": a.std(0).tolist(),
                         "min": a.min(0).tolist(), "max": a.max(0).tolist(),
                         "q01": np.quantile(a, 0.01, axis=0).tolist(),
                         "q99": np.quantile(a, 0.99, axis=0).tolist()},
        "skipped": {"count": 1,
                    "episodes": [{"file": "raw/bad.h5", "record": 0, "reason": "no actions"}]},
        "provenance": {"tool": "wm-ingest", "wmkit_version": "0.1.0", "git_commit": "0" * 40,
                       "config": config, "config_hash": hashlib.sha256(json.dumps(
                           config, separators=(",", ":"), sort_keys=True).encode()).hexdigest(),
                       "libraries": {"zstd": "1.5.4"}},
    }
    (Path(d) / "index.json").write_text(json.dumps(index, indent=2))
    return index, episodes


def run(*args):
    """Run wmshard.py with the system interpreter, as users and the C++ tests do."""
    return subprocess.run(["/usr/bin/python3", str(WMSHARD), *map(str, args)],
                          capture_output=True, text=True, timeout=120)


class WmshardSelfCheck(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="wmshard-selfcheck-")
        self.dir = Path(self.tmp) / "ds"
        self.dir.mkdir()
        self.index, self.episodes = write_dataset(self.dir)

    def tearDown(self):
        shutil.rmtree(self.tmp)

    def assertFails(self, args, *needles):
        """Exit 1, no traceback, and every needle (case-insensitive) in the one stderr message."""
        r = run(*args)
        self.assertEqual(r.returncode, 1, f"{args}: expected failure, got {r.stdout[:300]!r}")
        self.assertNotIn("Traceback", r.stderr)
        self.assertEqual(r.stdout, "")
        for needle in needles:
            self.assertIn(needle.lower(), r.stderr.lower(), f"{args}: {needle!r} not in message")
        return r.stderr

    def patch(self, name, offset, fn):
        """Rewrite one byte of a file (offset may be negative, from the end)."""
        path = self.dir / name
        data = bytearray(path.read_bytes())
        data[offset] = fn(data[offset])
        path.write_bytes(bytes(data))

    def shard0_layout(self):
        """(record offsets, index_offset, size) of shard 0 as the test writer laid it out."""
        data = (self.dir / "shard-00000.wms").read_bytes()
        index_offset, n = struct.unpack_from("<QQ", data, len(data) - 40)
        offs = [struct.unpack_from("<Q", data, index_offset + 24 * i)[0] for i in range(n)]
        return offs, index_offset, len(data)

    def test_info(self):
        r = run(self.dir, "--info")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(json.loads(r.stdout), self.index)

    def test_episodes(self):
        r = run(self.dir, "--all", "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        everything = json.loads(r.stdout)
        self.assertEqual(len(everything), 3)
        for k, (meta, arrays, blobs) in enumerate(self.episodes):
            r = run(self.dir, "--episode", k, "--json")
            self.assertEqual(r.returncode, 0, r.stderr)
            ep = json.loads(r.stdout)
            self.assertEqual(ep, everything[k])
            for key in ("episode_key", "source", "num_steps", "language_instruction", "policy_id",
                        "episode_seed"):
                self.assertEqual(ep[key], meta[key], key)
            self.assertEqual(ep["actions"], arrays["action"][0].tolist())  # exact float32 values
            self.assertEqual(ep["rewards"], arrays["reward"][0].tolist())
            self.assertEqual(ep["discounts"], arrays["discount"][0].tolist())
            for key in ("is_first", "is_last", "is_terminal"):
                self.assertEqual(ep[key], arrays[key][0].tolist(), key)
            self.assertEqual(ep["image_shape"], [H, W, 3])
            self.assertEqual(ep["num_frames"], {"image": meta["num_steps"],
                                                "depth": meta["num_steps"]})
            self.assertEqual(ep["image_sha256"],
                             [hashlib.sha256(b).hexdigest() for b in blobs["image"][0]])
        self.assertEqual(everything[1]["episode_seed"], None)
        self.assertEqual(everything[2]["shard"], "shard-00001.wms")
        self.assertEqual(everything[2]["record"], 0)

    def test_verify_ok(self):
        r = run(self.dir, "--verify")
        self.assertEqual((r.returncode, r.stdout.strip(), r.stderr), (0, "OK 3 episodes", ""))
        for meta, _, blobs in self.episodes:  # the writer's frames decode as the meta says
            for s in meta["sections"]:
                for frame in blobs.get(s["name"], [[]])[0]:
                    img = cv2.imdecode(np.frombuffer(frame, np.uint8), cv2.IMREAD_UNCHANGED)
                    self.assertEqual(list(img.shape) + [1] * (img.ndim == 2), s["shape"])
                    self.assertEqual(img.dtype.name, s["dtype"])

    def test_schemas(self):
        index_schema = json.loads((SCHEMAS / "shard-index.schema.json").read_text())
        meta_schema = json.loads((SCHEMAS / "shard-episode-meta.schema.json").read_text())
        for schema in (index_schema, meta_schema):
            jsonschema.Draft202012Validator.check_schema(schema)
        index_v = jsonschema.Draft202012Validator(index_schema)
        meta_v = jsonschema.Draft202012Validator(meta_schema)
        index_v.validate(self.index)
        for meta, _, _ in self.episodes:
            meta_v.validate(meta)
        bad_index = [("format_version", 3), ("num_steps", -1),
                     ("shards", [dict(self.index["shards"][0], file="a.wms")])]
        for key, value in bad_index:
            self.assertFalse(index_v.is_valid(dict(self.index, **{key: value})), key)
        self.assertFalse(index_v.is_valid(dict(self.index, action_stats=dict(
            self.index["action_stats"], q99=[0.0] * 6))))
        self.assertFalse(index_v.is_valid({k: v for k, v in self.index.items()
                                           if k != "provenance"}))
        self.assertTrue(index_v.is_valid(dict(self.index, future_optional_key=1)))
        meta = self.episodes[0][0]
        no_raw = [{k: v for k, v in s.items() if k != "raw_length"} for s in meta["sections"]]
        self.assertFalse(meta_v.is_valid(dict(meta, sections=no_raw)))
        no_image = [s for s in meta["sections"] if s["name"] != "image"]
        self.assertFalse(meta_v.is_valid(dict(meta, sections=no_image)))
        self.assertFalse(meta_v.is_valid(dict(meta, episode_seed="7")))

    def test_episode_out_of_range(self):
        self.assertFails([self.dir, "--episode", 3, "--json"], "episode 3", "out of range",
                         "3 episodes")
        self.assertFails([self.dir, "--episode", -1, "--json"], "out of range")
        self.assertFails([Path(self.tmp), "--info"], "index.json")

    def test_corrupt_record_payload(self):
        offs, _, _ = self.shard0_layout()
        self.patch("shard-00000.wms", offs[1] + 200, lambda b: b ^ 0x01)
        for args in ([self.dir, "--verify"], [self.dir, "--episode", 1, "--json"]):
            self.assertFails(args, "shard-00000.wms", "record 1", "CRC32C mismatch")
        r = run(self.dir, "--episode", 0, "--json")  # random access never touches record 1
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_corrupt_record_magic(self):
        offs, _, _ = self.shard0_layout()
        self.patch("shard-00000.wms", offs[1], lambda b: ord("X"))
        self.assertFails([self.dir, "--episode", 1, "--json"], "record 1", "magic", "WMER")

    def test_corrupt_footer_index(self):
        _, index_offset, _ = self.shard0_layout()
        self.patch("shard-00000.wms", index_offset + 9, lambda b: b ^ 0x10)
        for args in ([self.dir, "--verify"], [self.dir, "--episode", 0, "--json"]):
            self.assertFails(args, "shard-00000.wms", "footer index", "CRC32C mismatch")

    def test_corrupt_trailer(self):
        for offset, needles in ((-40, ["CRC32C mismatch"]), (-1, ["magic", "WMKSHEND"])):
            self.index, _ = write_dataset(self.dir)
            self.patch("shard-00001.wms", offset, lambda b: b ^ 0x01)
            for args in ([self.dir, "--verify"], [self.dir, "--episode", 2, "--json"]):
                self.assertFails(args, "shard-00001.wms", "trailer", *needles)

    def test_truncated(self):
        path = self.dir / "shard-00000.wms"
        path.write_bytes(path.read_bytes()[:-7])
        self.assertFails([self.dir, "--verify"], "shard-00000.wms", "bytes", "truncated")
        self.assertFails([self.dir, "--episode", 0, "--json"], "shard-00000.wms", "trailer")
        path.write_bytes(b"WMKSHARD")
        self.assertFails([self.dir, "--episode", 0, "--json"], "file header", "truncated")

    def test_index_format_version(self):
        (self.dir / "index.json").write_text(json.dumps(dict(self.index, format_version=3)))
        for args in ([self.dir, "--verify"], [self.dir, "--info"], [self.dir, "--episode", 0]):
            self.assertFails(args, "index.json", "format_version 3", "supports (1, 2)")

    def test_index_version_2_needs_an_action_space(self):
        # Version 2 is the any-width action (docs/shard-format.md, "Action width").
        (self.dir / "index.json").write_text(json.dumps(dict(self.index, format_version=2)))
        self.assertFails([self.dir, "--verify"], "index.json", "features.action.space")

    def test_file_header_version(self):
        path = self.dir / "shard-00000.wms"
        data = bytearray(path.read_bytes())
        head = b"WMKSHARD" + struct.pack("<I", 2)
        data[0:16] = head + struct.pack("<I", crc32c.crc32c(head))  # valid CRC, future version
        path.write_bytes(bytes(data))
        self.assertFails([self.dir, "--episode", 0], "shard-00000.wms", "file header",
                         "version 2", "supports 1")

    def test_index_sha256_and_totals(self):
        index = json.loads(json.dumps(self.index))
        index["shards"][1]["sha256"] = "0" * 64
        (self.dir / "index.json").write_text(json.dumps(index))
        self.assertFails([self.dir, "--verify"], "shard-00001.wms", "sha256")
        (self.dir / "index.json").write_text(json.dumps(dict(self.index, num_steps=8)))
        self.assertFails([self.dir, "--verify"], "index.json", "num_steps 8")
        stats = dict(self.index["action_stats"], std=[1.0] * 7)
        (self.dir / "index.json").write_text(json.dumps(dict(self.index, action_stats=stats)))
        self.assertFails([self.dir, "--verify"], "action_stats.std")

    def test_lying_meta(self):
        """Records whose CRC is valid but whose meta contradicts the body."""
        def bad_raw_length(meta):
            meta["sections"][0]["raw_length"] += 4

        def past_body(meta):
            meta["sections"][-1]["length"] += 1

        def wrong_steps(meta):
            meta["sections"][1]["shape"] = [meta["num_steps"] + 1]
            meta["sections"][1]["raw_length"] += 4

        def no_image(meta):
            meta["sections"] = [s for s in meta["sections"] if s["name"] != "image"]

        cases = [(bad_raw_length, ["section 'action'", "raw_length"]),
                 (past_body, ["section 'depth'", "runs past the body"]),
                 (wrong_steps, ["section 'reward'", "first dimension"]),
                 (no_image, ["required section 'image'"]),
                 (lambda m: m.update(num_steps="3"), ["meta key 'num_steps'"]),
                 (lambda m: m.update(episode_seed=1.5), ["episode_seed"]),
                 (lambda m: m["sections"].__setitem__(2, "x"), ["section 2", "'name'"]),
                 (lambda m: m["sections"][0].update(shape=["3", 7]), ["section 'action'", "shape"]),
                 (lambda m: m["sections"][3].update(kind="tensor"), ["unknown kind 'tensor'"]),
                 (lambda m: m["sections"][3].update(codec="lz4"), ["section 'is_first'", "codec"]),
                 (lambda m: m["sections"][-1].update(count=2), ["section 'depth'", "count 2"])]
        for mutate, needles in cases:
            shutil.rmtree(self.dir)
            self.dir.mkdir()
            write_dataset(self.dir, mutate)
            self.assertFails([self.dir, "--verify"], "shard-00000.wms", "record 1", *needles)

    def test_ignores_ingest_leftovers(self):
        """An interrupted wm-ingest leaves hidden .tmp files and a state file: ignored."""
        (self.dir / ".wm-ingest-state.json").write_text("{}")
        (self.dir / ".shard-00002.wms.tmp").write_bytes(b"WMKSHARD partial")
        r = run(self.dir, "--verify")
        self.assertEqual((r.returncode, r.stdout.strip()), (0, "OK 3 episodes"), r.stderr)

    def test_every_byte_and_every_truncation(self):
        """Every byte of a shard is covered by a CRC or a magic, so any single flipped byte, and
        any truncation, is a clean, named error (checked in-process: thousands of cases)."""
        spec = importlib.util.spec_from_file_location("wmshard", WMSHARD)
        wmshard = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(wmshard)
        path = self.dir / "shard-00001.wms"
        good = path.read_bytes()
        cases = [good[:i] + bytes([good[i] ^ 0x40]) + good[i + 1:] for i in range(len(good))]
        cases += [good[:n] for n in range(0, len(good), 7)]
        for data in cases:
            path.write_bytes(data)
            err = io.StringIO()
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                rc = wmshard.main([str(self.dir), "--episode", "2"])
            self.assertEqual(rc, 1, f"corruption not detected ({len(data)} bytes)")
            self.assertIn("shard-00001.wms: ", err.getvalue())
            self.assertNotIn("unexpected", err.getvalue())

    def test_zstd_raw_length(self):
        """zstd data decompressing to fewer (no content size in the frame) or more (content size
        present) bytes than raw_length, in a record whose CRC and meta are otherwise valid."""
        shard = self.dir / "shard-00001.wms"
        for size, content_size, needle in ((52, False, "decompressed size 52"),
                                           (60, True, "decompressed size more than")):
            meta, arrays, blobs = make_episode(2, 2)
            full, rec = encode_record(meta, arrays, blobs)
            sec = full["sections"][0]  # action: [2, 7] float32, raw_length 56
            wrong = zstandard.ZstdCompressor(level=3, write_content_size=content_size).compress(
                b"\0" * size)
            delta = len(wrong) - sec["length"]
            full["sections"] = [dict(s, offset=s["offset"] + delta * (i > 0))
                                for i, s in enumerate(full["sections"])]
            full["sections"][0]["length"] = len(wrong)
            meta_len = struct.unpack_from("<Q", rec, 8)[0]
            body = wrong + rec[24 + meta_len + sec["length"]:]
            meta_bytes = json.dumps(full).encode()
            payload = struct.pack("<QQ", len(meta_bytes), len(body)) + meta_bytes + body
            rec = b"WMER" + struct.pack("<I", crc32c.crc32c(payload)) + payload
            shard.write_bytes(encode_shard([(2, rec)]))
            self.assertFails([self.dir, "--episode", 2], "shard-00001.wms", "record 0",
                             "section 'action'", needle, "raw_length 56")

if __name__ == "__main__":
    unittest.main(verbosity=2)
