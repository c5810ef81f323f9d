"""Renders the pictures of the hands (open and closed) and the two robots into ``assets/``.

MuJoCo's offscreen renderer needs an OpenGL context: this script uses EGL (``MUJOCO_GL=egl``)
unless ``MUJOCO_GL`` is set; ``osmesa`` is the software fallback.

Usage: ``python scripts/render_robots.py [--size 480]``
"""

from __future__ import annotations

import dataclasses
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from symjax import hands, robots  # noqa: E402
from symjax._atomic import atomic_write_bytes  # noqa: E402
from symjax.cli.common import PresetArgs, parse  # noqa: E402
from symjax.resources import asset_dir  # noqa: E402


def _save(path, rgb: np.ndarray) -> None:
    ok, buf = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise RuntimeError(f"cannot encode {path}")
    atomic_write_bytes(path, buf.tobytes())
    print(path)


def _with_light(spec: mujoco.MjSpec) -> mujoco.MjModel:
    spec.worldbody.add_light(pos=[0.3, -0.3, 1.0], dir=[-0.3, 0.3, -1.0], diffuse=[0.8] * 3)
    spec.worldbody.add_light(pos=[-0.3, 0.3, 1.0], dir=[0.3, -0.3, -1.0], diffuse=[0.4] * 3)
    spec.visual.headlight.ambient = [0.3, 0.3, 0.3]
    spec.visual.global_.offwidth = 1024
    spec.visual.global_.offheight = 1024
    return spec.compile()


def _camera(lookat, distance, azimuth, elevation) -> mujoco.MjvCamera:
    cam = mujoco.MjvCamera()
    cam.lookat[:] = lookat
    cam.distance, cam.azimuth, cam.elevation = distance, azimuth, elevation
    return cam


def render_hand(name: str, size: int) -> None:
    h = hands.load(name)
    m = _with_light(h.spec())
    d = mujoco.MjData(m)
    r = mujoco.Renderer(m, size, size)
    cam = _camera(h.tcp_pos * [1, 1, 0.7], 0.38, 135, -25)
    p = h.preshape_index("open")
    for state in ("open", "closed"):
        mujoco.mj_resetData(m, d)
        d.qpos[:] = h.preshape_qpos[p]
        d.ctrl[:] = h.preshape_ctrl[p] if state == "open" else np.asarray(h.closed_ctrl(p))
        for _ in range(0 if state == "open" else 1500):
            mujoco.mj_step(m, d)
        mujoco.mj_forward(m, d)
        r.update_scene(d, cam)
        _save(asset_dir() / "hands" / name / f"{state}.png", r.render())


def render_robot(name: str, size: int) -> None:
    rb = robots.load(name)
    spec = rb.spec()
    spec.visual.global_.offwidth = 1024
    spec.visual.global_.offheight = 1024
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    r = mujoco.Renderer(m, size, int(size * 4 / 3))
    r.update_scene(d, _camera([0.4, 0.0, 0.8], 2.6, 120, -20))
    _save(asset_dir() / "robots" / name / "robot.png", r.render())
    r.update_scene(d, rb.camera)
    _save(asset_dir() / "robots" / name / "head_camera.png", r.render())


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    size: int = 480
    """Picture size, pixels."""


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "render_robots.py", __doc__)
    for name in hands.HAND_NAMES:
        render_hand(name, args.size)
    for name in robots.ROBOT_NAMES:
        render_robot(name, args.size)


if __name__ == "__main__":
    sys.exit(main())
