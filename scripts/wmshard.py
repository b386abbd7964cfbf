#!/usr/bin/python3
"""Independent reader/verifier for wmkit shard format v1, written from docs/shard-format.md alone
so tests can cross-check it against the C++ reader and writer.

  wmshard.py DIR --info | --episode K --json | --all --json | --verify

Bad data never gives a traceback: one stderr line naming file, record and expectation; exit 1.
"""
import argparse
import hashlib
import json
import mmap
import os
import re
import signal
import struct
import sys

import crc32c
import numpy as np
import zstandard

VERSION = 1
HEADER = struct.Struct("<8sII")  # magic, version, CRC32C of bytes 0..11
RECORD = struct.Struct("<4sIQQ")  # magic, CRC32C of bytes 8..end, meta_length, body_length
ENTRY = struct.Struct("<QQII")  # record offset, record length, num_steps, reserved
# index_offset, num_records, index CRC, version, reserved, CRC of bytes 0..27, magic
TRAILER = struct.Struct("<QQIIII8s")
ARRAY_DTYPES = {"float32": np.dtype("<f4"), "uint8": np.dtype("u1")}
BLOB_DTYPES = ("uint8", "uint16")
BLOB_MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "jpeg": b"\xff\xd8"}
# Sections every record has: name -> (dtype, shape after the leading num_steps).
REQUIRED = {"action": ("float32", [7]), "reward": ("float32", []), "discount": ("float32", []),
            "is_first": ("uint8", []), "is_last": ("uint8", []), "is_terminal": ("uint8", [])}
META_TYPES = {"episode_key": str, "source": dict, "num_steps": int, "language_instruction": str,
              "policy_id": str, "sections": list}
INDEX_KEYS = ["format", "format_version", "dataset", "split", "source", "features", "shards",
              "num_episodes", "num_steps", "action_stats", "skipped", "provenance"]


class ShardError(Exception):
    """Bad data: reported as one line on stderr, never as a traceback."""


def fail(where, what):
    """Raise the one error type the CLI reports; `where` names the file and record."""
    raise ShardError(f"{where}: {what}")


def is_int(x, minimum=0):
    """JSON integer >= minimum (bool is a Python int but not a JSON integer)."""
    return isinstance(x, int) and not isinstance(x, bool) and x >= minimum


def check_crc(where, stored, data):
    """Compare a stored CRC32C with the bytes; name both values on mismatch."""
    got = crc32c.crc32c(data)
    if got != stored:
        fail(where, f"CRC32C mismatch: stored 0x{stored:08x}, computed 0x{got:08x}")


