#!/usr/bin/python3
"""Independent Python reader and verifier for wmkit shard format v1 (docs/shard-format.md).

Written from the document alone, so that tests can cross-check it against the C++ reader/writer.

  wmshard.py DIR --info               index.json as JSON
  wmshard.py DIR --episode K --json   global episode K as one JSON object
  wmshard.py DIR --all --json         JSON list of every episode
  wmshard.py DIR --verify [--decode]  check every byte; prints "OK <n> episodes"

Bad data never gives a traceback: one line on stderr naming file, record and expectation, exit 1.
"""
import argparse
import hashlib
import json
import mmap
import os
import re
import struct
import sys

import crc32c
import numpy as np
import zstandard

FORMAT_VERSION = 1
HEADER = struct.Struct("<8sII")  # magic, version, CRC32C of bytes 0..11
RECORD_HEAD = struct.Struct("<4sIQQ")  # magic, CRC32C of bytes 8..end, meta_length, body_length
INDEX_ENTRY = struct.Struct("<QQII")  # record offset, record length, num_steps, reserved
TRAILER = struct.Struct("<QQIIII8s")  # index_offset, num_records, index CRC, version, reserved, CRC, magic
ARRAY_DTYPES = {"float32": np.dtype("<f4"), "uint8": np.dtype("u1")}
BLOB_DTYPES = {"uint8": np.uint8, "uint16": np.uint16}
BLOB_MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "jpeg": b"\xff\xd8"}
# Sections every record has: name -> (dtype, shape after the leading T).
REQUIRED_ARRAYS = {"action": ("float32", [7]), "reward": ("float32", []), "discount": ("float32", []),
                   "is_first": ("uint8", []), "is_last": ("uint8", []), "is_terminal": ("uint8", [])}
INDEX_KEYS = ["format", "format_version", "dataset", "split", "source", "features", "shards",
              "num_episodes", "num_steps", "action_stats", "skipped", "provenance"]
SHARD_FILE = re.compile(r"^shard-[0-9]{5}\.wms$")


class ShardError(Exception):
    """Bad data: reported as one line on stderr, never as a traceback."""


def fail(where, what):
    """Raise the one error type the CLI reports; `where` names the file and record."""
    raise ShardError(f"{where}: {what}")


def is_int(x):
    """JSON integers only: bool is an int subclass in Python but not a JSON integer."""
    return isinstance(x, int) and not isinstance(x, bool)


def check_crc(where, stored, data):
    """Every stored CRC32C is compared with the bytes, and both values are named on mismatch."""
    got = crc32c.crc32c(data)
    if got != stored:
        fail(where, f"CRC32C mismatch: stored 0x{stored:08x}, computed 0x{got:08x}")


