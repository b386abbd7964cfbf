#!/usr/bin/python3
"""The config schemas (schemas/{tokenizer,dynamics,motion,success,segmentation}-config, mixture)
and the schemas of the tokenizer and motion runs' checkpoint.json and of `wm-metrics` frame
comparison, against what the C++ reads and writes (a success run's checkpoint.json:
tests/evaluate/test_wm_eval_policy_motion.py):

- every file in configs/{tokenizer,dynamics,motion,success,mixtures,segmentation} validates (after
  YAML -> JSON), and the keys of each schema are those of its doc's field table;
- each schema rejects unknown keys, wrong types and out-of-range values, and the C++ loader
  rejects the very same files (exit 1, naming the file and the key);
- `wm-tokenize train --steps 2` and `wm-train --steps 1` record the loaders' defaults in
  checkpoint.json exactly as the schemas' "default"s say; the tokenizer's checkpoint.json validates
  (hashes and shard list checked too) and mutated copies do not, and so does a fine-tune's
  (`--init-from --freeze encoder`: init_from records the parent, config_hash includes it);
- `wm-motion train --steps 1` likewise: the loader's defaults are the schema's, checkpoint.json
  validates (hashes, shard list, action statistics and the archive's meta checked too) and
  mutated copies do not;
- `wm-metrics` JSON validates for lpips_style + fvd_style with --per-frame (null per-frame
  fvd_style), for identical frames (PSNR "inf") and for the default metrics.
Needs the built tools (WM_BIN_DIR); about 20 s on 2 cores."""
import copy
import glob
import hashlib
import json
import os
import re
import shutil
import struct
import subprocess
import tempfile
import unittest

import cv2
import jsonschema
import numpy as np
import yaml

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))

# config family -> (configs/ folder, schema, doc, heading of the doc's field table)
FAMILIES = {
    "tokenizer": ("tokenizer", "tokenizer-config", "tokenizer.md", "## Config"),
    "dynamics": ("dynamics", "dynamics-config", "dynamics.md", "## Config keys"),
    "motion": ("motion", "motion-config", "motion.md", "## Config"),
    "success": ("success", "success-config", "success.md", "## Config"),
    "mixture": ("mixtures", "mixture", None, None),
    "segmentation": ("segmentation", "segmentation-config", "metrics-segmentation.md", "## Config"),
}


class YamlLoader(yaml.SafeLoader):
    """PyYAML's YAML 1.1 floats need a dot (3e-4 would be a string); yaml-cpp reads 3e-4 as a
    number, so the 1.2 form is added here."""


YamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)[eE][-+]?[0-9]+$"),
    list("-+.0123456789"))


def to_json(doc):
    """The document as a JSON file holds it: integer mapping keys (segmentation labels) -> strings."""
    return json.loads(json.dumps(doc))


def load_yaml(path):
    with open(path, encoding="utf-8") as f:
        return to_json(yaml.load(f, Loader=YamlLoader))


def schema(name):
    with open(os.path.join(SRC, "schemas", name + ".schema.json"), encoding="utf-8") as f:
        return json.load(f)


def validator(name):
    return jsonschema.Draft202012Validator(schema(name))


def tool(name, *args):
    return subprocess.run([os.path.join(BIN, name), *map(str, args)], capture_output=True,
                          text=True, timeout=300)