class Shard:
    """A memory-mapped shard. Opening checks header, trailer and footer index (two small reads);
    a record is checked only when read, so random access never touches the others."""

    def __init__(self, path):
        self.path = path
        try:
            with open(path, "rb") as f:
                self.size = os.fstat(f.fileno()).st_size
                if self.size < HEADER.size + TRAILER.size:
                    fail(f"{path}: file header", f"truncated: file is {self.size} bytes, a shard "
                         "has at least 56 (header + trailer)")
                self.mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except OSError as e:
            fail(path, f"cannot open shard file: {e.strerror}")
        self.view = memoryview(self.mm)
        where = f"{path}: file header"  # version before CRC: a v2 file says "unknown version"
        magic, version, stored = HEADER.unpack_from(self.mm, 0)
        if magic != b"WMKSHARD":
            fail(where, f"bad magic {magic!r}, expected b'WMKSHARD' (not a wmkit shard?)")
        if version != VERSION:
            fail(where, f"unknown format version {version}, this reader supports {VERSION}")
        check_crc(where, stored, self.view[0:12])
        self._read_trailer_and_index()

    def _read_trailer_and_index(self):
        """The trailer locates the footer index, whose records must tile [16, index_offset)."""
        where, t = f"{self.path}: trailer", self.size - TRAILER.size
        index_offset, n, index_crc, version, reserved, stored, magic = TRAILER.unpack_from(
            self.mm, t)
        if magic != b"WMKSHEND":
            fail(where, f"bad magic {magic!r} at offset {t + 32}, expected b'WMKSHEND' "
                 "(truncated file?)")
        check_crc(where, stored, self.view[t:t + 28])
        if version != VERSION:
            fail(where, f"unknown format version {version}, this reader supports {VERSION}")
        if reserved != 0:
            fail(where, f"reserved field is {reserved}, expected 0")
        if index_offset < HEADER.size or index_offset + n * ENTRY.size != t:
            fail(where, f"index_offset {index_offset} + {n} x 24 B entries does not end at the "
                 f"trailer (offset {t}): truncated or corrupt")
        where = f"{self.path}: footer index"
        check_crc(where, index_crc, self.view[index_offset:t])
        self.entries, expected = [], HEADER.size
        for i in range(n):
            off, length, steps, reserved = ENTRY.unpack_from(self.mm, index_offset + i * ENTRY.size)
            if off != expected or length < RECORD.size or reserved != 0:
                fail(where, f"entry {i}: offset {off}, length {length}, reserved {reserved}; "
                     f"expected offset {expected} (records back to back), length >= 24, "
                     "reserved 0")
            self.entries.append((off, length, steps))
            expected = off + length
        if expected != index_offset:
            fail(where, f"records end at offset {expected}, expected index_offset {index_offset}")

    def record(self, i):
        """(meta, body) of record i, after its magic, lengths, CRC and meta are checked."""
        where = f"{self.path}: record {i}"
        off, length, steps = self.entries[i]
        magic, stored, meta_len, body_len = RECORD.unpack_from(self.mm, off)
        if magic != b"WMER":
            fail(where, f"bad magic {magic!r} at offset {off}, expected b'WMER'")
        if RECORD.size + meta_len + body_len != length:
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
    """Validate the meta before any section is sliced, so a lying meta is an error, not a crash."""
    if not isinstance(meta, dict):
        fail(where, "episode meta is not a JSON object")
    for key, typ in META_TYPES.items():
        if not (is_int(meta.get(key)) if typ is int else isinstance(meta.get(key), typ)):
            fail(where, f"meta key {key!r} missing or not a "
                 f"{'non-negative int' if typ is int else typ.__name__}")
    src, seed = meta["source"], meta.get("episode_seed", "missing")
    if not isinstance(src.get("file"), str) or not is_int(src.get("record")):
        fail(where, "meta 'source' must be {file: string, record: integer}")
    if not (seed is None or is_int(seed, -2**63)):
        fail(where, f"meta 'episode_seed' is {seed!r}, expected an integer or null")
    T, seen = meta["num_steps"], {}
    for j, s in enumerate(meta["sections"]):
        name = s.get("name") if isinstance(s, dict) else None
        sw = f"{where}: section {name if isinstance(name, str) else j!r}"
        if not isinstance(name, str) or name in seen:
            fail(sw, "section is not an object with a unique string 'name'")
        if not (is_int(s.get("offset")) and is_int(s.get("length"))):
            fail(sw, "'offset'/'length' missing or not non-negative integers")
        if s["offset"] + s["length"] > body_len:
            fail(sw, f"offset {s['offset']} + length {s['length']} runs past the body "
                 f"({body_len} bytes)")
        shape = s.get("shape")
        if not isinstance(shape, list) or not shape or not all(is_int(d) for d in shape):
            fail(sw, "'shape' missing or not a list of non-negative integers")
        if s.get("kind") == "array":
            if s.get("dtype") not in ARRAY_DTYPES or s.get("codec") not in ("zstd", "none"):
                fail(sw, f"dtype {s.get('dtype')!r}, codec {s.get('codec')!r}: expected "
                     "float32|uint8 and zstd|none")
            raw = int(np.prod(shape, dtype=object)) * ARRAY_DTYPES[s["dtype"]].itemsize
            if shape[0] != T or s.get("raw_length") != raw:
                fail(sw, f"shape {shape}, raw_length {s.get('raw_length')}: expected first "
                     f"dimension {T} (num_steps) and raw_length {raw}")
            if s["codec"] == "none" and s["length"] != raw:
                fail(sw, f"codec none but length {s['length']} != raw_length {raw}")
        elif s.get("kind") == "blobs":
            if (s.get("encoding") not in BLOB_MAGIC or s.get("dtype") not in BLOB_DTYPES
                    or len(shape) != 3):
                fail(sw, "expected encoding jpeg|png, dtype uint8|uint16 and shape [H, W, C]")
            if s.get("count") != T:
                fail(sw, f"count {s.get('count')!r}, expected {T} (num_steps)")
        else:
            fail(sw, f"unknown kind {s.get('kind')!r}, expected 'array' or 'blobs'")
        seen[name] = s
    for name, (dtype, tail) in REQUIRED.items():
        s = seen.get(name, {})
        if s.get("kind") != "array" or s["dtype"] != dtype or s["shape"] != [T] + tail:
            fail(where, f"required section {name!r} missing or not a {dtype} array of shape "
                 f"{[T] + tail}")
    if seen.get("image", {}).get("kind") != "blobs":
        fail(where, "required section 'image' missing or not of kind 'blobs'")