class Shard:
    """One memory-mapped shard file. Opening checks header, trailer and footer index (two small
    reads); records are checked when read, so random access never touches other records."""

    def __init__(self, path):
        self.path = path
        try:
            with open(path, "rb") as f:
                self.size = os.fstat(f.fileno()).st_size
                if self.size < HEADER.size + TRAILER.size:
                    fail(f"{path}: file header", f"truncated: file is {self.size} bytes, a shard "
                         f"has at least {HEADER.size + TRAILER.size} (header + trailer)")
                self.mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except OSError as e:
            fail(path, f"cannot open shard file: {e.strerror}")
        self.view = memoryview(self.mm)
        self._check_header()
        self._read_trailer_and_index()

    def _check_header(self):
        """Version before CRC, so a future-version file reports 'unknown version' not 'CRC'."""
        where = f"{self.path}: file header"
        magic, version, stored = HEADER.unpack_from(self.mm, 0)
        if magic != b"WMKSHARD":
            fail(where, f"bad magic {magic!r}, expected b'WMKSHARD' (not a wmkit shard?)")
        if version != FORMAT_VERSION:
            fail(where, f"unknown format version {version}, this reader supports {FORMAT_VERSION}")
        check_crc(where, stored, self.view[0:12])

    def _read_trailer_and_index(self):
        """The trailer locates the footer index; records must tile [16, index_offset) exactly."""
        where, t = f"{self.path}: trailer", self.size - TRAILER.size
        index_offset, n, index_crc, version, reserved, stored, magic = TRAILER.unpack_from(self.mm, t)
        if magic != b"WMKSHEND":
            fail(where, f"bad magic {magic!r} at offset {t + 32}, expected b'WMKSHEND' (truncated file?)")
        check_crc(where, stored, self.view[t:t + 28])
        if version != FORMAT_VERSION:
            fail(where, f"unknown format version {version}, this reader supports {FORMAT_VERSION}")
        if reserved != 0:
            fail(where, f"reserved field is {reserved}, expected 0")
        if index_offset < HEADER.size or index_offset + n * INDEX_ENTRY.size != t:
            fail(where, f"index_offset {index_offset} + {n} x {INDEX_ENTRY.size} B entries does not "
                 f"end at the trailer (offset {t}): truncated or corrupt")
        where = f"{self.path}: footer index"
        check_crc(where, index_crc, self.view[index_offset:t])
        self.entries, expected = [], HEADER.size
        for i in range(n):
            off, length, steps, reserved = INDEX_ENTRY.unpack_from(self.mm, index_offset + i * 24)
            if reserved != 0:
                fail(where, f"entry {i}: reserved field is {reserved}, expected 0")
            if off != expected or length < RECORD_HEAD.size:
                fail(where, f"entry {i}: record at offset {off} length {length}, expected offset "
                     f"{expected} (records back to back) and length >= {RECORD_HEAD.size}")
            self.entries.append((off, length, steps))
            expected = off + length
        if expected != index_offset:
            fail(where, f"records end at offset {expected}, expected index_offset {index_offset}")

    def record(self, i):
        """Return (meta, body) of record i, after its magic, lengths, CRC and meta are checked."""
        where = f"{self.path}: record {i}"
        off, length, steps = self.entries[i]
        magic, stored, meta_len, body_len = RECORD_HEAD.unpack_from(self.mm, off)
        if magic != b"WMER":
            fail(where, f"bad magic {magic!r} at offset {off}, expected b'WMER'")
        if RECORD_HEAD.size + meta_len + body_len != length:
            fail(where, f"24 + meta_length {meta_len} + body_length {body_len} != record length "
                 f"{length} in the footer index (truncated or corrupt)")
        check_crc(where, stored, self.view[off + 8:off + length])
        try:
            meta = json.loads(bytes(self.view[off + 24:off + 24 + meta_len]).decode("utf-8"))
        except ValueError as e:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
            fail(where, f"episode meta is not UTF-8 JSON: {e}")
        check_meta(meta, where, body_len)
        if meta["num_steps"] != steps:
            fail(where, f"meta num_steps {meta['num_steps']} != footer index num_steps {steps}")
        return meta, self.view[off + 24 + meta_len:off + length]


def check_meta(meta, where, body_len):
    """Validate the meta before any section is sliced, so bad meta is an error, not a crash."""
    types = {"episode_key": str, "source": dict, "num_steps": int, "language_instruction": str,
             "policy_id": str, "sections": list}
    if not isinstance(meta, dict):
        fail(where, "episode meta is not a JSON object")
    for key, typ in types.items():
        if not isinstance(meta.get(key), typ) or (typ is int and not is_int(meta[key])):
            fail(where, f"meta key {key!r} missing or not a {typ.__name__}")
    src = meta["source"]
    if not isinstance(src.get("file"), str) or not is_int(src.get("record")) or meta["num_steps"] < 0:
        fail(where, "meta 'source' must be {file: string, record: integer}, num_steps >= 0")
    if "episode_seed" not in meta or not (meta["episode_seed"] is None or is_int(meta["episode_seed"])):
        fail(where, "meta key 'episode_seed' missing or not an integer/null")
    T, seen = meta["num_steps"], {}
    for j, s in enumerate(meta["sections"]):
        name = s.get("name") if isinstance(s, dict) else None
        sw = f"{where}: section {name if isinstance(name, str) else j!r}"
        if not isinstance(name, str) or name in seen:
            fail(sw, "section is not an object with a unique string 'name'")
        if not all(is_int(s.get(k)) and s[k] >= 0 for k in ("offset", "length")):
            fail(sw, "'offset'/'length' missing or not non-negative integers")
        if s["offset"] + s["length"] > body_len:
            fail(sw, f"offset {s['offset']} + length {s['length']} runs past the body ({body_len} bytes)")
        shape = s.get("shape")
        if not isinstance(shape, list) or not shape or not all(is_int(d) and d >= 0 for d in shape):
            fail(sw, "'shape' missing or not a list of non-negative integers")
        if s.get("kind") == "array":
            if s.get("dtype") not in ARRAY_DTYPES or s.get("codec") not in ("zstd", "none"):
                fail(sw, f"dtype {s.get('dtype')!r}/codec {s.get('codec')!r}, expected float32|uint8 and zstd|none")
            raw = int(np.prod(shape, dtype=object)) * ARRAY_DTYPES[s["dtype"]].itemsize
            if shape[0] != T or s.get("raw_length") != raw:
                fail(sw, f"shape {shape}, raw_length {s.get('raw_length')}: expected first dimension "
                     f"{T} (num_steps) and raw_length {raw}")
            if s["codec"] == "none" and s["length"] != raw:
                fail(sw, f"codec none but length {s['length']} != raw_length {raw}")
        elif s.get("kind") == "blobs":
            if s.get("encoding") not in BLOB_MAGIC or s.get("dtype") not in BLOB_DTYPES or len(shape) != 3:
                fail(sw, "expected encoding jpeg|png, dtype uint8|uint16 and shape [H, W, C]")
            if s.get("count") != T:
                fail(sw, f"count {s.get('count')!r}, expected {T} (num_steps)")
        else:
            fail(sw, f"unknown kind {s.get('kind')!r}, expected 'array' or 'blobs'")
        seen[name] = s
    for name, (dtype, tail) in REQUIRED_ARRAYS.items():
        s = seen.get(name)
        if s is None or s["kind"] != "array" or s["dtype"] != dtype or s["shape"] != [T] + tail:
            fail(where, f"required section {name!r} missing or not a {dtype} array of shape {[T] + tail}")
    if seen.get("image", {}).get("kind") != "blobs":
        fail(where, "required section 'image' missing or not of kind 'blobs'")


