"""What the experiment scripts' tests (test_finetune.py, test_scaling.py) share: file hashes, the
repository's JSON Schemas, and a report CSV row typed as its schema sees it."""
import hashlib
import json
import os
import subprocess
import tempfile

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def schema(name):
    with open(os.path.join(SRC, "schemas", name + ".schema.json"), encoding="utf-8") as f:
        return json.load(f)


def typed(row, text_columns):
    """A CSV row as its schema sees it: empty cell -> null, other columns than `text_columns`
    -> numbers."""
    out = {}
    for k, v in row.items():
        if v == "":
            out[k] = None
        elif k in text_columns:
            out[k] = v
        else:
            out[k] = int(v) if v.lstrip("-").isdigit() else float(v)
    return out


def run_experiment(who, config, out):
    """scripts/<who>.py --config CONFIG --out OUT with the built tools, its output captured."""
    return subprocess.run(["/usr/bin/python3", os.path.join(SRC, "scripts", who + ".py"), "--bin",
                           BIN, "--config", config, "--out", out], cwd=SRC, capture_output=True,
                          text=True)


def set_up_experiment(test_class, who, reduced_config, outputs):
    """Runs the experiment `who` once for a test class on reduced_config(path) (which writes the
    config there and returns it as a dict), in a temporary directory: sets tmp, out, config, cfg
    and bytes ({name: contents} of `outputs`, for the rerun's comparison)."""
    test_class.tmp = tempfile.TemporaryDirectory()
    test_class.out = os.path.join(test_class.tmp.name, who)
    test_class.config = os.path.join(test_class.tmp.name, "reduced.yaml")
    test_class.cfg = reduced_config(test_class.config)
    p = run_experiment(who, test_class.config, test_class.out)
    assert p.returncode == 0, p.stdout + p.stderr
    test_class.bytes = {}
    for name in outputs:
        with open(os.path.join(test_class.out, name), "rb") as f:
            test_class.bytes[name] = f.read()
