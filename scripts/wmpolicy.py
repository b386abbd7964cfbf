#!/usr/bin/python3
"""wmpolicy: serve any Python policy to wmkit over the wmkit-policy protocol v1.

The protocol (docs/policy-protocol.md): wmkit starts the policy as a process and writes one JSON
line per request to its stdin; a step request is followed by the raw RGB image bytes. The policy
answers one JSON line per request on its stdout. This module does all of that; a policy is a
class built once per episode:

    import wmpolicy

    class MyPolicy:
        def __init__(self, episode):        # episode.id, episode.seed, episode.instruction
            self.rng = np.random.default_rng(episode.seed)
        def act(self, obs):                 # obs.image: uint8 [H, W, 3] RGB; obs.instruction,
            return [0.0] * obs.action_dim   # obs.step, obs.episode; return action_dim floats

    if __name__ == "__main__":
        wmpolicy.serve(MyPolicy, name="my_policy")

print() inside a policy goes to stderr (wmkit shows its end when the policy fails): stdout carries
only the protocol. An exception in a policy is reported to wmkit as an error reply (wmkit stops
with the policy's message, episode and step).
"""
import json
import os
import sys
import traceback

PROTOCOL = "wmkit-policy"
VERSION = 1

try:
    import numpy as _np
except ImportError:  # the protocol works without numpy; images are then bytes
    _np = None


class Episode:
    """What a reset says: id, seed (seed the policy's random generator with it), instruction."""

    def __init__(self, message, action_dim):
        self.id = message["episode"]
        self.seed = message.get("seed", 0)
        self.instruction = message.get("instruction", "")
        self.action_dim = action_dim


class Observation:
    """One step: image (numpy uint8 [H, W, 3] RGB, or bytes without numpy), instruction,
    episode, step, action_dim."""

    def __init__(self, message, pixels, action_dim):
        image = message["image"]
        self.height, self.width = image["height"], image["width"]
        self.image = (_np.frombuffer(pixels, dtype=_np.uint8).reshape(self.height, self.width, 3)
                      if _np is not None else pixels)
        self.instruction = message.get("instruction", "")
        self.episode = message["episode"]
        self.step = message["step"]
        self.action_dim = action_dim


def _read_exact(stream, n):
    data = bytearray()
    while len(data) < n:
        chunk = stream.read(n - len(data))
        if not chunk:
            raise EOFError("wmkit closed the connection inside an image")
        data += chunk
    return bytes(data)


def serve(make_policy, name="python_policy", info=None, stdin=None, stdout=None):
    """Answers wmkit's requests until it sends close or closes stdin.

    make_policy(episode) -> object with act(observation) returning action_dim numbers. A policy
    with no per-episode state can ignore `episode` and return itself from a closure."""
    if stdin is None:
        stdin = sys.stdin.buffer
    if stdout is None:
        # Keep the protocol channel for ourselves and send everything else printed to stderr.
        stdout = os.fdopen(os.dup(1), "wb")
        os.dup2(2, 1)
        sys.stdout = sys.stderr
    action_dim = None
    episodes = {}

    def reply(message):
        stdout.write((json.dumps(message) + "\n").encode())
        stdout.flush()

    while True:
        line = stdin.readline()
        if not line:
            return
        message = json.loads(line)
        kind = message.get("type")
        if kind == "close":
            return
        try:
            if kind == "hello":
                action_dim = message["action_dim"]
                reply({"type": "hello", "protocol": PROTOCOL, "version": VERSION,
                       "name": name, "info": info or {}})
            elif kind == "reset":
                episodes[message["episode"]] = make_policy(Episode(message, action_dim))
                reply({"type": "ready", "episode": message["episode"]})
            elif kind == "step":
                pixels = _read_exact(stdin, message["image"]["bytes"])
                obs = Observation(message, pixels, action_dim)
                policy = episodes.get(obs.episode)
                if policy is None:
                    raise KeyError("step for episode %s before its reset" % obs.episode)
                action = [float(a) for a in policy.act(obs)]
                reply({"type": "action", "episode": obs.episode, "step": obs.step,
                       "action": action})
            else:
                raise ValueError("unknown request type %r" % kind)
        except Exception as e:  # reported to wmkit, which stops with this message
            traceback.print_exc(file=sys.stderr)
            reply({"type": "error", "message": "%s: %s" % (type(e).__name__, e)})


if __name__ == "__main__":
    # A do-nothing policy: zero motion, gripper open (a protocol smoke test).
    class _Still:
        def __init__(self, episode):
            pass

        def act(self, obs):
            return [0.0] * obs.action_dim

    serve(_Still, name="still")
