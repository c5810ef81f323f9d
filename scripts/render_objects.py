"""Renders the benchmark's 12 objects (canonical frame, 0 deg pose) into one picture.

Each object is drawn with matplotlib's 3-D axes as seen by the benchmark's stereo head at 0 deg
(looking along +y from 40 deg above the table), shaded by a fixed light, with its verified
symmetry plane(s) as red lines on the table (a red circle marks a rotational axis).

Usage: ``python scripts/render_objects.py [--out symjax/datasets/objects.png] [--cache DIR]``
"""

from __future__ import annotations

import dataclasses
import io
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from symjax._atomic import atomic_write_bytes  # noqa: E402
from symjax.cli.common import PresetArgs, parse  # noqa: E402
from symjax.datasets import OBJECT_NAMES, load_dataset_object  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def draw(ax, obj) -> None:
    mesh = obj.mesh
    tris = np.asarray(mesh.triangles)
    light = np.array([0.3, -0.6, 0.75])
    light /= np.linalg.norm(light)
    shade = 0.35 + 0.65 * np.clip(np.asarray(mesh.face_normals) @ light, 0, 1)
    colors = np.clip(np.outer(shade, [0.55, 0.65, 0.85]), 0, 1)
    ax.add_collection3d(Poly3DCollection(tris, facecolors=colors, edgecolors="none"))
    lo, hi = mesh.bounds
    r = 0.5 * float(np.max(hi - lo)) * 1.05
    c = 0.5 * (lo + hi)
    sym = obj.symmetry
    if sym.kind == "planar":
        for n, o in sym.planes:
            n = np.asarray(n)
            d = np.array([-n[1], n[0], 0.0])
            p = n * o + d * float(d @ c)
            seg = np.stack([p - d * r, p + d * r])
            ax.plot(seg[:, 0], seg[:, 1], [0, 0], color="red", lw=1.5)
    elif sym.kind == "rotational":
        t = np.linspace(0, 2 * np.pi, 60)
        ax.plot(sym.axis_xy[0] + 0.01 * np.cos(t), sym.axis_xy[1] + 0.01 * np.sin(t), 0 * t, "r")
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(0, 2 * r)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=40, azim=-90)
    ax.set_axis_off()
    w, d, h = (obj.size * 100).round(1)
    ax.set_title(f"{obj.dataset}\n{w} x {d} x {h} cm, {sym.kind}", fontsize=8)


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    out: str = str(ROOT / "symjax" / "datasets" / "objects.png")
    """The picture."""
    cache: str | None = None
    """Preprocessed-object cache folder (None: $SYMJAX_CACHE, else ~/.cache/symjax)."""


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "render_objects.py", __doc__)
    fig = plt.figure(figsize=(12, 9))
    for i, name in enumerate(OBJECT_NAMES):
        ax = fig.add_subplot(3, 4, i + 1, projection="3d")
        draw(ax, load_dataset_object(name, cache_dir=args.cache))
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    atomic_write_bytes(args.out, buf.getvalue())
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
