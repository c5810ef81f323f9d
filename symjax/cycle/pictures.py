"""The report's picture of a cycle: the head camera's frame with the object hypotheses, then key
frames of the executed pick in C MuJoCo with each predicted shape drawn over the true objects as
points on its surface (pre-grasp, grasp, lift, release).

Needs OpenGL for MuJoCo's offscreen renderer (``MUJOCO_GL=egl`` or ``osmesa``, set before
MuJoCo is imported; the ``symjax clear-table`` command sets ``egl`` unless it is set);
without it the picture is the head camera's frame alone (the project's ray caster made it).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax._atomic import atomic_write_bytes

__all__ = ["cycle_picture", "masks_image"]

_COLOURS = np.array([(230, 25, 75), (60, 180, 75), (255, 225, 25), (0, 130, 200),
                     (245, 130, 48), (145, 30, 180), (70, 240, 240)], np.uint8)  # fmt: skip


def masks_image(depth: np.ndarray, labels: np.ndarray, height: int) -> np.ndarray:
    """RGB (height, W', 3) of a depth image, grey by depth, hypotheses in colour, cropped to
    the objects with a margin (they fill a small part of the head camera's frame)."""
    import cv2

    valid = depth > 0
    grey = np.zeros(depth.shape, np.uint8)
    if valid.any():
        lo, hi = np.percentile(depth[valid], (1, 99))
        grey[valid] = np.clip(255 - 200 * (depth[valid] - lo) / max(hi - lo, 1e-6), 30, 255)
    img = np.repeat(grey[..., None], 3, axis=2)
    obj = labels >= 0
    img[obj] = (0.4 * img[obj] + 0.6 * _COLOURS[labels[obj] % len(_COLOURS)]).astype(np.uint8)
    if obj.any():
        rows, cols = np.flatnonzero(obj.any(axis=1)), np.flatnonzero(obj.any(axis=0))
        pad = 40
        r0, r1 = max(rows[0] - pad, 0), min(rows[-1] + pad, depth.shape[0])
        c0, c1 = max(cols[0] - pad, 0), min(cols[-1] + pad, depth.shape[1])
        # Keep the tile 4:3 so that the row of tiles lines up.
        w = max(c1 - c0, int((r1 - r0) * 4 / 3))
        h = int(w * 3 / 4)
        cr, cc = (r0 + r1) // 2, (c0 + c1) // 2
        r0, c0 = max(cr - h // 2, 0), max(cc - w // 2, 0)
        img = img[r0 : r0 + h, c0 : c0 + w]
    w = int(round(img.shape[1] * height / img.shape[0]))
    return cv2.resize(img, (w, height), interpolation=cv2.INTER_NEAREST)


def _key_frames(round_: dict, height: int) -> list[np.ndarray]:
    import cv2
    import mujoco

    from symjax.motion import replay_model

    m = replay_model(round_["truth"])
    m.vis.global_.offwidth, m.vis.global_.offheight = 1024, 1024
    d = mujoco.MjData(m)
    w = int(height * 4 / 3)
    r = mujoco.Renderer(m, height, w)
    cam = mujoco.MjvCamera()
    # From the far side of the table, looking back at the arm over the target.
    target = round_["plan"].grasp.grasp[0]
    cam.distance, cam.azimuth, cam.elevation = 1.0, 180.0, -35.0
    points = []
    for h, mesh in enumerate(round_["meshes"]):
        if hasattr(mesh, "sample"):
            rng = np.random.default_rng(h)
            idx = rng.choice(len(mesh.vertices), min(800, len(mesh.vertices)), replace=False)
            points.append((np.asarray(mesh.vertices)[idx], _COLOURS[h % len(_COLOURS)] / 255))
    tiles = []
    names = ("pre-grasp", "grasp", "lift", "release")
    for name, q in zip(names, round_["replay"].snapshots, strict=False):
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        cam.lookat[:] = round_["truth"].robot.dropoff if name == "release" else target
        r.update_scene(d, cam)
        if name in ("pre-grasp", "grasp"):  # the shapes as planned, before anything moved
            for pts, rgb in points:
                for p in pts:
                    if r.scene.ngeom >= r.scene.maxgeom:
                        break
                    g = r.scene.geoms[r.scene.ngeom]
                    mujoco.mjv_initGeom(
                        g,
                        mujoco.mjtGeom.mjGEOM_SPHERE,
                        np.array([0.003, 0, 0]),
                        p,
                        np.eye(3).ravel(),
                        np.r_[rgb, 0.9].astype(np.float32),
                    )
                    r.scene.ngeom += 1
        img = np.ascontiguousarray(r.render())
        cv2.putText(img, name, (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2)
        tiles.append(img)
    r.close()
    return tiles


def cycle_picture(report: Any, path: Any, height: int = 300) -> Any:
    """Writes the picture of the first frame and executed pick of ``report`` (a PNG).

    ``report`` must come from ``clear_table(..., pictures=True)``.
    """
    import cv2

    from symjax.errors import InvalidInputError

    if not report.extras or "first" not in report.extras:
        raise InvalidInputError("the report has no pictures: run clear_table(..., pictures=True)")
    frame = report.extras["first"]
    tiles = [masks_image(frame["depth"], frame["segmentation"].labels, height)]
    rounds = report.extras["rounds"]
    try:
        if not rounds:
            raise LookupError("nothing was executed")
        tiles += _key_frames(rounds[0], height)
    except Exception as e:  # noqa: BLE001 - no OpenGL here: the frame alone
        note = str(e) if isinstance(e, LookupError) else f"no OpenGL: {type(e).__name__}"
        cv2.putText(tiles[0], note[:40], (8, height - 12),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1)  # fmt: skip
    row = np.concatenate(tiles, axis=1)
    ok, buf = cv2.imencode(".png", cv2.cvtColor(row, cv2.COLOR_RGB2BGR))
    return atomic_write_bytes(path, buf.tobytes())
