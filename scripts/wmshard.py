#!/usr/bin/python3
"""Independent reader/verifier for wmkit shard format v1 and token format v1 (index v1/v2), written from
docs/shard-format.md and docs/token-format.md alone so tests can cross-check it against the C++
readers and writers.

  wmshard.py DIR --info | --episode K --json | --all --json | --verify
  wmshard.py --tokens TOKENS_DIR --info | --episode K --json | --all --json | --verify

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
# index.json versions: 2 marks actions other than the canonical 7-dim eef_delta
# (docs/shard-format.md, "Action width"); shard files stay version 1.
INDEX_VERSIONS = (1, 2)
ACTION_SPACES = ("eef_delta", "joint_position", "other")
HEADER = struct.Struct("<8sII")  # magic, version, CRC32C of bytes 0..11
RECORD = struct.Struct("<4sIQQ")  # magic, CRC32C of bytes 8..end, meta_length, body_length
ENTRY = struct.Struct("<QQII")  # record offset, record length, num_steps, reserved
# index_offset, num_records, index CRC, version, reserved, CRC of bytes 0..27, magic
TRAILER = struct.Struct("<QQIIII8s")
ARRAY_DTYPES = {"float32": np.dtype("<f4"), "uint8": np.dtype("u1")}
BLOB_DTYPES = ("uint8", "uint16")
BLOB_MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "jpeg": b"\xff\xd8"}
# Sections every record has: name -> (dtype, shape after the leading num_steps).
# The action's width is the dataset's (features.action.dim: 7 in version 1, any in version 2).
REQUIRED = {"action": ("float32", None), "reward": ("float32", []), "discount": ("float32", []),
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
        ok = s.get("kind") == "array" and s["dtype"] == dtype and (
            s["shape"] == [T] + tail if tail is not None else
            len(s["shape"]) == 2 and s["shape"][0] == T and s["shape"][1] >= 1)
        if not ok:
            want = [T] + tail if tail is not None else [T, "D"]
            fail(where, f"required section {name!r} missing or not a {dtype} array of shape "
                 f"{want}")
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
        if idx.get("format_version") not in INDEX_VERSIONS:
            fail(where, f"unknown format_version {idx.get('format_version')!r}, this reader "
                 f"supports {INDEX_VERSIONS}")
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
    dim = action_dim(idx, where)
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
            a = np.asarray(ep["actions"], dtype=np.float64)
            if a.ndim != 2 or a.shape[1] != dim:
                fail(rw, f"action section is {list(a.shape)}, index.json features.action.dim "
                     f"is {dim}")
            actions.append(a)
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
    check_stats(idx["action_stats"], np.concatenate(actions or [np.zeros((0, dim))]), where)
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


def action_dim(idx, where):
    """features.action.dim: 7 in version 1; in version 2 any positive width, with a space."""
    action = (idx["features"] if isinstance(idx["features"], dict) else {}).get("action") or {}
    dim = action.get("dim")
    if idx["format_version"] == 1 and dim != 7:
        fail(where, f"features.action.dim is {dim!r}: format_version 1 means the 7-dim action")
    if not is_int(dim) or dim < 1:
        fail(where, f"features.action.dim is {dim!r}, expected a positive integer")
    if idx["format_version"] == 2 and action.get("space") not in ACTION_SPACES:
        fail(where, f"features.action.space is {action.get('space')!r}, expected eef_delta, "
             "joint_position or other")
    return dim


def check_stats(stats, a, where):
    """Recompute action_stats in float64 (population std, numpy's linear quantiles); the
    tolerance absorbs float32 accumulation in other writers."""
    if len(a) == 0:
        return  # statistics over zero steps are undefined: nothing to compare
    computed = {"mean": a.mean(0), "std": a.std(0), "min": a.min(0), "max": a.max(0),
                "q01": np.quantile(a, 0.01, axis=0), "q99": np.quantile(a, 0.99, axis=0)}
    for key, want in computed.items():
        got = stats.get(key) if isinstance(stats, dict) else None
        if not (isinstance(got, list) and len(got) == a.shape[1]
                and all(isinstance(x, (int, float)) for x in got)
                and np.allclose(got, want, rtol=1e-4, atol=1e-6)):
            fail(where, f"action_stats.{key} is {got}, recomputed from the shards {want.tolist()}")


# --- Token datasets (docs/token-format.md): index.json + part-NNNNN.wmtok files of raw arrays ---

TOKEN_FORMAT, TOKEN_MAGIC, TOKEN_ALIGN = "wmkit-tokens", b"WMTOKEN1", 64
# magic, version, token bytes (2|4), grid_h, grid_w, levels (0: one), 32 zero bytes, CRC32C of
# bytes 0..59
TOKEN_HEADER = struct.Struct("<8sIIIII32sI")
# index.json versions: 1 (7-dim eef_delta actions), 2 (any action width), 3 (residual levels)
TOKEN_INDEX_VERSIONS, TOKEN_LEVELS_VERSION, MAX_TOKEN_LEVELS = (1, 2, 3), 3, 8
TOKEN_DTYPES = {"uint16": "<u2", "uint32": "<u4"}
# Per-step sections, in file order after "tokens": name -> (numpy dtype, shape after F); None:
# [D], the dataset's action width (index.json action_dim; 7 in version 1).
STEP_SECTIONS = {"actions": ("<f4", None), "rewards": ("<f4", []), "discounts": ("<f4", []),
                 "is_first": ("|u1", []), "is_last": ("|u1", []), "is_terminal": ("|u1", [])}
TOKEN_EPISODE_TYPES = {"part": int, "frame_offset": int, "num_frames": int, "source_episode": int,
                       "episode_key": str, "policy_id": str, "language_instruction": str}
TOKEN_PART_KEYS = ("bytes", "num_episodes", "num_frames")


def check_token_index(idx, where):
    """Everything reading needs from index.json, checked before any file is opened, so a lying
    index is a named error rather than a crash."""
    if not isinstance(idx, dict) or idx.get("format") != TOKEN_FORMAT:
        fail(where, f"not a JSON object with format '{TOKEN_FORMAT}'")
    if idx.get("format_version") not in TOKEN_INDEX_VERSIONS:
        fail(where, f"unknown format_version {idx.get('format_version')!r}, this reader supports "
             f"{', '.join(map(str, TOKEN_INDEX_VERSIONS))}")
    dim = token_action_dim(idx)
    if not (is_int(dim, 1) and idx.get("action_space", "eef_delta") in ACTION_SPACES):
        fail(where, f"action_dim {dim!r} / action_space {idx.get('action_space')!r}: version 2 "
             "needs a positive action_dim and one of " + ", ".join(ACTION_SPACES))
    stats = idx.get("action_stats")
    if not (isinstance(stats, dict) and all(isinstance(stats.get(k), list) and len(stats[k]) == dim
                                            for k in ("mean", "std", "min", "max", "q01", "q99"))):
        fail(where, f"action_stats must hold mean, std, min, max, q01, q99 of {dim} values each")
    tok = idx.get("tokenizer") if isinstance(idx.get("tokenizer"), dict) else {}
    grid = tok.get("grid")
    if not (is_int(tok.get("num_codes"), 1) and isinstance(grid, list) and len(grid) == 2
            and all(is_int(g, 1) for g in grid)):
        fail(where, "tokenizer must hold num_codes >= 1 and grid [grid_h, grid_w] >= 1")
    if idx["format_version"] == TOKEN_LEVELS_VERSION:
        if not (is_int(tok.get("levels"), 2) and tok["levels"] <= MAX_TOKEN_LEVELS):
            fail(where, f"format_version 3 needs tokenizer.levels in [2, {MAX_TOKEN_LEVELS}], "
                 f"got {tok.get('levels')!r}")
    elif "levels" in tok:
        fail(where, "tokenizer.levels is only written by format_version 3")
    if idx.get("token_dtype") not in TOKEN_DTYPES:
        fail(where, f"token_dtype {idx.get('token_dtype')!r}, expected uint16 or uint32")
    parts, n = idx.get("parts"), idx.get("num_parts")
    if not (is_int(n, 1) and isinstance(parts, list) and len(parts) == n):
        fail(where, f"num_parts {n!r} must be >= 1 and the length of parts")
    for j, p in enumerate(parts):
        if not (isinstance(p, dict) and re.fullmatch(r"part-[0-9]{5,}\.wmtok", str(p.get("file")))
                and all(is_int(p.get(k)) for k in TOKEN_PART_KEYS)
                and re.fullmatch(r"[0-9a-f]{64}", str(p.get("sha256")))
                and isinstance(p.get("sections"), dict)):
            fail(where, f"parts[{j}]: expected {{file: part-NNNNN.wmtok, bytes, sha256 (64 "
                 "lowercase hex), num_episodes, num_frames, sections}")
    episodes = idx.get("episodes")
    if not isinstance(episodes, list):
        fail(where, "episodes must be a list")
    for k, e in enumerate(episodes):
        if not (isinstance(e, dict) and all(is_int(e.get(key)) if typ is int else
                                            isinstance(e.get(key), typ)
                                            for key, typ in TOKEN_EPISODE_TYPES.items())
                and (e.get("episode_seed", "missing") is None or is_int(e.get("episode_seed"),
                                                                        -2**63))):
            fail(where, f"episodes[{k}]: expected {sorted(TOKEN_EPISODE_TYPES)} (non-negative "
                 "integers and strings) and episode_seed (integer or null)")
        if not (e["part"] < n and e["num_frames"] >= 1
                and e["frame_offset"] + e["num_frames"] <= parts[e["part"]]["num_frames"]):
            fail(where, f"episodes[{k}]: part {e['part']}, frames [{e['frame_offset']}, "
                 f"+{e['num_frames']}) lie outside the parts (num_frames >= 1 required)")
    frames = sum(e["num_frames"] for e in episodes)
    if (idx.get("num_episodes"), idx.get("num_frames")) != (len(episodes), frames):
        fail(where, f"num_episodes {idx.get('num_episodes')!r} / num_frames "
             f"{idx.get('num_frames')!r}, the episodes hold {len(episodes)} / {frames}")


def token_action_dim(idx):
    """Values per action: index.json action_dim from version 2; version 1 means the canonical 7."""
    return idx.get("action_dim") if idx["format_version"] >= 2 else 7


def token_frame_shape(tok):
    """A frame's tokens: [grid_h, grid_w], or [levels, grid_h, grid_w] for a residual tokenizer."""
    return ([tok["levels"]] if "levels" in tok else []) + tok["grid"]


class TokenPart:
    """One memory-mapped part file. Opening checks its size against index.json, the header, and
    every section's place, shape, dtype and CRC32C; arrays are views into the mapping."""

    def __init__(self, directory, entry, token_dtype, frame_shape, action_dim):
        self.path, self.entry = os.path.join(directory, entry["file"]), entry
        F = entry["num_frames"]
        self.expected = {"tokens": (TOKEN_DTYPES[token_dtype], [F] + frame_shape),
                         **{name: (dt, [F] + ([action_dim] if tail is None else tail))
                            for name, (dt, tail) in STEP_SECTIONS.items()}}
        self.size = size = os.path.getsize(self.path) if os.path.isfile(self.path) else None
        if size is None:
            fail(self.path, "part file is missing")
        if size != entry["bytes"]:
            past = [name for name, s in entry["sections"].items() if not isinstance(s, dict)
                    or not is_int(s.get("offset")) or s["offset"] + self.nbytes(name) > size]
            fail(self.path, f"file is {size} bytes, index.json says {entry['bytes']} (truncated "
                 f"or modified)" + (f"; sections past the end: {', '.join(map(repr, past))}"
                                   if past else ""))
        if size < TOKEN_HEADER.size:
            fail(f"{self.path}: header", f"truncated: file is {size} bytes, the header is 64")
        self.raw = np.memmap(self.path, dtype="u1", mode="r")
        self._check_header(token_dtype, frame_shape)
        self.arrays = {name: self._section(name) for name in self.expected}

    def nbytes(self, name):
        dtype, shape = self.expected.get(name, ("|u1", [0]))
        return int(np.prod(shape, dtype=object)) * np.dtype(dtype).itemsize

    def _check_header(self, token_dtype, frame_shape):
        where = f"{self.path}: header"  # version before CRC: a v2 file says "unknown version"
        magic, version, width, h, w, levels, _, stored = TOKEN_HEADER.unpack_from(self.raw, 0)
        if magic != TOKEN_MAGIC:
            fail(where, f"bad magic {magic!r}, expected {TOKEN_MAGIC!r} (not a wmkit token part?)")
        if version != VERSION:
            fail(where, f"unknown format version {version}, this reader supports {VERSION}")
        check_crc(where, stored, self.raw[0:60])
        levels, grid = max(levels, 1), frame_shape[-2:]
        want_levels = frame_shape[0] if len(frame_shape) == 3 else 1
        if [width, h, w, levels] != [np.dtype(TOKEN_DTYPES[token_dtype]).itemsize, *grid,
                                     want_levels]:
            fail(where, f"token bytes {width}, grid {h}x{w}, levels {levels}; index.json says "
                 f"token_dtype {token_dtype}, grid {grid[0]}x{grid[1]}, levels {want_levels}")

    def _section(self, name):
        """The section as an ndarray view, after its place, shape, dtype and CRC32C are checked."""
        where, s = f"{self.path}: section {name!r}", self.entry["sections"].get(name)
        dtype, shape = self.expected[name]
        if not isinstance(s, dict):
            fail(where, "missing from index.json")
        if s.get("dtype") != dtype or s.get("shape") != shape:
            fail(where, f"dtype {s.get('dtype')!r}, shape {s.get('shape')!r}; expected {dtype!r}, "
                 f"{shape} (F = the part's num_frames)")
        off, n = s.get("offset"), self.nbytes(name)
        if not (is_int(off, TOKEN_HEADER.size) and off % TOKEN_ALIGN == 0 and off + n <= self.size
                and is_int(s.get("crc32c")) and s["crc32c"] < 2**32):
            fail(where, f"offset {off!r} + {n} bytes: expected a multiple of 64 >= 64 inside the "
                 f"{self.size}-byte file, and a u32 crc32c")
        check_crc(where, s["crc32c"], self.raw[off:off + n])
        return self.raw[off:off + n].view(dtype).reshape(shape)

    def check_layout(self):
        """Sections do not overlap, every other byte after the header is zero padding, and the
        file's sha256 is what index.json says: every byte is accounted for."""
        extra = sorted(set(self.entry["sections"]) - set(self.expected))
        if extra:
            fail(self.path, f"unknown sections {extra} in index.json")
        spans = sorted((self.entry["sections"][name]["offset"], self.nbytes(name), name)
                       for name in self.expected if self.nbytes(name))
        end = TOKEN_HEADER.size
        for off, n, name in spans + [(self.size, 0, None)]:
            if off < end:
                fail(f"{self.path}: section {name!r}", f"bytes [{off}, {off + n}) overlap the "
                     "header or another section")
            stray = np.flatnonzero(self.raw[end:off])
            if stray.size:
                at = end + int(stray[0])
                fail(f"{self.path}: padding", f"byte at offset {at} is 0x{int(self.raw[at]):02x}, "
                     "expected 0 (bytes outside the header and the sections are zero)")
            end = off + n
        sha = hashlib.sha256(self.raw).hexdigest()
        if sha != self.entry["sha256"]:
            fail(self.path, f"sha256 {sha}, index.json says {self.entry['sha256']}")


class TokenDataset:
    """A token dataset directory: index.json (checked on open) plus lazily opened parts."""

    def __init__(self, directory):
        self.dir, self._parts = directory, {}
        where = self.index_path = os.path.join(directory, "index.json")
        try:
            with open(where, "rb") as f:
                self.index = json.loads(f.read().decode("utf-8"))
        except OSError as e:
            fail(where, f"cannot read ({e.strerror}): not a wmkit token dataset (an unfinished "
                 "or sharded wm-tokenize encode? index.json appears once every part is written)")
        except ValueError as e:
            fail(where, f"not UTF-8 JSON: {e}")
        check_token_index(self.index, where)
        self.num_episodes = len(self.index["episodes"])

    def part(self, j):
        if j not in self._parts:
            idx = self.index
            self._parts[j] = TokenPart(self.dir, idx["parts"][j], idx["token_dtype"],
                                       token_frame_shape(idx["tokenizer"]), token_action_dim(idx))
        return self._parts[j]

    def episode(self, k):
        """Episode k: metadata from index.json and every per-step array, as a JSON-ready dict."""
        if not 0 <= k < self.num_episodes:
            fail(self.index_path, f"episode {k} out of range: dataset has {self.num_episodes} "
                 "episodes")
        e = self.index["episodes"][k]
        arrays, a = self.part(e["part"]).arrays, e["frame_offset"]
        frames = {name: arr[a:a + e["num_frames"]].tolist() for name, arr in arrays.items()}
        return {"episode_index": k, "file": self.index["parts"][e["part"]]["file"],
                **{key: e[key] for key in (*TOKEN_EPISODE_TYPES, "episode_seed")}, **frames}


def verify_tokens(ds):
    """Check everything docs/token-format.md specifies; return the episode count."""
    idx, where = ds.index, ds.index_path
    for j, entry in enumerate(idx["parts"]):
        part = ds.part(j)
        part.check_layout()
        eps = [e for e in idx["episodes"] if e["part"] == j]
        offsets = [sum(e["num_frames"] for e in eps[:i]) for i in range(len(eps) + 1)]
        if [e["frame_offset"] for e in eps] != offsets[:-1] or offsets[-1] != entry["num_frames"] \
                or len(eps) != entry["num_episodes"]:
            fail(where, f"parts[{j}]: its {len(eps)} episodes must tile frames [0, "
                 f"{entry['num_frames']}) in order and number num_episodes "
                 f"{entry['num_episodes']}")
        tokens = part.arrays["tokens"]
        if tokens.size and int(tokens.max()) >= idx["tokenizer"]["num_codes"]:
            fail(f"{part.path}: section 'tokens'", f"token id {int(tokens.max())} >= num_codes "
                 f"{idx['tokenizer']['num_codes']}")
        check_part_json(ds, j)
    order = [(e["part"], e["source_episode"]) for e in idx["episodes"]]
    if order != sorted(order) or len({s for _, s in order}) != len(order):
        fail(where, "episodes must be in source order: parts ascending, source_episode strictly "
             "increasing")
    return ds.num_episodes


def check_part_json(ds, j):
    """part-NNNNN.json, when still present, must be what index.json was assembled from."""
    path = os.path.join(ds.dir, f"part-{j:05d}.json")
    if not os.path.isfile(path):
        return
    try:
        with open(path, "rb") as f:
            pj = json.loads(f.read().decode("utf-8"))
    except ValueError as e:
        fail(path, f"not UTF-8 JSON: {e}")
    idx = ds.index
    want = {"part_index": j, "num_parts": idx["num_parts"],
            "tokenizer_sha256": idx["tokenizer"].get("checkpoint_sha256"),
            "part": idx["parts"][j], "episodes": [e for e in idx["episodes"] if e["part"] == j]}
    bad = [key for key in want if not isinstance(pj, dict) or pj.get(key) != want[key]]
    if bad:
        fail(path, f"disagrees with index.json in {bad} (a stale part from another run?)")


def main(argv=None):
    """CLI entry point; maps every data error to one stderr line and exit status 1."""
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `wmshard.py ... | head` ends quietly
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dir", nargs="?", help="shard dataset directory (holds index.json)")
    p.add_argument("--tokens", metavar="DIR", help="a token dataset directory instead "
                   "(docs/token-format.md; wm-tokenize encode writes it)")
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--info", action="store_true", help="print index.json")
    mode.add_argument("--episode", type=int, metavar="K", help="print global episode K (0-based)")
    mode.add_argument("--all", action="store_true", help="print a list of every episode")
    mode.add_argument("--verify", action="store_true", help="check the whole dataset")
    p.add_argument("--json", action="store_true", help="JSON output (the only format)")
    args = p.parse_args(argv)
    if (args.dir is None) == (args.tokens is None):
        p.error("give either a shard dataset DIR or --tokens DIR")
    try:
        if args.tokens is not None:
            ds, check = TokenDataset(args.tokens), verify_tokens
            episode = ds.episode
        else:
            ds, check = Dataset(args.dir), verify
            episode = lambda k: ds.episode(k)[0]  # noqa: E731
        if args.verify:
            print(f"OK {check(ds)} episodes")
            return 0
        out = ds.index if args.info else [episode(k) for k in range(ds.num_episodes)] \
            if args.all else episode(args.episode)
    except ShardError as e:
        print(f"wmshard: error: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # a reader bug or an unforeseen corruption: still no traceback
        print(f"wmshard: error: {args.tokens or args.dir}: unexpected {type(e).__name__}: {e}",
              file=sys.stderr)
        return 1
    print(json.dumps(out, indent=2 if args.info else None))
    return 0


if __name__ == "__main__":
    sys.exit(main())
