#!/usr/bin/python3
"""Cross-check of `scripts/wmshard.py --tokens` (written from docs/token-format.md alone) against
the C++ token writer and reader (core/tokens/), and of the token JSON schemas.

token_dataset_tool ($WM_BIN_DIR, built from tests/core/token_dataset_tool.cc) writes a dataset
with test::MakeTokenDataset and prints what it wrote and what wm::tokens::TokenDataset reads
back; wmshard.py must return exactly the same tokens, arrays and metadata, the schemas must
accept every index.json and part-NNNNN.json, and corruption must give exit status 1 with one
message naming the file and the section (never a traceback).

Run: WM_BIN_DIR=build/bin /usr/bin/python3 tests/python/test_wmshard_tokens.py
"""
import contextlib
import importlib.util
import io
import json
import os
import shutil
import subprocess
import tempfile
import unittest
from pathlib import Path

import jsonschema
import numpy as np

ROOT = Path(os.environ.get("WM_SOURCE_DIR", Path(__file__).resolve().parents[2]))
WMSHARD = ROOT / "scripts" / "wmshard.py"
SCHEMAS = ROOT / "schemas"
TOOL = Path(os.environ.get("WM_BIN_DIR", ROOT / "build" / "bin")) / "token_dataset_tool"
STEP_KEYS = ("actions", "rewards", "discounts", "is_first", "is_last", "is_terminal")
META_KEYS = ("part", "frame_offset", "num_frames", "source_episode", "episode_key", "policy_id",
             "language_instruction", "episode_seed")
# (episodes, parts, grid_h, grid_w, num_codes, seed, expected token_dtype[, action_dim[, levels]])
CONFIGS = [(4, 1, 2, 3, 1024, 5, "uint16"),
           (7, 3, 3, 2, 65536, 11, "uint16"),   # the largest codebook that fits uint16
           (5, 3, 2, 2, 100000, 3, "uint32"),   # codes > 65536: 4-byte tokens
           (2, 3, 1, 4, 70000, 9, "uint32"),    # more parts than episodes: part 0 is empty
           (3, 2, 2, 2, 16, 13, "uint16", 26),  # joint actions of 26 values: index version 2
           (4, 2, 2, 3, 1024, 17, "uint16", 7, 4)]  # 4 residual levels a cell: index version 3


def run(*args):
    return subprocess.run(["/usr/bin/python3", str(WMSHARD), *map(str, args)],
                          capture_output=True, text=True, timeout=120)


