"""Key frames of a planned and replayed pick for the README (``assets/robots/<robot>/pick.png``).

A box on the table behind a post: the arm transits around the post (RRT-Connect), approaches
along a straight line, closes, lifts 10 cm, carries the box to the drop-off beside the table,
releases it and returns home. Frames are the replay in C MuJoCo at the end of each segment.
MuJoCo's offscreen renderer needs OpenGL: EGL (``MUJOCO_GL=egl``) unless ``MUJOCO_GL`` is set.

Usage: ``python scripts/render_motion.py [--robot uji] [--size 360]``
"""

from __future__ import annotations

import dataclasses
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import trimesh  # noqa: E402

from symjax import motion  # noqa: E402
from symjax._atomic import atomic_write_bytes  # noqa: E402
from symjax.cli.common import PresetArgs, parse  # noqa: E402
from symjax.resources import asset_dir  # noqa: E402


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    robot: str = "uji"
    """Robot: kth or uji."""
    size: int = 360
    """Height of each frame, pixels."""


def _box(size, centre):
    b = trimesh.creation.box(size)
    b.apply_translation(centre)
    return [(np.asarray(b.vertices), np.asarray(b.faces))]


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "render_motion.py", __doc__)
    scene = motion.PlanningScene(
        args.robot,
        {"box": _box((0.05, 0.05, 0.12), (0.75, -0.3, 0.81)),
         "post": _box((0.04, 0.04, 0.4), (0.7, -0.15, 0.95))},
        target="box",
    )  # fmt: skip
    R = np.diag([1.0, -1.0, -1.0])
    g = motion.GraspPose((np.array([0.75, -0.3, 0.93]), R), (np.array([0.75, -0.3, 0.85]), R), 1)
    plan = motion.plan_arm(scene, g)
    if not plan.ok:
        print(plan.summary())
        return 1
    times = plan.segment_times()
    keys = ["transit", "approach", "close", "lift", "transfer", "release", "return"]
    shots_t = [times[k][1] for k in keys]
    rep = motion.replay(plan, scene, snapshots=tuple(shots_t))
    m = motion.replay_model(scene)
    m.vis.global_.offwidth, m.vis.global_.offheight = 1024, 1024
    d = mujoco.MjData(m)
    w = int(args.size * 4 / 3)
    r = mujoco.Renderer(m, args.size, w)
    cam = mujoco.MjvCamera()
    cam.lookat[:] = (0.4, 0.0, 0.9)
    cam.distance, cam.azimuth, cam.elevation = 2.4, 215, -22
    tiles = []
    for name, q in zip(keys, rep.snapshots, strict=True):
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        r.update_scene(d, cam)
        img = np.ascontiguousarray(r.render())
        cv2.putText(img, name, (10, 28), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (255, 255, 255), 2)
        tiles.append(img)
    tiles.append(np.zeros_like(tiles[0]))
    grid = np.concatenate([np.concatenate(tiles[:4], 1), np.concatenate(tiles[4:], 1)], 0)
    ok, buf = cv2.imencode(".png", cv2.cvtColor(grid, cv2.COLOR_RGB2BGR))
    path = asset_dir() / "robots" / args.robot / "pick.png"
    atomic_write_bytes(path, buf.tobytes())
    print(path, plan.summary(), "collisions:", rep.collisions, "tcp error m:", rep.tcp_error)
    return 0


if __name__ == "__main__":
    sys.exit(main())
