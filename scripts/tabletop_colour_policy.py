#!/usr/bin/python3
"""An image-based tabletop policy for wm-sim-policy and closed-loop evaluation (issue 21).

It sees only what the protocol sends: the RGB frame and the instruction. It finds the block (by
the colour the instruction names), the green goal and the arm (bright grey, not the table's
colour) by colour, back-projects them onto the table through the fixed camera of
ingest/tabletop/render.cc, and runs the scripted expert's pick-and-place (ingest/tabletop/
policies.cc): hover over the block, lower, close, carry the block to the goal.

The camera cannot tell the gripper's height from one frame, so the policy first lowers the
gripper to the table (the workspace stops it at 5 mm: its height is then known) and afterwards
tracks height, gripper and position from its own actions (dead reckoning with the world's
per-step limits), correcting the position with the arm it sees. Assumes --look plain (the demo's
look); the arm detector needs the plain table.

    tabletop_colour_policy.py [--noise SIGMA] [--random]

--noise adds Gaussian noise to every action: SIGMA * 4 cm on dx, dy, dz, SIGMA * 0.25 rad on the
rotations and SIGMA on the gripper command (WPE Table 4's noise levels). --random ignores the image
and acts like wm-gen-tabletop's `random` policy (a random walk with a sticky gripper).
"""
import argparse
import math
import os
import sys

import numpy as np
from scipy import ndimage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import wmpolicy  # noqa: E402

MAX_STEP, MAX_ROT = 0.04, 0.25
EE_MIN, EE_MAX = np.array([-0.25, -0.10, 0.005]), np.array([0.25, 0.40, 0.30])
HOVER_Z, GRASP_Z, CARRY_Z = 0.08, 0.012, 0.05
PALM_CENTRE = 0.06  # the palm's centre above the tool point
BLOCK_HALF = 0.02
DESCENT_STEPS = 6  # from the highest start (22 cm) to the table's stop at 5 mm

# ingest/tabletop/scene.cc's block colours (linear RGB; the renderer writes them unscaled).
BLOCK_RGB = {"red": (0.85, 0.12, 0.10), "blue": (0.12, 0.25, 0.85), "yellow": (0.92, 0.80, 0.12),
             "orange": (0.95, 0.48, 0.08), "purple": (0.55, 0.18, 0.70),
             "white": (0.92, 0.92, 0.90)}


class Camera:
    """render.cc's TableCamera() and IntrinsicsForSize(): 45 degree field of view."""

    def __init__(self, size):
        self.position = np.array([0.0, -0.25, 0.5])
        forward = np.array([0.0, 0.15, 0.0]) - self.position
        self.forward = forward / np.linalg.norm(forward)
        right = np.cross(self.forward, [0.0, 0.0, 1.0])
        self.right = right / np.linalg.norm(right)
        self.down = np.cross(self.forward, self.right)
        self.f = size / (2 * math.tan(math.radians(45) / 2))
        self.c = (size - 1) / 2

    def to_table(self, u, v, height):
        """The point at `height` above the table that pixel (u, v) sees."""
        ray = self.right * (u - self.c) / self.f + self.down * (v - self.c) / self.f + self.forward
        t = (height - self.position[2]) / ray[2]
        return self.position + t * ray


def colour_mask(image, rgb, tolerance=0.35):
    """Pixels whose chromaticity is close to `rgb`'s (shading changes brightness, not hue)."""
    pixels = image.astype(np.float32) + 1
    chroma = pixels / pixels.sum(axis=2, keepdims=True)
    target = np.array(rgb) + 0.004
    target = target / target.sum()
    close = np.abs(chroma - target).sum(axis=2) < tolerance * 0.25
    bright = image.max(axis=2) > 60
    return close & bright


def centroid(mask):
    v, u = np.nonzero(mask)
    return (u.mean(), v.mean(), len(u)) if len(u) else None


