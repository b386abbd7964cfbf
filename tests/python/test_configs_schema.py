#!/usr/bin/python3
"""Every shipped dataset mapping (configs/datasets/*.yaml) validates against its JSON Schema, and
the schema rejects the mistakes it exists to catch."""
import glob
import json
import os
import unittest

import jsonschema
import yaml

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))


class DatasetMappingSchema(unittest.TestCase):
    def setUp(self):
        with open(os.path.join(SRC, "schemas", "dataset-mapping.schema.json")) as f:
            self.schema = json.load(f)

    def test_every_shipped_mapping_is_valid(self):
        files = sorted(glob.glob(os.path.join(SRC, "configs", "datasets", "*.yaml")))
        self.assertGreaterEqual(len(files), 2)
        for path in files:
            with open(path) as f:
                mapping = yaml.safe_load(f)
            jsonschema.validate(mapping, self.schema)
            name = os.path.splitext(os.path.basename(path))[0]
            self.assertEqual(mapping["dataset"], name, path)

    def test_rejects_typos_and_bad_parts(self):
        good = {"dataset": "x", "image": "steps/observation/image",
                "action": [{"key": "steps/action"}]}
        jsonschema.validate(good, self.schema)
        for bad in ({**good, "imgae": "k"},
                    {**good, "action": [{"key": "a", "zeros": 2}]},
                    {**good, "action": [{"zeros": 0}]},
                    {**good, "action": []},
                    {k: v for k, v in good.items() if k != "image"}):
            with self.assertRaises(jsonschema.ValidationError, msg=str(bad)):
                jsonschema.validate(bad, self.schema)


class LeRobotMappingSchema(unittest.TestCase):
    """configs/lerobot/*.yaml against schemas/lerobot-mapping.schema.json."""

    def setUp(self):
        with open(os.path.join(SRC, "schemas", "lerobot-mapping.schema.json")) as f:
            self.schema = json.load(f)

    def test_every_shipped_mapping_is_valid(self):
        files = sorted(glob.glob(os.path.join(SRC, "configs", "lerobot", "*.yaml")))
        self.assertGreaterEqual(len(files), 2)
        for path in files:
            with open(path) as f:
                jsonschema.validate(yaml.safe_load(f), self.schema)

    def test_rejects_typos_and_unknown_spaces(self):
        for bad in ({"acton": "action"}, {"action_space": "joints"}, {"tolerance_s": 0}):
            with self.assertRaises(jsonschema.ValidationError, msg=str(bad)):
                jsonschema.validate(bad, self.schema)


if __name__ == "__main__":
    unittest.main(verbosity=2)
