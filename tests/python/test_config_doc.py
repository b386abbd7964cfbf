#!/usr/bin/python3
"""docs/config.md's family table names every folder under configs/, so a new config family
cannot ship without saying which tool reads it and where its fields are documented."""
import os
import re
import unittest

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")


class ConfigDocTest(unittest.TestCase):
    def test_every_config_folder_has_a_row(self):
        with open(os.path.join(SRC, "docs", "config.md")) as f:
            rows = set(re.findall(r"^\| `configs/([\w-]+)/` \|", f.read(), re.M))
        folders = {d for d in os.listdir(os.path.join(SRC, "configs"))
                   if os.path.isdir(os.path.join(SRC, "configs", d))}
        self.assertEqual(sorted(folders - rows), [], "configs/ folders without a docs/config.md row")
        self.assertEqual(sorted(rows - folders), [], "docs/config.md rows without a folder")


if __name__ == "__main__":
    unittest.main()