def write_dataset(directory, config):
    """Runs the C++ writer; returns its JSON report (what it wrote and what C++ read back)."""
    episodes, parts, gh, gw, codes, seed = config[:6]
    args = [TOOL, directory, episodes, parts, gh, gw, codes, seed, *config[7:]]
    r = subprocess.run(list(map(str, args)), capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        raise AssertionError(f"{TOOL} failed ({r.returncode}): {r.stderr}")
    return json.loads(r.stdout)


def load_wmshard():
    spec = importlib.util.spec_from_file_location("wmshard", WMSHARD)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class TokenCrossCheck(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if not TOOL.is_file():
            raise AssertionError(f"{TOOL} is not built (cmake --build BUILD_DIR --target "
                                 "token_dataset_tool): the cross-check cannot run")

    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="wmtok-")
        self.addCleanup(shutil.rmtree, self.tmp)

    def dataset(self, config, name="tokens"):
        directory = Path(self.tmp) / name
        return directory, write_dataset(directory, config)

    def assertFails(self, args, *needles):
        """Exit 1, no traceback, nothing on stdout, every needle (case-insensitive) in stderr."""
        r = run(*args)
        self.assertEqual(r.returncode, 1, f"{args}: expected failure, got {r.stdout[:300]!r}")
        self.assertNotIn("Traceback", r.stderr)
        self.assertNotIn("unexpected", r.stderr)
        self.assertEqual(r.stdout, "")
        for needle in needles:
            self.assertIn(needle.lower(), r.stderr.lower(), f"{args}: {needle!r} not in {r.stderr}")
        return r.stderr

    def test_reads_exactly_what_cpp_wrote(self):
        for config in CONFIGS:
            with self.subTest(config=config):
                d, wrote = self.dataset(config, f"c{config[5]}")
                self.assertEqual(wrote["token_dtype"], config[6])
                index = json.loads((d / "index.json").read_text())
                r = run("--tokens", d, "--info")
                self.assertEqual(r.returncode, 0, r.stderr)
                self.assertEqual(json.loads(r.stdout), index)
                r = run("--tokens", d, "--all", "--json")
                self.assertEqual(r.returncode, 0, r.stderr)
                everything = json.loads(r.stdout)
                self.assertEqual(len(everything), config[0])
                for k, want in enumerate(wrote["episodes"]):
                    r = run("--tokens", d, "--episode", k, "--json")
                    self.assertEqual(r.returncode, 0, r.stderr)
                    ep = json.loads(r.stdout)
                    self.assertEqual(ep, everything[k])
                    self.assertEqual(ep["episode_index"], k)
                    self.assertEqual(ep["tokens"], want["tokens"], f"episode {k} tokens")
                    self.assertEqual(want["tokens_read"], want["tokens"], "C++ CopyTokens")
                    levels = (config[8],) if len(config) > 8 else ()
                    self.assertEqual(np.array(ep["tokens"]).shape,
                                     (want["num_frames"], *levels, config[2], config[3]))
                    for key in STEP_KEYS + META_KEYS:
                        self.assertEqual(ep[key], want[key], f"episode {k} {key}")
                    self.assertEqual(ep["file"], f"part-{want['part']:05d}.wmtok")
                    self.assertEqual(index["episodes"][k], {key: want[key] for key in META_KEYS})
                tokens = np.concatenate([np.array(e["tokens"]).ravel() for e in everything])
                if config[6] == "uint32":  # the wide path really carries ids above 65535
                    self.assertGreater(int(tokens.max()), 65535)
                r = run("--tokens", d, "--verify")
                self.assertEqual((r.returncode, r.stdout.strip(), r.stderr),
                                 (0, f"OK {config[0]} episodes", ""))

    def test_memmap_example_of_the_doc(self):
        """The numpy snippet of docs/token-format.md, verbatim in spirit, reads the tokens."""
        d, wrote = self.dataset(CONFIGS[2])
        index = json.loads((d / "index.json").read_text())
        dtype = {"uint16": "<u2", "uint32": "<u4"}[index["token_dtype"]]
        for k, e in enumerate(index["episodes"]):
            part = index["parts"][e["part"]]
            sec = part["sections"]["tokens"]
            tokens = np.memmap(d / part["file"], dtype=dtype, mode="r", offset=sec["offset"],
                               shape=tuple(sec["shape"]))
            a = e["frame_offset"]
            self.assertEqual(tokens[a:a + e["num_frames"]].tolist(), wrote["episodes"][k]["tokens"])
            sec = part["sections"]["actions"]
            actions = np.memmap(d / part["file"], dtype="<f4", mode="r", offset=sec["offset"],
                                shape=tuple(sec["shape"]))
            self.assertEqual(actions[a:a + e["num_frames"]].tolist(),
                             wrote["episodes"][k]["actions"])

    def test_schemas(self):
        index_schema = json.loads((SCHEMAS / "token-index.schema.json").read_text())
        part_schema = json.loads((SCHEMAS / "token-part.schema.json").read_text())
        for schema in (index_schema, part_schema):
            jsonschema.Draft202012Validator.check_schema(schema)
        for name, definition in part_schema["$defs"].items():  # repeated verbatim: no drift
            self.assertEqual(definition, index_schema["$defs"][name], name)
        index_v = jsonschema.Draft202012Validator(index_schema)
        part_v = jsonschema.Draft202012Validator(part_schema)
        for config in CONFIGS:
            d, _ = self.dataset(config, f"c{config[5]}")
            index = json.loads((d / "index.json").read_text())
            index_v.validate(index)
            for j in range(config[1]):
                part_v.validate(json.loads((d / f"part-{j:05d}.json").read_text()))
        index = json.loads((Path(self.tmp) / "c11" / "index.json").read_text())  # 3 parts, uint16
        part_json = json.loads((Path(self.tmp) / "c11" / "part-00001.json").read_text())
        self.assertTrue(index_v.is_valid(index))

        def mutated(fn, doc=index):
            doc = json.loads(json.dumps(doc))
            fn(doc)
            return doc

        p0 = lambda x: x["parts"][0]  # noqa: E731
        bad_index = {
            "format_version 3": lambda x: x.update(format_version=3),
            "version 2 without action_dim": lambda x: x.update(format_version=2,
                                                               action_space="other"),
            "version 1 with action_dim": lambda x: x.update(action_dim=7),
            "unknown key": lambda x: x.update(future_key=1),
            "token_dtype for 65536 codes": lambda x: x.update(token_dtype="uint32"),
            "uint16 for 65537 codes": lambda x: x["tokenizer"].update(num_codes=65537),
            "tokens dtype vs token_dtype": lambda x: p0(x)["sections"]["tokens"].update(
                dtype="<u4"),
            "missing section": lambda x: p0(x)["sections"].pop("is_last"),
            "extra section": lambda x: p0(x)["sections"].update(depth=p0(x)["sections"]["rewards"]),
            "unaligned offset": lambda x: p0(x)["sections"]["rewards"].update(offset=100),
            "tokens not at 64": lambda x: p0(x)["sections"]["tokens"].update(offset=128),
            "actions not [F, 7]": lambda x: p0(x)["sections"]["actions"].update(shape=[3, 6]),
            "crc32c > u32": lambda x: p0(x)["sections"]["rewards"].update(crc32c=2**32),
            "part file name": lambda x: p0(x).update(file="a.wmtok"),
            "sha256": lambda x: p0(x).update(sha256="XYZ"),
            "grid": lambda x: x["tokenizer"].update(grid=[2]),
            "episode_seed": lambda x: x["episodes"][0].update(episode_seed="7"),
            "episode extra key": lambda x: x["episodes"][0].update(shard=0),
            "zero-frame episode": lambda x: x["episodes"][0].update(num_frames=0),
            "action_stats": lambda x: x["action_stats"].update(q99=[0.0] * 6),
            "no provenance": lambda x: x.pop("provenance"),
        }
        for what, fn in bad_index.items():
            self.assertFalse(index_v.is_valid(mutated(fn)), what)
        wide = json.loads((Path(self.tmp) / "c13" / "index.json").read_text())  # 26-dim, v2
        self.assertEqual((wide["format_version"], wide["action_dim"], wide["action_space"]),
                         (2, 26, "joint_position"))
        for what, fn in {"action_space": lambda x: x.update(action_space="cartesian"),
                         "no action_dim": lambda x: x.pop("action_dim"),
                         "version 1": lambda x: x.update(format_version=1)}.items():
            self.assertFalse(index_v.is_valid(mutated(fn, wide)), "v2 " + what)
        stacked = json.loads((Path(self.tmp) / "c17" / "index.json").read_text())  # 4 levels, v3
        self.assertEqual((stacked["format_version"], stacked["tokenizer"]["levels"]), (3, 4))
        tokens0 = lambda x: x["parts"][0]["sections"]["tokens"]  # noqa: E731
        for what, fn in {"no levels": lambda x: x["tokenizer"].pop("levels"),
                         "one level": lambda x: x["tokenizer"].update(levels=1),
                         "version 2": lambda x: x.update(format_version=2),
                         "3-d tokens": lambda x: tokens0(x).update(shape=tokens0(x)["shape"][:1]
                                                                  + tokens0(x)["shape"][2:]),
                         "no action_dim": lambda x: x.pop("action_dim")}.items():
            self.assertFalse(index_v.is_valid(mutated(fn, stacked)), "v3 " + what)
        for what, fn in {"levels in version 1": lambda x: x["tokenizer"].update(levels=2),
                         "4-d tokens in version 1": lambda x: p0(x)["sections"]["tokens"].update(
                             shape=[p0(x)["num_frames"], 1, 3, 2])}.items():
            self.assertFalse(index_v.is_valid(mutated(fn)), what)
        self.assertTrue(part_v.is_valid(part_json))
        bad_part = {"no tokenizer_sha256": lambda x: x.pop("tokenizer_sha256"),
                    "extra key": lambda x: x.update(index=0),
                    "bad section": lambda x: x["part"]["sections"]["tokens"].update(dtype="<f4"),
                    "num_parts 0": lambda x: x.update(num_parts=0)}
        for what, fn in bad_part.items():
            self.assertFalse(part_v.is_valid(mutated(fn, part_json)), what)

    def test_levels_must_match_the_part_header(self):
        d, _ = self.dataset(CONFIGS[5])  # 4 levels a cell
        index = json.loads((d / "index.json").read_text())
        index["tokenizer"]["levels"] = 2
        for part in index["parts"]:
            part["sections"]["tokens"]["shape"][1] = 2
        (d / "index.json").write_text(json.dumps(index))
        self.assertFails(["--tokens", d, "--episode", 0], "part-00000.wmtok: header",
                         "levels 4", "levels 2")

    def test_corrupt_section_is_named(self):
        d, _ = self.dataset(CONFIGS[1])  # 3 parts; part 1 holds episodes 2 and 3
        index = json.loads((d / "index.json").read_text())
        path = d / "part-00001.wmtok"
        good = path.read_bytes()
        sections = index["parts"][1]["sections"]
        for name in ("tokens", "actions", "rewards", "is_terminal"):
            with self.subTest(section=name):
                data = bytearray(good)
                data[sections[name]["offset"] + 1] ^= 0x40
                path.write_bytes(bytes(data))
                for args in (["--verify"], ["--episode", 2, "--json"]):
                    self.assertFails(["--tokens", d, *args], "part-00001.wmtok",
                                     f"section '{name}'", "CRC32C mismatch")
                r = run("--tokens", d, "--episode", 0, "--json")  # part 0 is never opened
                self.assertEqual(r.returncode, 0, r.stderr)
        for offset, needles in ((0, ["header", "magic"]), (17, ["header", "CRC32C mismatch"]),
                                (62, ["header", "CRC32C mismatch"])):
            data = bytearray(good)
            data[offset] ^= 0x01
            path.write_bytes(bytes(data))
            self.assertFails(["--tokens", d, "--verify"], "part-00001.wmtok", *needles)
        data = bytearray(good)  # padding is outside every CRC: --verify still catches it
        data[sections["actions"]["offset"] - 1] = 0x55
        path.write_bytes(bytes(data))
        self.assertFails(["--tokens", d, "--verify"], "part-00001.wmtok", "padding",
                         "expected 0")

    def test_truncated_part_is_named(self):
        d, _ = self.dataset(CONFIGS[2])
        path = d / "part-00002.wmtok"
        good = path.read_bytes()
        path.write_bytes(good[:-1])
        for args in (["--verify"], ["--episode", 4, "--json"]):
            self.assertFails(["--tokens", d, *args], "part-00002.wmtok", f"{len(good) - 1} bytes",
                             f"index.json says {len(good)}", "truncated", "'is_terminal'")
        path.write_bytes(good[:100])
        self.assertFails(["--tokens", d, "--verify"], "part-00002.wmtok", "truncated",
                         "'tokens'", "'actions'")
        path.write_bytes(good[:10])
        self.assertFails(["--tokens", d, "--verify"], "part-00002.wmtok", "truncated")
        path.unlink()
        self.assertFails(["--tokens", d, "--verify"], "part-00002.wmtok", "missing")

    def test_every_byte_and_every_truncation(self):
        """Every byte of a part is covered by the header CRC, a section CRC or the zero-padding
        rule, so any flipped byte and any truncation is a clean error naming the file."""
        d, _ = self.dataset((3, 1, 2, 2, 100000, 4, "uint32"))
        wmshard = load_wmshard()
        path = d / "part-00000.wmtok"
        good = path.read_bytes()
        cases = [good[:i] + bytes([good[i] ^ 0x40]) + good[i + 1:] for i in range(len(good))]
        cases += [good[:n] for n in range(0, len(good), 5)]
        for data in cases:
            path.write_bytes(data)
            err = io.StringIO()
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                rc = wmshard.main(["--tokens", str(d), "--verify"])
            self.assertEqual(rc, 1, f"corruption not detected ({len(data)} bytes)")
            self.assertIn("part-00000.wmtok", err.getvalue())
            self.assertNotIn("unexpected", err.getvalue())

    def test_index_problems(self):
        d, _ = self.dataset(CONFIGS[1])
        index_path = d / "index.json"
        index = json.loads(index_path.read_text())

        def write(fn):
            doc = json.loads(json.dumps(index))
            fn(doc)
            index_path.write_text(json.dumps(doc))

        write(lambda x: x.update(format_version=4))
        for args in (["--verify"], ["--info"], ["--episode", 0]):
            self.assertFails(["--tokens", d, *args], "index.json", "format_version 4",
                             "supports 1, 2, 3")
        write(lambda x: x.update(format_version=3, action_dim=7, action_space="eef_delta"))
        self.assertFails(["--tokens", d, "--info"], "index.json", "tokenizer.levels in [2, 8]",
                         "got None")
        write(lambda x: x["tokenizer"].update(levels=2))  # in a version-1 index
        self.assertFails(["--tokens", d, "--info"], "index.json",
                         "levels is only written by format_version 3")
        write(lambda x: x.update(format_version=2))  # version 2 must say its action
        self.assertFails(["--tokens", d, "--info"], "index.json", "action_dim None")
        write(lambda x: x.update(format_version=2, action_dim=6, action_space="other"))
        self.assertFails(["--tokens", d, "--info"], "index.json", "action_stats", "6 values")
        write(lambda x: x.update(format_version=2, action_dim=7, action_space="cartesian"))
        self.assertFails(["--tokens", d, "--info"], "index.json", "action_space 'cartesian'")
        write(lambda x: x.update(num_frames=x["num_frames"] + 1))
        self.assertFails(["--tokens", d, "--info"], "index.json", "num_frames")
        write(lambda x: x["episodes"][1].update(num_frames=x["episodes"][1]["num_frames"] + 99,
                                                frame_offset=0) or x.update(
            num_frames=x["num_frames"] + 99))
        self.assertFails(["--tokens", d, "--episode", 0], "index.json", "episodes[1]", "outside")
        write(lambda x: x["parts"][0].update(sha256="0" * 64))
        self.assertFails(["--tokens", d, "--verify"], "part-00000.wmtok", "sha256")
        write(lambda x: x["parts"][0]["sections"]["tokens"].update(dtype="<u4"))
        self.assertFails(["--tokens", d, "--verify"], "part-00000.wmtok", "section 'tokens'",
                         "dtype")
        sections = index["parts"][0]["sections"]  # MakeTokenDataset: is_terminal == is_last
        self.assertEqual(sections["is_terminal"]["crc32c"], sections["is_last"]["crc32c"])
        write(lambda x: x["parts"][0]["sections"]["is_terminal"].update(
            offset=sections["is_last"]["offset"]))  # every CRC still matches
        self.assertFails(["--tokens", d, "--verify"], "part-00000.wmtok", "section 'is_terminal'",
                         "overlap")
        index_path.write_text(json.dumps(index))
        self.assertFails(["--tokens", d, "--episode", 7], "episode 7", "out of range")
        part_json = d / "part-00002.json"  # a part of another run left beside the index
        part_json.write_text(json.dumps(dict(json.loads(part_json.read_text()),
                                             tokenizer_sha256="other")))
        self.assertFails(["--tokens", d, "--verify"], "part-00002.json", "tokenizer_sha256",
                         "stale")
        index_path.unlink()
        self.assertFails(["--tokens", d, "--info"], "index.json", "unfinished")

    def test_cli_usage(self):
        d, _ = self.dataset(CONFIGS[0])
        r = run(d, "--tokens", d, "--info")  # a shard DIR and --tokens DIR: one or the other
        self.assertEqual(r.returncode, 2)
        self.assertIn("--tokens", r.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