def read_section(body, s, where):
    """Array -> ndarray (exactly raw_length bytes after zstd, read across frames without trusting
    a frame's content size); blobs -> list of bytes (count u64 lengths + images fill it exactly)."""
    data = body[s["offset"]:s["offset"] + s["length"]]
    if s["kind"] == "array":
        if s["codec"] == "zstd":
            out, want = bytearray(), s["raw_length"]
            try:
                reader = zstandard.ZstdDecompressor().stream_reader(
                    bytes(data), read_across_frames=True)
                while len(out) <= want and (chunk := reader.read(want + 1 - len(out))):
                    out += chunk
            except zstandard.ZstdError as e:
                fail(where, f"zstd decompression failed: {e}")
            if len(out) != want:
                got = "more than" if len(out) > want else str(len(out))
                fail(where, f"decompressed size {got} bytes, expected raw_length {want}")
            data = bytes(out)
        return np.frombuffer(data, dtype=ARRAY_DTYPES[s["dtype"]]).reshape(s["shape"])
    n = s["count"]
    lengths = [int(x) for x in np.frombuffer(data[:8 * n], "<u8")] if 8 * n <= len(data) else None
    if lengths is None or 8 * n + sum(lengths) != len(data):
        fail(where, f"{n} u64 lengths + images do not fill the section length {len(data)} exactly")
    ends = np.cumsum([8 * n] + lengths).tolist()
    blobs = [bytes(data[a:b]) for a, b in zip(ends, ends[1:])]
    for j, blob in enumerate(blobs):
        if not blob.startswith(BLOB_MAGIC[s["encoding"]]):
            fail(where, f"frame {j} does not start with the {s['encoding']} signature")
    return blobs


class Dataset:
    """A dataset directory: index.json (checked on open) plus lazily opened shards."""

    def __init__(self, directory):
        self.dir, self._shards = directory, {}
        where = self.index_path = os.path.join(directory, "index.json")
        try:
            with open(where, "rb") as f:
                idx = self.index = json.loads(f.read().decode("utf-8"))
        except OSError as e:
            fail(where, f"cannot read ({e.strerror}): not a wmkit dataset directory")
        except ValueError as e:
            fail(where, f"not UTF-8 JSON: {e}")
        if not isinstance(idx, dict) or idx.get("format") != "wmkit-shard":
            fail(where, "not a JSON object with format 'wmkit-shard'")
        if idx.get("format_version") != VERSION:
            fail(where, f"unknown format_version {idx.get('format_version')!r}, this reader "
                 f"supports {VERSION}")
        for j, e in enumerate(idx.get("shards") if isinstance(idx.get("shards"), list) else [None]):
            if not (isinstance(e, dict) and re.fullmatch(r"shard-[0-9]{5}\.wms", str(e.get("file")))
                    and all(is_int(e.get(k)) for k in ("bytes", "num_episodes", "num_steps"))
                    and re.fullmatch(r"[0-9a-f]{64}", str(e.get("sha256")))):
                fail(where, f"shards[{j}]: expected {{file: shard-NNNNN.wms, bytes, sha256 (64 "
                     "lowercase hex), num_episodes, num_steps}")
        self.num_episodes = sum(e["num_episodes"] for e in idx["shards"])

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

    def episode(self, k):
        """Global episode k (located by cumulative num_episodes), every section decoded and
        checked; returns (JSON-ready dict, meta, blobs by stream)."""
        if not 0 <= k < self.num_episodes:
            fail(self.index_path, f"episode {k} out of range: dataset has {self.num_episodes} "
                 "episodes")
        j, i = 0, k
        while i >= self.index["shards"][j]["num_episodes"]:
            i, j = i - self.index["shards"][j]["num_episodes"], j + 1
        shard = self.shard(j)
        meta, body = shard.record(i)
        data = {s["name"]: read_section(body, s, f"{shard.path}: record {i}: section {s['name']!r}")
                for s in meta["sections"]}
        blobs = {s["name"]: data[s["name"]] for s in meta["sections"] if s["kind"] == "blobs"}
        image = next(s for s in meta["sections"] if s["name"] == "image")
        sha = {name: [hashlib.sha256(b).hexdigest() for b in frames]
               for name, frames in blobs.items()}
        out = {"episode_index": k, "shard": self.index["shards"][j]["file"], "record": i,
               **{key: meta[key] for key in ("episode_key", "source", "num_steps",
                                            "language_instruction", "policy_id", "episode_seed")},
               "actions": data["action"].tolist(), "rewards": data["reward"].tolist(),
               "discounts": data["discount"].tolist(), "is_first": data["is_first"].tolist(),
               "is_last": data["is_last"].tolist(), "is_terminal": data["is_terminal"].tolist(),
               "image_shape": image["shape"], "image_encoding": image["encoding"],
               "num_frames": {name: len(frames) for name, frames in blobs.items()},
               "image_sha256": sha["image"], "blob_sha256": sha}
        return out, meta, blobs


