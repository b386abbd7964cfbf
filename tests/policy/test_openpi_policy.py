#!/usr/bin/python3
"""scripts/openpi_policy.py against a fake openpi-style policy server written here from the
convention (metadata first, msgpack maps, arrays as {b"__ndarray__", b"data", b"dtype",
b"shape"}, a text message = an error), driven over the wmkit-policy protocol as wmkit drives a
policy (docs/policy-protocol.md): the observation the server receives, chunks played open loop
for --replan steps, and the errors (wrong action width, a server error, no server) named."""
import asyncio
import json
import os
import subprocess
import sys
import threading

import numpy as np

try:
    import msgpack
    import websockets
except ImportError as e:  # e.g. a GPU image without them; scripts/install-deps.sh installs both
    print("SKIP: %s (Debian: python3-msgpack python3-websockets)" % e)
    sys.exit(77)

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from check_list import CheckList, free_port  # noqa: E402

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BRIDGE = os.path.join(SRC, "scripts", "openpi_policy.py")
check = CheckList()


def decode(value):  # the server side's own reading of the convention
    if b"__ndarray__" in value:
        return np.frombuffer(value[b"data"], dtype=value[b"dtype"]).reshape(value[b"shape"])
    return value


def encode(value):
    if isinstance(value, np.ndarray):
        return {b"__ndarray__": True, b"data": value.tobytes(), b"dtype": value.dtype.str,
                b"shape": value.shape}
    raise TypeError(type(value))


class FakeServer:
    """Answers each observation per `mode`: "chunk" a [5, width] chunk whose row r of call c is
    [c, r, red of pixel (0, 0), image height, prompt length, 0, ...]; "text" an error text."""

    def __init__(self, mode="chunk", width=7):
        self.mode, self.width, self.seen, self.port = mode, width, [], free_port()
        ready = threading.Event()
        self.loop = asyncio.new_event_loop()
        threading.Thread(target=self._serve, args=(ready,), daemon=True).start()
        ready.wait(10)

    def _serve(self, ready):
        asyncio.set_event_loop(self.loop)
        self.loop.run_until_complete(websockets.serve(self._handle, "127.0.0.1", self.port))
        ready.set()
        self.loop.run_forever()

    async def _handle(self, ws, *_):
        await ws.send(msgpack.packb({"policy": "fake", "action_horizon": 5}))
        try:
            await self._answer(ws)
        except websockets.exceptions.ConnectionClosed:
            pass  # a bridge killed mid-episode

    async def _answer(self, ws):
        async for data in ws:
            obs = msgpack.unpackb(data, object_hook=decode, raw=False)
            self.seen.append(obs)
            if self.mode == "text":
                await ws.send("Traceback (most recent call last):\nValueError: bad prompt")
                continue
            image = obs["observation/image"]
            call = len(self.seen) - 1
            chunk = np.zeros((5, self.width), np.float32)
            chunk[:, 0], chunk[:, 1] = call, np.arange(5)
            chunk[:, 2], chunk[:, 3], chunk[:, 4] = image[0, 0, 0], image.shape[0], len(obs["prompt"])
            await ws.send(msgpack.packb({"actions": chunk}, default=encode))


def drive(server_port, flags, steps, image_size=64, action_dim=7):
    """Runs the bridge through hello, reset and `steps` steps: -> the replies."""
    p = subprocess.Popen([sys.executable, BRIDGE, "--server", "ws://127.0.0.1:%d" % server_port,
                          "--timeout", "10"] + flags,
                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    image = {"height": image_size, "width": image_size, "channels": 3, "encoding": "rgb8"}
    def line(message):
        return (json.dumps(message) + "\n").encode()
    payload = line({"type": "hello", "protocol": "wmkit-policy", "version": 1,
                    "action_dim": action_dim, "image": image})
    payload += line({"type": "reset", "episode": 3, "seed": 1, "instruction": "push the block"})
    for step in range(steps):
        pixels = np.full((image_size, image_size, 3), 10 * step + 5, np.uint8).tobytes()
        payload += line({"type": "step", "episode": 3, "step": step, "instruction":
                         "push the block", "image": dict(image, bytes=len(pixels))}) + pixels
    out, err = p.communicate(payload + b'{"type":"close"}\n', timeout=60)
    replies = [json.loads(line) for line in out.decode().splitlines()]
    return replies, p.returncode, err.decode()


def main():
    server = FakeServer()
    replies, rc, err = drive(server.port, ["--replan", "2"], 4)
    actions = [r.get("action") or [None] * 4 for r in replies[2:]] + [[None] * 4] * 4
    check(rc == 0 and len(replies) == 6 and replies[0]["name"] == "openpi",
          "hello, ready and 4 actions (rc %s, %s)" % (rc, err[-300:]))
    check(bool(replies) and replies[0].get("info", {}).get("metadata", {}).get("policy") == "fake",
          "the server's metadata reaches the hello's info")
    check([a[:2] for a in actions[:4]] == [[0, 0], [0, 1], [1, 0], [1, 1]],
          "--replan 2: two actions of each chunk, then the server is asked again (%s)"
          % [a[:2] for a in actions[:4]])
    check(len(server.seen) == 2 and server.seen[0].get("prompt") == "push the block",
          "the instruction goes under 'prompt'")
    image = server.seen[1]["observation/image"] if len(server.seen) > 1 else np.zeros(0)
    check(image.dtype == np.uint8 and image.shape == (64, 64, 3) and image[0, 0, 0] == 25,
          "the image arrives as uint8 [64, 64, 3], the frame of the asking step")
    check(actions[2][2] == 25 and actions[2][3] == 64, "the action echoes what the server saw")

    server = FakeServer()
    replies, rc, err = drive(server.port, ["--resize", "224", "--state-key", "observation/state",
                                           "--state-dim", "8"], 1)
    seen = server.seen[0] if server.seen else {}
    image = seen.get("observation/image", np.zeros(0))
    check(rc == 0 and image.shape == (224, 224, 3) and image[112, 112, 0] == 5,
          "--resize 224 letterboxes the image (%s)" % (image.shape,))
    check(np.array_equal(seen.get("observation/state"), np.zeros(8, np.float32)),
          "--state-key sends zeros of --state-dim")

    server = FakeServer(width=6)
    replies, rc, err = drive(server.port, [], 1)
    message = replies[-1].get("message", "") if replies else ""
    check(replies and replies[-1]["type"] == "error" and "shape [5, 6]" in message
          and "[horizon, 7]" in message and "episode 3, step 0" in message,
          "a chunk of another width is an error naming both widths and the step (%r)" % message)

    server = FakeServer(mode="text")
    replies, rc, err = drive(server.port, [], 1)
    message = replies[-1].get("message", "") if replies else ""
    check(replies and replies[-1]["type"] == "error" and "bad prompt" in message,
          "the server's error text becomes the error reply (%r)" % message)

    dead = free_port()
    replies, rc, err = drive(dead, [], 1)
    check(rc == 1 and not replies and "cannot open ws://127.0.0.1:%d" % dead in err,
          "no server: exit 1 with one line naming it (%r)" % err.strip()[-200:])
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