def sha256_file(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def schema_defaults(s):
    """{section: {key: default}} of a sectioned config schema."""
    return {sec: {k: v["default"] for k, v in body["properties"].items()}
            for sec, body in s["properties"].items()}


def expected_config(name, overrides, steps):
    """The config a run trained with `overrides` and --steps `steps` records: the schema's
    defaults but for those."""
    expected = schema_defaults(schema(name))
    for sec, values in overrides.items():
        expected[sec].update(values)
    expected["train"]["steps"] = steps
    return expected


FIX = {}  # built once by setUpModule: shard dataset, tokenizer and motion runs, frame folders


def train_run(command, name, overrides, steps):
    """Trains FIX["tmp"]/name on the fixture's shards with the config `overrides` (written to
    name.yaml) for `steps` steps; returns the run directory."""
    config, run = (os.path.join(FIX["tmp"], name + ext) for ext in (".yaml", ""))
    with open(config, "w", encoding="utf-8") as f:
        yaml.safe_dump(overrides, f)
    r = tool(*command, "--config", config, "--data", FIX["shards"], "--out", run, "--steps", steps,
             "--threads", 1)
    assert r.returncode == 0, r.stderr
    return run


def setUpModule():
    tmp = FIX["tmp"] = tempfile.mkdtemp(prefix="wm_config_schemas_")
    raw, shards = os.path.join(tmp, "raw"), FIX.setdefault("shards", os.path.join(tmp, "shards"))
    for args in (("wm-gen-tabletop", "--out", raw, "--size", 64, "--train-episodes", 2,
                  "--val-episodes", 1),
                 ("wm-ingest", "--format", "rlds", "--input",
                  os.path.join(raw, "wm_tabletop", "1.0.0"), "--split", "train", "--output",
                  shards, "--configs", os.path.join(SRC, "configs"))):
        r = tool(*args)
        assert r.returncode == 0, r.stderr
    # Only two keys set: every other key of checkpoint.json's config is the loader's default.
    FIX["tok_overrides"] = {"model": {"min_channels": 16}, "train": {"batch_size": 4}}
    FIX["tok"] = train_run(("wm-tokenize", "train"), "tok", FIX["tok_overrides"], 2)
    FIX["motion_overrides"] = {"model": {"channels": 8}, "train": {"batch_size": 4}}
    FIX["motion"] = train_run(("wm-motion", "train"), "motion", FIX["motion_overrides"], 1)
    rng = np.random.default_rng(7)
    for side in ("ref", "pred"):
        os.makedirs(os.path.join(tmp, side))
    for i in range(4):
        ref = rng.integers(0, 256, (32, 32, 3), dtype=np.uint8)
        pred = np.clip(ref.astype(int) + rng.integers(-20, 21, ref.shape), 0, 255).astype(np.uint8)
        cv2.imwrite(os.path.join(tmp, "ref", "%03d.png" % i), ref)
        cv2.imwrite(os.path.join(tmp, "pred", "%03d.png" % i), pred)


def tearDownModule():
    shutil.rmtree(FIX["tmp"], ignore_errors=True)


class ShippedConfigs(unittest.TestCase):
    def test_schemas_are_draft_2020_12(self):
        for name in ("tokenizer-config", "dynamics-config", "motion-config", "mixture",
                     "segmentation-config", "tokenizer-checkpoint", "motion-checkpoint",
                     "metrics-compare", "success-config", "success-checkpoint"):
            s = schema(name)
            self.assertEqual(s["$schema"], "https://json-schema.org/draft/2020-12/schema")
            self.assertTrue(s["$id"].endswith("/%s.schema.json" % name))
            jsonschema.Draft202012Validator.check_schema(s)

    def test_every_shipped_config_is_valid(self):
        for folder, name, _, _ in FAMILIES.values():
            files = sorted(glob.glob(os.path.join(SRC, "configs", folder, "*.yaml")))
            self.assertGreaterEqual(len(files), 1, folder)
            v = validator(name)
            for path in files:
                errors = [e.message for e in v.iter_errors(load_yaml(path))]
                self.assertEqual(errors, [], path)

    def test_doc_tables_list_exactly_the_schema_keys(self):
        for folder, name, doc, heading in FAMILIES.values():
            if doc is None:
                continue
            with open(os.path.join(SRC, "docs", doc), encoding="utf-8") as f:
                text = f.read()
            start = re.search(r"^%s\b" % re.escape(heading), text, re.M).start()
            end = text.find("\n## ", start + 1)
            documented = set()
            for line in text[start:end if end > 0 else None].splitlines():
                if line.startswith("| `"):
                    documented |= set(re.findall(r"`([a-z_][a-z0-9_.]*)`", line.split("|")[1]))
            keys = set()
            for k, v in schema(name)["properties"].items():
                keys |= {k + "." + kk for kk in v["properties"]} if "properties" in v else {k}
            self.assertEqual(documented, keys, doc)

    def test_checkpoint_config_rules_equal_the_config_schema(self):
        for family in ("tokenizer", "motion", "success"):
            cfg, ckpt = schema(family + "-config"), schema(family + "-checkpoint")
            self.assertEqual(set(ckpt["$defs"]["config"]["required"]), set(cfg["properties"]))
            for sec, body in cfg["properties"].items():
                self.assertEqual(ckpt["$defs"][sec]["properties"], body["properties"], sec)
                self.assertEqual(set(ckpt["$defs"][sec]["required"]), set(body["properties"]),
                                 sec)
            for d in ("int", "int64", "uint64"):
                self.assertEqual(ckpt["$defs"][d], cfg["$defs"][d])

    def test_empty_file_means_defaults(self):
        for name in ("tokenizer-config", "dynamics-config", "motion-config",
                     "segmentation-config", "success-config"):
            validator(name).validate(None)
        self.assertFalse(validator("mixture").is_valid(None))


def setting(path, value):
    """A mutation: sets doc[a][b]... = value (the last key is created)."""
    def apply(doc):
        node = doc
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
    return apply


# (family, base config, what, mutation, key the C++ error names)
MUTATIONS = [
    ("tokenizer", "tiny", "unknown key", setting(["model", "patch_sise"], 8), "model.patch_sise"),
    ("tokenizer", "tiny", "unknown section", setting(["optimizer"], {"lr": 1}), "optimizer"),
    ("tokenizer", "tiny", "section not a mapping", setting(["model"], None), "model"),
    ("tokenizer", "tiny", "wrong type", setting(["model", "num_codes"], "many"), "model.num_codes"),
    ("tokenizer", "tiny", "wrong type", setting(["model", "l2_normalize"], "sometimes"),
     "model.l2_normalize"),
    ("tokenizer", "tiny", "int overflow", setting(["train", "batch_size"], 2**31),
     "train.batch_size"),
    ("tokenizer", "tiny", "not a power of 2", setting(["model", "patch_size"], 6),
     "model.patch_size"),
    ("tokenizer", "tiny", "out of range", setting(["train", "beta1"], 1.0), "train.beta1"),
    ("tokenizer", "tiny", "out of range", setting(["data", "image_key"], ""), "data.image_key"),
    ("dynamics", "tiny", "unknown key", setting(["policy", "heads"], 2), "policy.heads"),
    ("dynamics", "tiny", "wrong type", setting(["train", "bf16"], "maybe"), "train.bf16"),
    ("dynamics", "tiny", "negative uint64", setting(["train", "seed"], -1), "train.seed"),
    ("dynamics", "tiny", "not an allowed value", setting(["model", "norm"], "batchnorm"),
     "model.norm"),
    ("dynamics", "tiny", "out of range", setting(["model", "context_frames"], 1),
     "model.context_frames"),
    ("dynamics", "tiny", "out of range (0 is allowed for the tokenizer)",
     setting(["train", "val_every"], 0), "train.val_every"),
    ("motion", "tiny", "unknown key", setting(["model", "chanels"], 8), "model.chanels"),
    ("motion", "tiny", "unknown section", setting(["optimizer"], {"lr": 1}), "optimizer"),
    ("motion", "tiny", "section not a mapping", setting(["train"], 5), "train"),
    ("motion", "tiny", "wrong type", setting(["model", "action_jacobian"], "yes please"),
     "model.action_jacobian"),
    ("motion", "tiny", "wrong type", setting(["train", "unroll"], 1.5), "train.unroll"),
    ("motion", "tiny", "int overflow", setting(["model", "channels"], 2**31), "model.channels"),
    ("motion", "tiny", "negative uint64", setting(["train", "seed"], -1), "train.seed"),
    ("motion", "tiny", "not a multiple of 8", setting(["model", "image_size"], 60),
     "model.image_size"),
    ("motion", "tiny", "out of range", setting(["model", "image_size"], 0), "model.image_size"),
    ("motion", "tiny", "out of range", setting(["model", "flow_scale"], 0.0), "model.flow_scale"),
    ("motion", "tiny", "out of range", setting(["train", "beta2"], 1.0), "train.beta2"),
    ("motion", "tiny", "out of range", setting(["train", "val_every"], -1), "train.val_every"),
    ("motion", "tiny", "out of range", setting(["train", "unroll"], 0), "train.unroll"),
    ("motion", "tiny", "out of range", setting(["train", "val_episodes"], 0),
     "train.val_episodes"),
    ("motion", "tiny", "out of range", setting(["train", "val_horizon"], 0), "train.val_horizon"),
    ("motion", "tiny", "out of range", setting(["data", "image_key"], ""), "data.image_key"),
    ("success", "tiny", "unknown key", setting(["train", "positive_fracton"], 0.5),
     "train.positive_fracton"),
    ("success", "tiny", "wrong type", setting(["data", "reward_threshold"], "half"),
     "data.reward_threshold"),
    ("success", "tiny", "out of range", setting(["train", "positive_fraction"], 1.0),
     "train.positive_fraction"),
    ("success", "tiny", "out of range", setting(["model", "image_size"], 60), "model.image_size"),
    ("mixture", "tabletop", "wrong type", setting(["datasets", 0, "weight"], "heavy"),
     "datasets[0]"),
    ("mixture", "tabletop", "missing weight", lambda d: d["datasets"][0].pop("weight"),
     "datasets[0]"),
    ("mixture", "tabletop", "not a list", setting(["datasets"], "wm_tabletop"), "datasets"),
    ("mixture", "tabletop", "empty list", setting(["datasets"], []), "datasets"),
    ("mixture", "tabletop", "out of range", setting(["datasets", 0, "weight"], 0),
     "datasets[0].weight"),
    ("mixture", "tabletop", "unknown key", setting(["notes"], "demo"), "notes"),
    ("mixture", "tabletop", "unknown entry key", setting(["datasets", 0, "comment"], "only one"),
     "datasets[0].comment"),
    ("mixture", "tabletop", "empty name", setting(["datasets", 0, "name"], ""),
     "datasets[0].name"),
    ("segmentation", "tabletop", "unknown key", setting(["colour"], "red"), "colour"),
    ("segmentation", "tabletop", "unknown key", setting(["motion", "treshold"], 0.1),
     "motion.treshold"),
    ("segmentation", "tabletop", "wrong type", setting(["motion", "open_radius"], "wide"),
     "motion.open_radius"),
    ("segmentation", "tabletop", "out of range", setting(["motion", "open_radius"], 51),
     "motion.open_radius"),
    ("segmentation", "tabletop", "out of range", setting(["depth", "plane_iterations"], 0),
     "depth.plane_iterations"),
    ("segmentation", "tabletop", "unknown region", setting(["labels", 1], "hand"), "labels.1"),
    ("segmentation", "tabletop", "unknown region", setting(["unlisted"], "arms"), "unlisted"),
    ("segmentation", "tabletop", "unknown border", setting(["arm_borders"], "top,up"),
     "arm_borders"),
    ("segmentation", "tabletop", "focal length not positive",
     setting(["depth", "intrinsics"], [0, 50, 32, 32]), "depth.intrinsics"),
]


class ConfigMutations(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(dir=FIX["tmp"])

    def write(self, doc, name="bad.yaml"):
        path = os.path.join(self.dir, name)
        with open(path, "w", encoding="utf-8") as f:
            yaml.safe_dump(doc, f)
        return path

    def cpp(self, family, path):
        """Runs the tool that reads `family` configs on `path`; the data arguments are real but
        are only reached when the config is accepted."""
        out = os.path.join(self.dir, "out")
        tiny = os.path.join(SRC, "configs", "tokenizer", "tiny.yaml")
        if family == "tokenizer":
            return tool("wm-tokenize", "train", "--config", path, "--data", FIX["shards"],
                        "--out", out, "--steps", 1, "--threads", 1)
        if family == "dynamics":  # the config is read before --tokens is opened
            return tool("wm-train", "--config", path, "--tokens", FIX["shards"], "--out", out,
                        "--steps", 1, "--threads", 1)
        if family == "motion":
            return tool("wm-motion", "train", "--config", path, "--data", FIX["shards"], "--out",
                        out, "--steps", 1, "--threads", 1)
        if family == "success":  # the config is read before --data is opened
            return tool("wm-success", "train", "--config", path, "--data", FIX["shards"],
                        "--out", out, "--steps", 1, "--threads", 1)
        if family == "mixture":
            return tool("wm-tokenize", "train", "--config", tiny, "--mixture", path, "--data",
                        FIX["shards"], "--out", out, "--steps", 1, "--threads", 1)
        return tool("wm-metrics", "seg", "--ref", os.path.join(FIX["tmp"], "ref"), "--pred",
                    os.path.join(FIX["tmp"], "pred"), "--masks", "motion", "--config", path)

    def test_schema_and_loader_reject_the_same_mutations(self):
        for family, base, what, mutate, key in MUTATIONS:
            folder, name = FAMILIES[family][:2]
            with self.subTest(family=family, what=what, key=key):
                with open(os.path.join(SRC, "configs", folder, base + ".yaml"),
                          encoding="utf-8") as f:
                    doc = yaml.load(f, Loader=YamlLoader)
                mutate(doc)
                self.assertFalse(validator(name).is_valid(to_json(doc)), "schema accepts it")
                path = self.write(doc)
                r = self.cpp(family, path)
                self.assertEqual(r.returncode, 1, r.stderr)
                self.assertIn("bad.yaml", r.stderr)
                self.assertIn("key '%s'" % key, r.stderr)

    def test_shipped_segmentation_config_is_accepted_by_the_loader(self):
        r = self.cpp("segmentation", os.path.join(SRC, "configs", "segmentation", "tabletop.yaml"))
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_segmentation_config_without_depth_section(self):
        """docs/metrics-segmentation.md: every key is optional, the depth section too (a
        default-constructed YAML::Node is defined, which once made its absence an error)."""
        doc = {"unlisted": "error", "motion": {"open_radius": 1}}
        validator("segmentation-config").validate(doc)
        r = self.cpp("segmentation", self.write(doc, "no_depth.yaml"))
        self.assertEqual(r.returncode, 0, r.stderr)


def check_run_manifest(test, m, run_dir, step):
    """The cross-field facts a checkpoint schema cannot state: step, the archive's sha256, the
    config hash, and the one data entry against the fixture's index.json (all but the entry's
    stage-specific keys). Returns (that entry, the index)."""
    test.assertEqual(m["step"], step)
    test.assertEqual(m["checkpoint"]["sha256"],
                     sha256_file(os.path.join(run_dir, "checkpoint.wmt")))
    compact = json.dumps(m["config"], sort_keys=True, separators=(",", ":"))
    test.assertEqual(m["config_hash"], hashlib.sha256(compact.encode()).hexdigest())
    with open(os.path.join(FIX["shards"], "index.json"), encoding="utf-8") as f:
        index = json.load(f)
    [data] = m["data"]
    test.assertEqual((data["dataset"], data["split"], data["num_steps"]),
                     (index["dataset"], index["split"], index["num_steps"]))
    test.assertEqual(data["index_config_hash"], index["provenance"]["config_hash"])
    test.assertEqual(data["shards"],
                     [{"file": s["file"], "sha256": s["sha256"]} for s in index["shards"]])
    test.assertNotIn(FIX["tmp"], json.dumps(m))  # no paths
    return data, index


class TokenizerCheckpoint(unittest.TestCase):
    def setUp(self):
        with open(os.path.join(FIX["tok"], "checkpoint.json"), encoding="utf-8") as f:
            self.manifest = json.load(f)
        self.validator = validator("tokenizer-checkpoint")

    def test_valid_and_consistent(self):
        self.validator.validate(self.manifest)
        data, _ = check_run_manifest(self, self.manifest, FIX["tok"], 2)
        self.assertEqual(data["weight"], 1.0)

    def test_loader_defaults_are_the_schema_defaults(self):
        self.assertEqual(self.manifest["config"],
                         expected_config("tokenizer-config", FIX["tok_overrides"], 2))

    def test_rejects_mutated_manifests(self):
        def mutated(fn):
            doc = copy.deepcopy(self.manifest)
            fn(doc)
            return doc
        for fn in (lambda d: d.update(extra=1),
                   lambda d: d.update(tool="wm-train"),
                   lambda d: d.update(step=0),
                   lambda d: d.pop("rng"),
                   lambda d: d["rng"].update(reseed_mt19937_64="1 2 3"),
                   lambda d: d["config"]["model"].pop("beta"),
                   lambda d: d["config"]["train"].update(grad_clip=None),
                   lambda d: d["config"]["model"].update(patch_size=6),
                   lambda d: d["checkpoint"].update(sha256=d["checkpoint"]["sha256"].upper()),
                   lambda d: d["libraries"].pop("libtorch"),
                   lambda d: d["libraries"].pop("blas"),
                   lambda d: d["libraries"].update(blas=""),
                   lambda d: d["data"][0]["shards"][0].update(path="/data/x"),
                   lambda d: d["data"][0].update(weight=1.5),
                   lambda d: d.update(data=[])):
            self.assertFalse(self.validator.is_valid(mutated(fn)))


class TokenizerFineTune(unittest.TestCase):
    """`wm-tokenize train --init-from --freeze encoder`: checkpoint.json validates, records the
    parent by hash (init_from) and hashes it into config_hash."""

    @classmethod
    def setUpClass(cls):
        cls.run_dir = os.path.join(FIX["tmp"], "tok_ft")
        config = os.path.join(FIX["tmp"], "tok.yaml")
        r = tool("wm-tokenize", "train", "--config", config, "--data", FIX["shards"], "--out",
                 cls.run_dir, "--steps", 2, "--threads", 1, "--init-from", FIX["tok"],
                 "--freeze", "encoder")
        assert r.returncode == 0, r.stderr
        with open(os.path.join(cls.run_dir, "checkpoint.json"), encoding="utf-8") as f:
            cls.manifest = json.load(f)

    def test_valid_and_records_the_parent(self):
        m = self.manifest
        validator("tokenizer-checkpoint").validate(m)
        with open(os.path.join(FIX["tok"], "checkpoint.json"), encoding="utf-8") as f:
            parent = json.load(f)
        self.assertEqual(m["init_from"], {
            "checkpoint_sha256": sha256_file(os.path.join(FIX["tok"], "checkpoint.wmt")),
            "config_hash": parent["config_hash"], "step": 2, "freeze": ["encoder"]})
        hashed = dict(m["config"], init_from=m["init_from"])
        compact = json.dumps(hashed, sort_keys=True, separators=(",", ":"))
        self.assertEqual(m["config_hash"], hashlib.sha256(compact.encode()).hexdigest())
        self.assertNotIn(FIX["tmp"], json.dumps(m))  # no paths

    def test_rejects_mutated_init_from(self):
        v = validator("tokenizer-checkpoint")
        for fn in (lambda d: d["init_from"].pop("step"),
                   lambda d: d["init_from"].update(run=FIX["tok"]),
                   lambda d: d["init_from"].update(freeze=["decoder"]),
                   lambda d: d["init_from"].update(checkpoint_sha256="x")):
            doc = copy.deepcopy(self.manifest)
            fn(doc)
            self.assertFalse(v.is_valid(doc))


def archive_meta(path):
    """The JSON meta of a wmkit tensor archive (WMTENSR1, u64 header length, header JSON)."""
    with open(path, "rb") as f:
        blob = f.read()
    assert blob[:8] == b"WMTENSR1", path
    (n,) = struct.unpack_from("<Q", blob, 8)
    return json.loads(blob[16:16 + n].decode("utf-8"))["meta"]


class MotionCheckpoint(unittest.TestCase):
    """checkpoint.json of `wm-motion train --steps 1` on the fixture's shards against
    schemas/motion-checkpoint.schema.json, the index and the archive."""

    @classmethod
    def setUpClass(cls):
        with open(os.path.join(FIX["motion"], "checkpoint.json"), encoding="utf-8") as f:
            cls.manifest = json.load(f)

    def test_valid_and_consistent(self):
        m = self.manifest
        validator("motion-checkpoint").validate(m)
        data, index = check_run_manifest(self, m, FIX["motion"], 1)
        self.assertEqual((m["model_kind"], data["num_episodes"]), ("motion", index["num_episodes"]))
        stats = index["action_stats"]
        self.assertEqual(m["action_norms"],
                         {index["dataset"]: {"mean": stats["mean"], "std": stats["std"]}})
        self.assertEqual(m["action_dim"], len(stats["mean"]))
        self.assertEqual(m["action_space"],
                         index["features"]["action"].get("space", "eef_delta"))

    def test_archive_meta_agrees(self):
        """What MotionModel::Load and --resume read (the archive's meta) is what the manifest
        says."""
        meta = archive_meta(os.path.join(FIX["motion"], "checkpoint.wmt"))
        for key in ("model_kind", "step", "config", "config_hash", "action_dim", "action_space",
                    "action_norms"):
            self.assertEqual(meta[key], self.manifest[key], key)

    def test_loader_defaults_are_the_schema_defaults(self):
        self.assertEqual(self.manifest["config"],
                         expected_config("motion-config", FIX["motion_overrides"], 1))
        validator("motion-config").validate(self.manifest["config"])

    def test_rejects_mutated_manifests(self):
        v = validator("motion-checkpoint")
        [name] = self.manifest["action_norms"]
        for fn in (lambda d: d.update(extra=1),
                   lambda d: d.update(tool="wm-train"),
                   lambda d: d.update(model_kind="dynamics"),
                   lambda d: d.pop("model_kind"),
                   lambda d: d.update(step=0),
                   lambda d: d.update(rng={"scheme": "mt19937_64", "seed": 0}),
                   lambda d: d.update(init_from={}),
                   lambda d: d["config"]["model"].pop("flow_scale"),
                   lambda d: d["config"]["model"].update(image_size=60),
                   lambda d: d["config"]["train"].update(unroll=0),
                   lambda d: d["config"]["train"].update(grad_clip=None),
                   lambda d: d["config"]["data"].update(stream="image"),
                   lambda d: d.update(config_hash="0" * 63),
                   lambda d: d["checkpoint"].update(sha256=d["checkpoint"]["sha256"].upper()),
                   lambda d: d["checkpoint"].update(format="torch"),
                   lambda d: d["libraries"].pop("libtorch"),
                   lambda d: d["libraries"].pop("blas"),
                   lambda d: d["libraries"].update(blas=""),
                   lambda d: d.update(data=[]),
                   lambda d: d.update(data=d["data"] * 2),
                   lambda d: d["data"][0].update(weight=1.0),
                   lambda d: d["data"][0].pop("num_episodes"),
                   lambda d: d["data"][0]["shards"][0].update(path="/data/x"),
                   lambda d: d["data"][0]["shards"][0].update(file="shard-0.wms"),
                   lambda d: d.update(action_dim=0),
                   lambda d: d.pop("action_dim"),
                   lambda d: d.update(action_space="cartesian"),
                   lambda d: d.update(action_norms={}),
                   lambda d: d["action_norms"].update(other=d["action_norms"][name]),
                   lambda d: d["action_norms"][name].pop("std"),
                   lambda d: d["action_norms"][name].update(mean=[]),
                   lambda d: d["action_norms"][name]["std"].__setitem__(0, -1.0),
                   lambda d: d["action_norms"][name].update(min=[0.0])):
            doc = copy.deepcopy(self.manifest)
            fn(doc)
            self.assertFalse(v.is_valid(doc), doc)


class DynamicsDefaults(unittest.TestCase):
    def test_loader_defaults_are_the_schema_defaults(self):
        tmp = FIX["tmp"]
        tokens, run, empty = (os.path.join(tmp, n) for n in ("tokens", "dyn", "empty.yaml"))
        r = tool("wm-tokenize", "encode", "--checkpoint", FIX["tok"], "--data", FIX["shards"],
                 "--out", tokens, "--threads", 1)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(empty, "w", encoding="utf-8") as f:
            f.write("# every key at its default\n")
        validator("dynamics-config").validate(load_yaml(empty))
        r = tool("wm-train", "--config", empty, "--tokens", tokens, "--out", run, "--steps", 1,
                 "--threads", 1)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(run, "checkpoint.json"), encoding="utf-8") as f:
            config = json.load(f)["config"]
        expected = schema_defaults(schema("dynamics-config"))
        expected["train"]["steps"] = 1  # --steps
        # Written only when not the default, so older configs keep their hashes.
        self.assertEqual(expected["model"].pop("temporal_positions"), "learned")
        self.assertEqual(expected["model"].pop("adaptive_norm"), "none")
        self.assertEqual(config, expected)
        validator("dynamics-config").validate(config)


class MetricsCompare(unittest.TestCase):
    def metrics(self, pred, *args):
        r = tool("wm-metrics", "--ref", os.path.join(FIX["tmp"], "ref"), "--pred",
                 os.path.join(FIX["tmp"], pred), "--threads", 1, *args)
        self.assertEqual(r.returncode, 0, r.stderr)
        return json.loads(r.stdout)

    def deep(self, pred, metrics):
        return self.metrics(pred, "--metrics", metrics, "--feature-net", FIX["tok"],
                            "--clip-length", 2, "--per-frame")

    def setUp(self):
        self.validator = validator("metrics-compare")

    def test_deep_metrics_per_frame(self):
        out = self.deep("pred", "psnr,ssim,lpips_style,fvd_style")
        self.validator.validate(out)
        self.assertEqual(set(out), {"psnr", "ssim", "lpips_style", "fvd_style", "fvd_style_clips",
                                    "frames", "per_frame"})
        self.assertEqual((out["frames"], out["fvd_style_clips"]), (4, 2))
        self.assertEqual([r["source"] for r in out["per_frame"]],
                         [os.path.join(FIX["tmp"], "pred", "%03d.png" % i) for i in range(4)])
        for row in out["per_frame"]:
            self.assertEqual(set(row), {"source", "psnr", "ssim", "lpips_style", "fvd_style"})
            self.assertIsNone(row["fvd_style"])
            self.assertIsInstance(row["psnr"], float)
        self.assertGreater(out["lpips_style"], 0)

        def mutated(fn):
            doc = copy.deepcopy(out)
            fn(doc)
            return doc
        for fn in (lambda d: d.update(psnr="Infinity"),
                   lambda d: d.update(ssim=1.5),
                   lambda d: d.update(vmaf=90.0),
                   lambda d: d.pop("frames"),
                   lambda d: d.pop("fvd_style_clips"),
                   lambda d: d.update(fvd_style_clips=1),
                   lambda d: d["per_frame"][0].update(fvd_style=0.0),
                   lambda d: d["per_frame"][1].pop("lpips_style"),
                   lambda d: d["per_frame"][2].pop("source"),
                   lambda d: d["per_frame"][3].update(lpips_style=-0.1)):
            self.assertFalse(self.validator.is_valid(mutated(fn)))

    def test_identical_frames_psnr_is_the_string_inf(self):
        out = self.deep("ref", "mse,psnr,ssim,lpips_style,fvd_style")
        self.validator.validate(out)
        self.assertEqual((out["psnr"], out["mse"], out["ssim"], out["lpips_style"]),
                         ("inf", 0.0, 1.0, 0.0))
        self.assertEqual({r["psnr"] for r in out["per_frame"]}, {"inf"})
        self.assertFalse(self.validator.is_valid({**out, "psnr": "+inf"}))

    def test_default_metrics(self):
        out = self.metrics("pred")
        self.validator.validate(out)
        self.assertEqual(set(out), {"mse", "psnr", "ssim", "frames"})


if __name__ == "__main__":
    unittest.main(verbosity=2)