def verify(ds):
    """Check everything the doc specifies; return the episode count. Order: file size (clearest
    for truncation), then structure and CRCs, then whole-file sha256, then dataset totals."""
    idx, where = ds.index, ds.index_path
    if [k for k in INDEX_KEYS if k not in idx]:
        fail(where, f"missing required keys {[k for k in INDEX_KEYS if k not in idx]}")
    features, actions, k, total_steps = idx["features"], [], 0, 0
    if not isinstance(features, dict) or (features.get("action") or {}).get("dim") != 7:
        fail(where, "features.action.dim must be 7")
    for j, entry in enumerate(idx["shards"]):
        path = os.path.join(ds.dir, entry["file"])
        size = os.path.getsize(path) if os.path.isfile(path) else "missing, 0"
        if size != entry["bytes"]:
            fail(path, f"file is {size} bytes, index.json says {entry['bytes']} "
                 "(truncated or modified)")
        steps = 0
        for i in range(len(ds.shard(j).entries)):
            ep, meta, _ = ds.episode(k)
            rw = f"{path}: record {i}"
            for s in (s for s in meta["sections"] if s["kind"] == "blobs"):
                want = {key: s[key] for key in ("encoding", "shape", "dtype")}
                feat = features.get(s["name"]) if isinstance(features.get(s["name"]), dict) else {}
                if {key: feat.get(key) for key in want} != want:
                    fail(rw, f"section {s['name']!r} is {want}, index.json features say {feat}")
            actions.append(np.asarray(ep["actions"], dtype=np.float64).reshape(-1, 7))
            steps, k = steps + ep["num_steps"], k + 1
        if steps != entry["num_steps"]:
            fail(path, f"records hold {steps} steps, index.json says num_steps "
                 f"{entry['num_steps']}")
        sha = hashlib.sha256(ds.shard(j).mm).hexdigest()
        if sha != entry["sha256"]:
            fail(path, f"sha256 {sha}, index.json says {entry['sha256']}")
        total_steps += steps
    if (k, total_steps) != (idx["num_episodes"], idx["num_steps"]):
        fail(where, f"shards hold {k} episodes / {total_steps} steps, index.json says "
             f"num_episodes {idx['num_episodes']} / num_steps {idx['num_steps']}")
    check_stats(idx["action_stats"], np.concatenate(actions or [np.zeros((0, 7))]), where)
    prov = idx["provenance"] if isinstance(idx["provenance"], dict) else {}
    config = json.dumps(prov.get("config"), separators=(",", ":"), sort_keys=True,
                        ensure_ascii=False)
    if hashlib.sha256(config.encode("utf-8")).hexdigest() != prov.get("config_hash"):
        fail(where, "provenance.config_hash is not the SHA-256 of provenance.config as compact "
             "sorted-key JSON")
    skipped = idx["skipped"]
    if not (isinstance(skipped, dict) and isinstance(skipped.get("episodes"), list)
            and skipped.get("count") == len(skipped["episodes"])):
        fail(where, "skipped.count must equal the length of skipped.episodes")
    return k


def check_stats(stats, a, where):
    """Recompute action_stats in float64 (population std, numpy's linear quantiles); the
    tolerance absorbs float32 accumulation in other writers."""
    if len(a) == 0:
        return  # statistics over zero steps are undefined: nothing to compare
    computed = {"mean": a.mean(0), "std": a.std(0), "min": a.min(0), "max": a.max(0),
                "q01": np.quantile(a, 0.01, axis=0), "q99": np.quantile(a, 0.99, axis=0)}
    for key, want in computed.items():
        got = stats.get(key) if isinstance(stats, dict) else None
        if not (isinstance(got, list) and len(got) == 7
                and all(isinstance(x, (int, float)) for x in got)
                and np.allclose(got, want, rtol=1e-4, atol=1e-6)):
            fail(where, f"action_stats.{key} is {got}, recomputed from the shards {want.tolist()}")


def main(argv=None):
    """CLI entry point; maps every data error to one stderr line and exit status 1."""
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `wmshard.py ... | head` ends quietly
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dir", help="dataset directory (holds index.json)")
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--info", action="store_true", help="print index.json")
    mode.add_argument("--episode", type=int, metavar="K", help="print global episode K (0-based)")
    mode.add_argument("--all", action="store_true", help="print a list of every episode")
    mode.add_argument("--verify", action="store_true", help="check the whole dataset")
    p.add_argument("--json", action="store_true", help="JSON output (the only format)")
    args = p.parse_args(argv)
    try:
        ds = Dataset(args.dir)
        if args.verify:
            print(f"OK {verify(ds)} episodes")
            return 0
        out = ds.index if args.info else [ds.episode(k)[0] for k in range(ds.num_episodes)] \
            if args.all else ds.episode(args.episode)[0]
    except ShardError as e:
        print(f"wmshard: error: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # a reader bug or an unforeseen corruption: still no traceback
        print(f"wmshard: error: {args.dir}: unexpected {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    print(json.dumps(out, indent=2 if args.info else None))
    return 0


if __name__ == "__main__":
    sys.exit(main())