def read_array(body, s, where):
    """Decompress (reading across zstd frames, without trusting a frame's content size) and
    insist on exactly raw_length bytes."""
    data = body[s["offset"]:s["offset"] + s["length"]]
    if s["codec"] == "zstd":
        out = bytearray()
        try:
            reader = zstandard.ZstdDecompressor().stream_reader(bytes(data), read_across_frames=True)
            while len(out) <= s["raw_length"]:
                chunk = reader.read(s["raw_length"] + 1 - len(out))
                if not chunk:
                    break
                out += chunk
        except zstandard.ZstdError as e:
            fail(where, f"zstd decompression failed: {e}")
        if len(out) != s["raw_length"]:
            got = "more than" if len(out) > s["raw_length"] else str(len(out))
            fail(where, f"decompressed size {got} bytes, expected raw_length {s['raw_length']}")
        data = bytes(out)
    return np.frombuffer(data, dtype=ARRAY_DTYPES[s["dtype"]]).reshape(s["shape"])


def read_blobs(body, s, where):
    """Split a blobs section: count u64 lengths, then images back to back filling it exactly."""
    data, n = body[s["offset"]:s["offset"] + s["length"]], s["count"]
    if 8 * n > len(data):
        fail(where, f"{n} u64 lengths need {8 * n} bytes, section length is {len(data)}")
    lengths = [int(x) for x in np.frombuffer(data[:8 * n], dtype="<u8")]
    if 8 * n + sum(lengths) != len(data):
        fail(where, f"{n} lengths + images = {8 * n + sum(lengths)} bytes, expected section length {len(data)}")
    blobs, pos = [], 8 * n
    for j, length in enumerate(lengths):
        blob = bytes(data[pos:pos + length])
        if not blob.startswith(BLOB_MAGIC[s["encoding"]]):
            fail(where, f"frame {j} does not start with the {s['encoding']} signature")
        blobs.append(blob)
        pos += length
    return blobs


