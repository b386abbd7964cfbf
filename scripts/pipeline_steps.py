"""What the experiment scripts (scripts/ablation.py, scripts/finetune.py) share: running a wmkit
tool with its output in a log, hashing inputs for a manifest, and writing results atomically so
a killed run never leaves a half-written file that looks finished."""
import hashlib
import os
import subprocess
import sys


def run(cmd, log, who):
    """Runs one wmkit tool, its output appended to `log`; a failure stops the script `who`."""
    print("+ " + " ".join(cmd), flush=True)
    with open(log, "a", encoding="utf-8") as f:
        if subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode != 0:
            sys.exit(f"{who}: command failed (log: {log}): {' '.join(cmd)}")


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def write_atomically(path, data):
    """Writes `data` (text, or bytes) to a temporary file, syncs it, then renames it to `path`."""
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
