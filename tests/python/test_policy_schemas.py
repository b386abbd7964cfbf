#!/usr/bin/python3
"""The policy formats of issue 21 validate against their schemas: configs/policies/*.yaml, the
messages scripts/wmpolicy.py exchanges, and wm-sim-policy's policy_values.json."""
import glob
import json
import os
import subprocess
import tempfile
import unittest

import jsonschema
import yaml

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))


def schema(name):
    with open(os.path.join(SRC, "schemas", name)) as f:
        return json.load(f)


class PolicySchemas(unittest.TestCase):
    def test_policy_lists(self):
        files = sorted(glob.glob(os.path.join(SRC, "configs", "policies", "*.yaml")))
        self.assertGreaterEqual(len(files), 1)
        for path in files:
            with open(path) as f:
                jsonschema.validate(yaml.safe_load(f), schema("policy-list.schema.json"))
        with self.assertRaises(jsonschema.ValidationError):
            jsonschema.validate({"policies": [{"name": "Bad-Name", "command": "x"}]},
                                schema("policy-list.schema.json"))

    def test_wmpolicy_messages(self):
        s = schema("policy-protocol.schema.json")
        hello = {"type": "hello", "protocol": "wmkit-policy", "version": 1, "action_dim": 7,
                 "image": {"height": 2, "width": 2, "channels": 3, "encoding": "rgb8"}}
        step = {"type": "step", "episode": 0, "step": 0, "instruction": "push",
                "image": {"height": 2, "width": 2, "channels": 3, "encoding": "rgb8", "bytes": 12}}
        reset = {"type": "reset", "episode": 0, "seed": 5, "instruction": "push"}
        stdin = b"".join(json.dumps(m).encode() + b"\n" for m in (hello, reset)) + \
            json.dumps(step).encode() + b"\n" + bytes(12) + b'{"type": "close"}\n'
        for m in (hello, step, reset):
            jsonschema.validate(m, s)
        out = subprocess.run(["/usr/bin/python3", os.path.join(SRC, "scripts", "wmpolicy.py")],
                             input=stdin, capture_output=True, check=True).stdout
        replies = [json.loads(line) for line in out.splitlines()]
        self.assertEqual([r["type"] for r in replies], ["hello", "ready", "action"])
        for r in replies:
            jsonschema.validate(r, s)

    def test_sim_policy_values(self):
        with tempfile.TemporaryDirectory() as out:
            subprocess.run([os.path.join(BIN, "wm-sim-policy"), "--out", out, "--size", "64",
                            "--episodes", "2", "--max-steps", "3", "--no-dataset", "--policy",
                            "still=/usr/bin/python3 " + os.path.join(SRC, "scripts", "wmpolicy.py")],
                           check=True, capture_output=True)
            with open(os.path.join(out, "policy_values.json")) as f:
                jsonschema.validate(json.load(f), schema("policy-values.schema.json"))


if __name__ == "__main__":
    unittest.main()