class ColourPolicy:
    def __init__(self, episode, noise, size_hint=None):
        self.rng = np.random.default_rng(episode.seed)
        self.noise = noise
        words = episode.instruction.split()
        self.colour = next((w for w in words if w in BLOCK_RGB), "red")
        self.camera = None
        self.z = None  # tool point height once known
        self.xy = None  # tool point position (dead reckoning + arm detection)
        self.gripper = 0.0
        self.holding = False
        self.goal = None
        self.block = None

    def see(self, image):
        """Block, goal and arm positions on the table (None when not visible)."""
        table = np.median(image.reshape(-1, 3), axis=0)
        green = ((image[..., 1].astype(int) - image[..., 0] > 35) &
                 (image[..., 1].astype(int) - image[..., 2] > 35))
        block_mask = colour_mask(image, BLOCK_RGB[self.colour])
        if self.colour == "white":
            block_mask = (image.min(axis=2) > table.max() + 40)
        block = centroid(block_mask & ~green)
        goal = centroid(green)
        diff = np.abs(image.astype(int) - table).sum(axis=2)
        saturation = image.max(axis=2).astype(int) - image.min(axis=2)
        arm = (diff > 30) & (image.mean(axis=2) > 70) & (saturation < 35) & ~block_mask
        # The goal's dark rim and JPEG ringing around it are not the arm.
        near_green = np.zeros_like(green)
        gv, gu = np.nonzero(green)
        if len(gu):
            v0, v1 = max(gv.min() - 2, 0), gv.max() + 3
            u0, u1 = max(gu.min() - 2, 0), gu.max() + 3
            near_green[v0:v1, u0:u1] = True
        arm &= ~near_green
        labels, count = ndimage.label(arm)
        if count > 1:  # the arm is the largest blob; specks of JPEG ringing are not
            sizes = ndimage.sum(arm, labels, range(1, count + 1))
            arm = labels == (1 + int(np.argmax(sizes)))
        return block, goal, arm

    def arm_position(self, arm):
        """The tool point from the arm's lowest rows (palm and fingers), seen at the palm's
        height; the offset is the mean error measured in the simulator."""
        rows = np.nonzero(arm.sum(axis=1) >= 2)[0]
        if len(rows) == 0 or self.z is None:
            return None
        top = max(rows.max() - 5, 0)
        v, u = np.nonzero(arm[top:rows.max() + 1])
        point = self.camera.to_table(u.mean(), top + v.mean(), self.z + PALM_CENTRE)
        return point[:2] + np.array([0.0, 0.006])

    def act(self, obs):
        if self.camera is None:
            self.camera = Camera(obs.width)
        block, goal, arm = self.see(obs.image)
        if goal is not None and goal[2] >= 6:
            self.goal = self.camera.to_table(goal[0], goal[1], 0.0)[:2]
        if block is not None and block[2] >= 4:
            seen_block = self.camera.to_table(block[0], block[1], BLOCK_HALF)[:2]
            if not self.holding:
                self.block = seen_block
            elif self.block is not None and np.linalg.norm(seen_block - self.block) > 0.05:
                self.holding = False  # the grasp missed: the block stayed behind
                self.block = seen_block
        if obs.step < DESCENT_STEPS:
            action = np.zeros(7)
            action[2] = -MAX_STEP
            return self.send(action)
        if self.z is None:
            self.z = EE_MIN[2]
        seen = self.arm_position(arm)
        if seen is not None and self.xy is None:
            self.xy = seen
        elif seen is not None and not self.holding:
            self.xy = 0.5 * self.xy + 0.5 * seen
        if self.xy is None or self.block is None or self.goal is None:
            action = np.zeros(7)
            action[2] = MAX_STEP  # lift and look again
            return self.send(action)
        return self.send(self.pick_and_place())

    def move_towards(self, target_xy, target_z, gripper):
        return np.array([target_xy[0] - self.xy[0], target_xy[1] - self.xy[1], target_z - self.z,
                         0.0, 0.0, 0.0, gripper])

    def pick_and_place(self):
        """policies.cc's PickAndPlace on the estimated state."""
        if not self.holding:
            distance = np.linalg.norm(self.block - self.xy)
            if distance > 0.036 and self.z < 2 * BLOCK_HALF + 0.01:
                return self.move_towards(self.xy, HOVER_Z, 0.0)
            if distance > 0.012:
                return self.move_towards(self.block, HOVER_Z, 0.0)
            lowered = self.z <= GRASP_Z + 0.004
            close = lowered and self.gripper < 0.5
            return self.move_towards(self.block, GRASP_Z, 1.0 if close else 0.0)
        target = self.xy + self.goal - self.block
        return self.move_towards(target, CARRY_Z, 1.0)

    def send(self, action):
        action = np.array(action, dtype=float)
        if self.noise > 0:
            action += self.rng.normal(0.0, 1.0, 7) * self.noise * np.array(
                [MAX_STEP] * 3 + [MAX_ROT] * 3 + [1.0])
        action[:3] = np.clip(action[:3], -MAX_STEP, MAX_STEP)
        action[3:6] = np.clip(action[3:6], -MAX_ROT, MAX_ROT)
        action[6] = min(max(action[6], 0.0), 1.0)
        self.track(action)
        return action

    def track(self, a):
        """Dead reckoning with StepScene's rules (scene.cc)."""
        if self.z is not None:
            self.z = float(np.clip(self.z + a[2], EE_MIN[2], EE_MAX[2]))
        if self.xy is not None:
            self.xy = np.clip(self.xy + a[:2], EE_MIN[:2], EE_MAX[:2])
        closing = a[6] >= 0.5 and self.gripper < 0.5
        if self.holding and a[6] < 0.5:
            self.holding = False
        elif closing and self.xy is not None and self.block is not None and self.z is not None:
            self.holding = (np.linalg.norm(self.xy - self.block) < 0.02 and
                            self.z < 2 * BLOCK_HALF - 0.01)
        if self.holding and self.block is not None:
            self.block = self.block + a[:2]
        self.gripper = a[6]


class RandomPolicy:
    """wm-gen-tabletop's `random` policy: a random walk with a sticky gripper."""

    def __init__(self, episode):
        self.rng = np.random.default_rng(episode.seed)
        self.closed = False

    def act(self, obs):
        a = np.concatenate([self.rng.normal(0, 0.02, 3), self.rng.normal(0, 0.08, 3), [0.0]])
        if self.rng.uniform() < 0.2:
            self.closed = not self.closed
        a[6] = 1.0 if self.closed else 0.0
        return np.clip(a, [-MAX_STEP] * 3 + [-MAX_ROT] * 3 + [0], [MAX_STEP] * 3 + [MAX_ROT] * 3 + [1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--noise", type=float, default=0.0, help="action noise SIGMA (see above)")
    parser.add_argument("--random", action="store_true", help="a random walk instead")
    args = parser.parse_args()
    if args.random:
        wmpolicy.serve(RandomPolicy, name="tabletop_random")
    else:
        wmpolicy.serve(lambda episode: ColourPolicy(episode, args.noise),
                       name="tabletop_colour", info={"noise": args.noise})


if __name__ == "__main__":
    main()
