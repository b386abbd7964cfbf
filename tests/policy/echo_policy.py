#!/usr/bin/python3
"""Test policy for tests/policy/policy_process_test.cc: answers an action that echoes what it
received, so a round trip can be checked value by value, or misbehaves on purpose:

    echo_policy.py [--bad crash|segv|hang|malformed|wide|nan|inf|raise|hang_start|old_version]
                   [--at STEP] [--chatty]

action = [step, episode, image[0,0,0], image[-1,-1,2], image.sum() % 9973,
          len(instruction), seed % 1000]"""
import argparse
import math
import os
import signal
import sys
import time

sys.path.insert(0, os.path.join(os.environ.get("WM_SOURCE_DIR",
                                os.path.join(os.path.dirname(__file__), "..", "..")), "scripts"))
import wmpolicy  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--bad", default="")
parser.add_argument("--at", type=int, default=0)
parser.add_argument("--chatty", action="store_true", help="print() to stdout on every step")
args = parser.parse_args()

if args.bad == "hang_start":
    time.sleep(1000)
if args.bad == "old_version":
    wmpolicy.VERSION = 0

protocol_out = os.fdopen(os.dup(1), "wb")
os.dup2(2, 1)
sys.stdout = sys.stderr


def pixels(image):
    """(red of the first pixel, blue of the last, sum of all) of a numpy [H, W, 3] image, or of
    the raw RGB bytes wmpolicy hands over where Python has no numpy (a GPU image's)."""
    if isinstance(image, (bytes, bytearray)):
        return image[0], image[-1], sum(image)
    return int(image[0, 0, 0]), int(image[-1, -1, 2]), int(image.sum())


class Echo:
    def __init__(self, episode):
        self.seed = episode.seed

    def act(self, obs):
        if args.chatty:
            print("chatty policy at step", obs.step)  # must not reach the protocol channel
        first_red, last_blue, total = pixels(obs.image)
        action = [obs.step, obs.episode, first_red, last_blue, total % 9973,
                  len(obs.instruction), self.seed % 1000]
        if obs.step != args.at or not args.bad:
            return action
        print("misbehaving on purpose:", args.bad, file=sys.stderr)
        sys.stderr.flush()
        if args.bad == "crash":
            os._exit(3)
        if args.bad == "segv":
            os.kill(os.getpid(), signal.SIGSEGV)
        if args.bad == "hang":
            time.sleep(1000)
        if args.bad == "malformed":
            protocol_out.write(b"{this is not json\n")
            protocol_out.flush()
        if args.bad == "wide":
            return action[:-1]
        if args.bad == "nan":
            action[2] = math.nan
        if args.bad == "inf":
            action[4] = -math.inf
        if args.bad == "raise":
            raise RuntimeError("the policy's own failure")
        return action


wmpolicy.serve(Echo, name="echo", info={"test": True}, stdout=protocol_out)