class Dataset:
    """A dataset directory: index.json (checked on open) plus lazily opened shards."""

    def __init__(self, directory):
        self.dir, self.index_path = directory, os.path.join(directory, "index.json")
        try:
            with open(self.index_path, "rb") as f:
                self.index = json.loads(f.read().decode("utf-8"))
        except OSError as e:
            fail(self.index_path, f"cannot read ({e.strerror}): not a wmkit dataset directory")
        except ValueError as e:
            fail(self.index_path, f"not UTF-8 JSON: {e}")
        idx, where = self.index, self.index_path
        if not isinstance(idx, dict) or idx.get("format") != "wmkit-shard":
            fail(where, f"format {idx.get('format') if isinstance(idx, dict) else idx!r}, expected 'wmkit-shard'")
        if idx.get("format_version") != FORMAT_VERSION:
            fail(where, f"unknown format_version {idx.get('format_version')!r}, this reader supports {FORMAT_VERSION}")
        if not isinstance(idx.get("shards"), list):
            fail(where, "'shards' missing or not a list")
        for j, e in enumerate(idx["shards"]):
            ok = isinstance(e, dict) and isinstance(e.get("file"), str) and SHARD_FILE.match(e["file"])
            if not ok or not all(is_int(e.get(k)) and e[k] >= 0 for k in ("bytes", "num_episodes", "num_steps")) \
                    or not re.fullmatch(r"[0-9a-f]{64}", str(e.get("sha256"))):
                fail(where, f"shards[{j}]: expected file shard-NNNNN.wms, integer bytes/num_episodes/"
                     "num_steps and a lowercase hex sha256")
        self.num_episodes = sum(e["num_episodes"] for e in idx["shards"])
        self._shards = {}

    def shard(self, j):
        """Open shard j once; its record count must be what index.json promises."""
        if j not in self._shards:
            entry = self.index["shards"][j]
            shard = Shard(os.path.join(self.dir, entry["file"]))
            if len(shard.entries) != entry["num_episodes"]:
                fail(f"{shard.path}: trailer", f"num_records {len(shard.entries)}, index.json says "
                     f"num_episodes {entry['num_episodes']}")
            self._shards[j] = shard
        return self._shards[j]

    def locate(self, k):
        """Global episode k -> (shard number, record number), via cumulative num_episodes."""
        if not 0 <= k < self.num_episodes:
            fail(self.index_path, f"episode {k} out of range: dataset has {self.num_episodes} episodes")
        for j, e in enumerate(self.index["shards"]):
            if k < e["num_episodes"]:
                return j, k
            k -= e["num_episodes"]

    def episode(self, k):
        """Fully decode episode k (every section checked) into (JSON-ready dict, meta, blobs)."""
        j, i = self.locate(k)
        shard = self.shard(j)
        meta, body = shard.record(i)
        where = f"{shard.path}: record {i}"
        arrays, blobs = {}, {}
        for s in meta["sections"]:
            sw = f"{where}: section {s['name']!r}"
            if s["kind"] == "array":
                arrays[s["name"]] = read_array(body, s, sw)
            else:
                blobs[s["name"]] = read_blobs(body, s, sw)
        image = next(s for s in meta["sections"] if s["name"] == "image")
        out = {"episode_index": k, "shard": self.index["shards"][j]["file"], "record": i,
               **{key: meta[key] for key in ("episode_key", "source", "num_steps", "language_instruction",
                                            "policy_id", "episode_seed")},
               "actions": arrays["action"].tolist(), "rewards": arrays["reward"].tolist(),
               "discounts": arrays["discount"].tolist(),
               **{key: arrays[key].tolist() for key in ("is_first", "is_last", "is_terminal")},
               "image_shape": image["shape"], "image_encoding": image["encoding"],
               "num_frames": {name: len(b) for name, b in blobs.items()},
               "image_sha256": [hashlib.sha256(b).hexdigest() for b in blobs["image"]],
               "blob_sha256": {name: [hashlib.sha256(x).hexdigest() for x in b] for name, b in blobs.items()}}
        return out, meta, blobs


