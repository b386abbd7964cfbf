#!/usr/bin/python3
"""openpi_policy: a wmkit policy (docs/policy-protocol.md) that asks a policy server speaking
the websocket + msgpack convention of openpi-style VLA servers (openpi's
`scripts/serve_policy.py`, and servers that copy its wire format) for each action.

    wm-eval --policy "pi0=scripts/openpi_policy.py --server ws://gpu-host:8000 --resize 224" ...

The convention (docs/policy-protocol.md, "openpi servers"): the client opens a websocket; the
server first sends its metadata; then every client message is one msgpack map of the
observation and every server answer one msgpack map holding "actions", an action chunk
[horizon, action_dim] (or one action [action_dim]). Arrays travel as maps
{b"__ndarray__": True, b"data": raw bytes, b"dtype": numpy typestr, b"shape": [...]}. A text
message instead of an answer is the server's error. The chunk's first `--replan` actions are
executed open loop before the server is asked again (openpi's LIBERO example replans every 5).

Observation keys differ between servers' configs, so they are options: the image goes under
--image-key (default observation/image, uint8 [H, W, 3]), the instruction under --prompt-key
(default prompt), and --state-key K --state-dim N adds N zeros (wmkit frames carry no
proprioception). A chunk whose action width is not wmkit's action_dim is an error naming both.
Needs python3-msgpack and python3-websockets (Debian; websockets >= 10).
"""
import argparse
import asyncio
import os
import sys

import msgpack
import numpy as np
import websockets

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import wmpolicy  # noqa: E402


def pack_array(value):
    """msgpack's `default` hook: numpy arrays and scalars in the convention's map form."""
    if isinstance(value, np.ndarray):
        return {b"__ndarray__": True, b"data": value.tobytes(), b"dtype": value.dtype.str,
                b"shape": list(value.shape)}
    if isinstance(value, np.generic):
        return {b"__npgeneric__": True, b"data": value.item(), b"dtype": value.dtype.str}
    raise TypeError("cannot send %s to the policy server" % type(value).__name__)


def unpack_array(value):
    """msgpack's `object_hook`: the map form back to numpy."""
    if b"__ndarray__" in value:
        return np.frombuffer(value[b"data"], dtype=np.dtype(value[b"dtype"])).reshape(
            value[b"shape"])
    if b"__npgeneric__" in value:
        return np.dtype(value[b"dtype"]).type(value[b"data"])
    return value


def pack(message):
    return msgpack.packb(message, default=pack_array, use_bin_type=True)


def unpack(data):
    return msgpack.unpackb(data, object_hook=unpack_array, raw=False)


def letterbox(image, size):
    """uint8 [H, W, 3] -> [size, size, 3]: scaled to fit (area resampling), padded with black,
    centred (what openpi's image_tools.resize_with_pad does)."""
    import cv2
    h, w = image.shape[:2]
    scale = size / max(h, w)
    nh, nw = max(1, round(h * scale)), max(1, round(w * scale))
    resized = cv2.resize(image, (nw, nh), interpolation=cv2.INTER_AREA if scale < 1
                         else cv2.INTER_LINEAR)
    out = np.zeros((size, size, 3), np.uint8)
    top, left = (size - nh) // 2, (size - nw) // 2
    out[top:top + nh, left:left + nw] = resized
    return out


class Server:
    """One websocket to the policy server for the whole process (its episodes share it)."""

    def __init__(self, uri, timeout):
        self.uri, self.timeout = uri, timeout
        self.loop = asyncio.new_event_loop()
        asyncio.set_event_loop(self.loop)  # websockets 10's client binds to the current loop
        self.ws = self._run(websockets.connect(uri, max_size=None, compression=None))
        self.metadata = self._receive()

    def _run(self, coroutine):
        return self.loop.run_until_complete(asyncio.wait_for(coroutine, self.timeout))

    def _receive(self):
        data = self._run(self.ws.recv())
        if isinstance(data, str):  # the convention's error reply: the server's traceback
            raise RuntimeError("policy server %s: %s" % (self.uri, data.strip()[-500:]))
        return unpack(data)

    def close(self):
        self._run(self.ws.close())

    def infer(self, observation):
        self._run(self.ws.send(pack(observation)))
        return self._receive()


def chunk_of(answer, action_dim, where):
    """The answer's "actions" as [horizon, action_dim] float32, or an error naming the problem."""
    if not isinstance(answer, dict) or "actions" not in answer:
        keys = sorted(answer) if isinstance(answer, dict) else type(answer).__name__
        raise ValueError("%s: the answer has no 'actions' (it has %s)" % (where, keys))
    actions = np.asarray(answer["actions"], dtype=np.float32)
    if actions.ndim == 1:
        actions = actions[None]
    if actions.ndim != 2 or actions.shape[1] != action_dim or actions.shape[0] == 0:
        raise ValueError("%s: 'actions' has shape %s, expected [horizon, %d] (wmkit's action_dim)"
                         % (where, list(actions.shape), action_dim))
    return actions


def make_policy(server, args):
    class OpenpiPolicy:
        """One episode: asks the server every `replan` steps and plays the chunk in between."""

        def __init__(self, episode):
            self.pending = []

        def act(self, obs):
            if not self.pending:
                image = np.asarray(obs.image, dtype=np.uint8)
                if args.resize:
                    image = letterbox(image, args.resize)
                observation = {args.image_key: image, args.prompt_key: obs.instruction}
                if args.state_key:
                    observation[args.state_key] = np.zeros(args.state_dim, np.float32)
                where = "policy server %s, episode %d, step %d" % (server.uri, obs.episode,
                                                                   obs.step)
                chunk = chunk_of(server.infer(observation), obs.action_dim, where)
                self.pending = list(chunk[:args.replan])
            return self.pending.pop(0)
    return OpenpiPolicy


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--server", default="ws://127.0.0.1:8000", help="ws://HOST:PORT")
    ap.add_argument("--replan", type=int, default=1, metavar="N",
                    help="execute the first N actions of each chunk before asking again")
    ap.add_argument("--resize", type=int, default=0, metavar="S",
                    help="letterbox the image to S x S (openpi's pi0 models: 224); 0 keeps it")
    ap.add_argument("--image-key", default="observation/image")
    ap.add_argument("--prompt-key", default="prompt")
    ap.add_argument("--state-key", default="", help="also send zeros of --state-dim under it")
    ap.add_argument("--state-dim", type=int, default=8)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per server answer")
    args = ap.parse_args()
    if args.replan < 1:
        ap.error("--replan must be >= 1")
    try:
        server = Server(args.server, args.timeout)
    except (OSError, asyncio.TimeoutError, websockets.exceptions.WebSocketException,
            RuntimeError) as e:
        sys.exit("openpi_policy: cannot open %s: %s" % (args.server, e or type(e).__name__))
    metadata = server.metadata if isinstance(server.metadata, dict) else {}
    info = {"server": args.server, "metadata": {str(k): str(v) for k, v in metadata.items()}}
    try:
        wmpolicy.serve(make_policy(server, args), name="openpi", info=info)
    finally:
        server.close()  # a clean close frame, so the server does not log a dropped connection


if __name__ == "__main__":
    main()