def verify(ds, decode):
    """Check everything the doc specifies; return the episode count. Cheap size check first
    (clearest for truncation), structure and CRCs next, whole-file sha256 last."""
    idx, where = ds.index, ds.index_path
    missing = [k for k in INDEX_KEYS if k not in idx]
    if missing:
        fail(where, f"missing required keys {missing}")
    features, actions, keys, k, total_steps = idx["features"], [], set(), 0, 0
    if not isinstance(features, dict) or not isinstance(features.get("action"), dict) \
            or features["action"].get("dim") != 7:
        fail(where, "features.action.dim must be 7")
    for j, entry in enumerate(idx["shards"]):
        path = os.path.join(ds.dir, entry["file"])
        if not os.path.isfile(path):
            fail(path, "shard file listed in index.json is missing")
        if os.path.getsize(path) != entry["bytes"]:
            fail(path, f"file is {os.path.getsize(path)} bytes, index.json says {entry['bytes']} "
                 "(truncated or modified)")
        steps = 0
        for i in range(len(ds.shard(j).entries)):
            ep, meta, blobs = ds.episode(k)
            rw = f"{path}: record {i}"
            if ep["episode_key"] in keys:
                fail(rw, f"duplicate episode_key {ep['episode_key']!r}")
            keys.add(ep["episode_key"])
            for s in meta["sections"]:
                if s["kind"] == "blobs":
                    feat = features.get(s["name"])
                    want = {key: s[key] for key in ("encoding", "shape", "dtype")}
                    if not isinstance(feat, dict) or {key: feat.get(key) for key in want} != want:
                        fail(rw, f"section {s['name']!r} is {want}, index.json features say {feat}")
                    if decode:
                        check_decoded(blobs[s["name"]], s, f"{rw}: section {s['name']!r}")
            actions.append(np.asarray(ep["actions"], dtype=np.float64).reshape(-1, 7))
            steps, k = steps + ep["num_steps"], k + 1
        if steps != entry["num_steps"]:
            fail(path, f"records hold {steps} steps, index.json says num_steps {entry['num_steps']}")
        sha = hashlib.sha256(ds.shard(j).mm).hexdigest()
        if sha != entry["sha256"]:
            fail(path, f"sha256 {sha}, index.json says {entry['sha256']}")
        total_steps += steps
    if (k, total_steps) != (idx["num_episodes"], idx["num_steps"]):
        fail(where, f"shards hold {k} episodes / {total_steps} steps, index.json says "
             f"num_episodes {idx['num_episodes']} / num_steps {idx['num_steps']}")
    check_stats(idx, np.concatenate(actions) if actions else np.zeros((0, 7)), where)
    prov = idx["provenance"]
    config = json.dumps(prov.get("config"), separators=(",", ":"), sort_keys=True, ensure_ascii=False)
    if hashlib.sha256(config.encode("utf-8")).hexdigest() != prov.get("config_hash"):
        fail(where, "provenance.config_hash is not the SHA-256 of compact sorted-key JSON of provenance.config")
    skipped = idx["skipped"]
    if not isinstance(skipped, dict) or skipped.get("count") != len(skipped.get("episodes", [])):
        fail(where, "skipped.count must equal the length of skipped.episodes")
    return k


def check_stats(idx, a, where):
    """Recompute action_stats in float64 (population std, numpy linear quantiles); a tolerance
    absorbs float32 accumulation in other writers."""
    if len(a) == 0:
        return  # statistics of zero steps are undefined; nothing to compare
    stats = idx["action_stats"]
    computed = {"mean": a.mean(0), "std": a.std(0), "min": a.min(0), "max": a.max(0),
                "q01": np.quantile(a, 0.01, axis=0), "q99": np.quantile(a, 0.99, axis=0)}
    for key, want in computed.items():
        got = stats.get(key) if isinstance(stats, dict) else None
        if not (isinstance(got, list) and len(got) == 7 and all(isinstance(x, (int, float)) for x in got)
                and np.allclose(got, want, rtol=1e-4, atol=1e-6)):
            fail(where, f"action_stats.{key} is {got}, recomputed from the shards {want.tolist()}")


def check_decoded(blobs, s, where):
    """Optional (--decode): every frame decodes with OpenCV to the declared shape and dtype."""
    import cv2  # only here: importing OpenCV is slow and most commands never decode
    for j, blob in enumerate(blobs):
        img = cv2.imdecode(np.frombuffer(blob, np.uint8), cv2.IMREAD_UNCHANGED)
        if img is None:
            fail(where, f"frame {j} does not decode as {s['encoding']}")
        shape = list(img.shape) + ([1] if img.ndim == 2 else [])
        if shape != s["shape"] or img.dtype != BLOB_DTYPES[s["dtype"]]:
            fail(where, f"frame {j} decodes to {shape} {img.dtype}, expected {s['shape']} {s['dtype']}")


def main(argv=None):
    """CLI entry point; maps every data error to one stderr line and exit status 1."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dir", help="dataset directory (holds index.json)")
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--info", action="store_true", help="print index.json")
    mode.add_argument("--episode", type=int, metavar="K", help="print global episode K (0-based)")
    mode.add_argument("--all", action="store_true", help="print every episode")
    mode.add_argument("--verify", action="store_true", help="check the whole dataset")
    p.add_argument("--json", action="store_true", help="JSON output (the only format; accepted for clarity)")
    p.add_argument("--decode", action="store_true", help="with --verify, also decode every image")
    args = p.parse_args(argv)
    try:
        ds = Dataset(args.dir)
        if args.verify:
            print(f"OK {verify(ds, args.decode)} episodes")
            return 0
        if args.info:
            out = ds.index
        elif args.all:
            out = [ds.episode(k)[0] for k in range(ds.num_episodes)]
        else:
            out = ds.episode(args.episode)[0]
    except ShardError as e:
        print(f"wmshard: error: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # a reader bug or an unforeseen corruption: still no traceback
        print(f"wmshard: error: {args.dir}: unexpected {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    json.dump(out, sys.stdout, indent=2 if args.info else None)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
