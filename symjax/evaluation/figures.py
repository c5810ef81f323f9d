"""The paper's evaluation figures (Fig. 10-12) and a gallery of completions, as PNG files.

Every figure reads the flat rows of :func:`symjax.evaluation.run.rows_of` (deviation in mm,
centroid error as a fraction), so it can be redrawn from ``results.json`` alone; only the gallery
recomputes its few views.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from symjax._atomic import atomic_write_bytes

__all__ = ["COLORS", "gallery", "pick_gallery", "plot_centroid", "plot_deviation", "group_stats"]

#: Bar colours per method (Del grey as the baseline).
COLORS = {"Del": "0.55", "Mir5": "tab:blue", "Mir7": "tab:orange"}


def _save(fig, path: str | Path) -> Path:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


def group_stats(
    rows: Sequence[dict[str, Any]], key: str, value: str, methods: Sequence[str]
) -> tuple[list, dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Mean and standard deviation of ``value`` per group of ``key`` and method.

    Rows with a non-finite value (failed reconstruction, no ground truth) are left out.

    Returns:
        ``(groups, mean, std)``: sorted group labels; per method arrays (G,) (NaN when empty).
    """
    groups = sorted({r[key] for r in rows}, key=lambda g: (isinstance(g, str), g))
    mean, std = {}, {}
    for m in methods:
        mu, sd = [], []
        for g in groups:
            x = np.array([r[value] for r in rows if r["method"] == m and r[key] == g], float)
            x = x[np.isfinite(x)]
            mu.append(x.mean() if x.size else math.nan)
            sd.append(x.std() if x.size else math.nan)
        mean[m], std[m] = np.array(mu), np.array(sd)
    return groups, mean, std


def _bars(ax, groups, values, methods, err=None, fmt=str):
    w = 0.8 / len(methods)
    x = np.arange(len(groups))
    for j, m in enumerate(methods):
        ax.bar(
            x + (j - (len(methods) - 1) / 2) * w,
            values[m],
            w,
            yerr=None if err is None else err[m],
            color=COLORS.get(m),
            label=m,
            capsize=2,
            error_kw={"lw": 0.8},
        )
    ax.set_xticks(x, [fmt(g) for g in groups])
    ax.grid(axis="y", alpha=0.3)


def plot_deviation(
    rows: Sequence[dict[str, Any]], methods: Sequence[str], key: str, path: str | Path
) -> Path:
    """Fig. 10 (``key="orientation_deg"``) or Fig. 11 (``key="dataset"``): mesh deviation.

    Top: mean over the group's views of each view's mean deviation (mm; bars show the standard
    deviation over the views). Bottom: mean over the group's views of each view's deviation
    variance (mm^2).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by_object = key == "dataset"
    groups, mean, std = group_stats(rows, key, "dev_mean_mm", methods)
    _, var, _ = group_stats(rows, key, "dev_var_mm2", methods)
    fmt = (lambda g: str(g)) if by_object else (lambda g: f"{g:g}")
    fig, axes = plt.subplots(2, 1, figsize=(12 if by_object else 8, 7.5), sharex=True)
    _bars(axes[0], groups, mean, methods, std, fmt)
    axes[0].set_ylabel("mean deviation [mm]")
    axes[0].legend(ncol=len(methods))
    _bars(axes[1], groups, var, methods, None, fmt)
    axes[1].set_ylabel("deviation variance [mm$^2$]")
    if by_object:
        axes[1].tick_params(axis="x", labelrotation=60)
        for lab in axes[1].get_xticklabels():
            lab.set_horizontalalignment("right")
        axes[1].set_xlabel("data set")
        title = "Fig. 11: deviation from the ground truth per object (mean over orientations)"
    else:
        axes[1].set_xlabel("orientation [deg]")
        title = "Fig. 10: deviation from the ground truth per orientation (mean over objects)"
    axes[0].set_title(title)
    fig.tight_layout()
    return _save(fig, path)


def plot_centroid(rows: Sequence[dict[str, Any]], methods: Sequence[str], path: str | Path) -> Path:
    """Fig. 12: centroid error per orientation, % of the ground truth's oriented-box diagonal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pct = [{**r, "centroid_pct": 100.0 * r["centroid_error"]} for r in rows]
    groups, mean, std = group_stats(pct, "orientation_deg", "centroid_pct", methods)
    fig, ax = plt.subplots(figsize=(8, 4))
    _bars(ax, groups, mean, methods, std, lambda g: f"{g:g}")
    ax.set_xlabel("orientation [deg]")
    ax.set_ylabel("centroid error [% of box diagonal]")
    ax.set_title("Fig. 12: centroid error per orientation (mean over objects)")
    ax.legend(ncol=len(methods))
    fig.tight_layout()
    return _save(fig, path)


def plot_confidence(records: Sequence[Any], path: str | Path) -> Path | None:
    """Plane confidence against plane error (the larger of deg and mm, log scale), one dot per
    view with a known plane, coloured by its completion; None when no view has both."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = [
        (max(p.plane_error_deg, p.plane_error_mm), p.confidence, p.completion)
        for p in (r.symmetry for r in records)
        if p is not None and math.isfinite(p.plane_error_deg) and math.isfinite(p.confidence)
    ]
    if not pts:
        return None
    fig, ax = plt.subplots(figsize=(7, 4))
    for kind, colour in (("mirror", "tab:blue"), ("revolution", "tab:green"),
                         ("fallback", "tab:red")):  # fmt: skip
        sel = [(e, c) for e, c, k in pts if k == kind]
        if sel:
            e, c = np.array(sel).T
            ax.scatter(np.maximum(e, 0.05), c, s=14, c=colour, label=kind)
    ax.axvline(10.0, color="grey", ls="--", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("plane error: max(deg, mm)  (right of the line: bad plane)")
    ax.set_ylabel("plane confidence")
    ax.set_title("Confidence of the mirror plane against its error")
    ax.legend()
    fig.tight_layout()
    return _save(fig, path)


def pick_gallery(records: Sequence[Any], n: int) -> list[tuple[str, str]]:
    """Views for the gallery: ``n - 1`` typical ones of distinct data sets, then the worst.

    With ground truth, the typical views spread over the Mir7 deviation quantiles and the
    failure case is the view with the largest Mir7 (else Mir5) deviation; without it, the
    failure case is the view whose best plane has the highest vote (most visibility violation).

    Returns:
        ``[(view name, caption)]``.
    """
    if n <= 0 or not records:
        return []
    method = next((m for m in ("Mir7", "Mir5") if m in records[0].methods), None)
    if method is None:
        return []

    def score(rec):
        dev = rec.result(method).dev_mean_mm
        if math.isfinite(dev):
            return dev, f"{method} {dev:.1f} mm"
        vote = None if rec.symmetry is None else rec.symmetry.vote
        return (
            vote if vote is not None else math.inf
        ), f"vote {vote if vote is not None else 0:.3g}"

    ok = [r for r in records if r.result(method).ok]
    if not ok:
        return []
    ok.sort(key=lambda r: score(r)[0])
    worst = ok[-1]
    picks: list[tuple[str, str]] = []
    seen = {worst.dataset}
    rest = ok[:-1]
    for q in np.linspace(0.1, 0.7, max(n - 1, 1)) if n > 1 else []:
        if not rest:
            break
        start = int(q * (len(rest) - 1))
        # The nearest view of a data set not shown yet, searching up then down from the quantile.
        order = list(range(start, len(rest))) + list(range(start - 1, -1, -1))
        cand = next((rest[i] for i in order if rest[i].dataset not in seen), None)
        if cand is None:
            # Few data sets (a small subset): show another view of one already shown.
            shown = {n for n, _ in picks} | {worst.view}
            cand = next((rest[i] for i in order if rest[i].view not in shown), None)
        if cand is None:
            continue
        seen.add(cand.dataset)
        picks.append((cand.view, score(cand)[1]))
    picks.append((worst.view, "failure case: " + score(worst)[1]))
    return picks


def _for_drawing(mesh, faces: int = 12000):
    """The mesh decimated for a thumbnail: matplotlib draws 60k polygons for seconds, and a
    panel 3 inches wide shows no more than this many."""
    if len(mesh.faces) <= faces:
        return mesh
    try:
        return mesh.simplify_quadric_decimation(face_count=faces)
    except (ImportError, ValueError):
        return mesh


def gallery(views: Sequence, captions: Sequence[str], config, path: str | Path) -> Path:
    """Partial cloud, completed cloud and Mir7 mesh of a few views (recomputed here).

    Args:
        views: The :class:`~symjax.datasets.View` objects to show, one row each.
        captions: One caption per view.
        config: The :class:`~symjax.evaluation.EvalConfig` (symmetry and normals settings).
        path: Output PNG.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from symjax.completion import choose_completion
    from symjax.errors import SymjaxError
    from symjax.evaluation.stages import poisson_meshes
    from symjax.symmetry import search_batch

    res = search_batch([v.observation for v in views], config.symmetry, config.execution)
    # The evaluation's own batched calls (same buckets, same width): no new compilation, and
    # the meshes it measured, cut at the table.
    ops: list = []
    added: list = []  # the points the completion added (mirrored or revolved)
    for i, v in enumerate(views):
        try:
            c = choose_completion(
                res[i], v.observation, config.completion, config.normals, config.symmetry
            )
            ops.append(c.oriented if c.mesh is None else c.mesh)
            added.append(
                (c.kind, np.zeros((0, 3)) if c.oriented is None else c.oriented.points[
                    c.oriented.mirrored])
            )  # fmt: skip
        except SymjaxError:
            ops.append(None)
            added.append(("mirror", res[i].mirrored_cloud()))
    built = poisson_meshes(ops, 7, config, [v.observation.table for v in views])
    meshes = [None if isinstance(m, str) else _for_drawing(m) for m in built]
    fig = plt.figure(figsize=(11, 3.4 * len(views)))
    light = np.array([0.3, -0.6, 0.75])
    light /= np.linalg.norm(light)
    rng = np.random.default_rng(0)
    for row, (v, cap) in enumerate(zip(views, captions, strict=True)):
        obs = v.points
        kind, mir = added[row]
        sel_o = rng.permutation(len(obs))[:3000]
        sel_m = rng.permutation(len(mir))[:3000]
        mesh = meshes[row]
        allp = np.concatenate([obs, mir]) if len(mir) else obs
        lo, hi = np.percentile(allp, 1, axis=0), np.percentile(allp, 99, axis=0)
        centre, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-3) * 1.1
        cam = np.asarray(v.camera.position) - centre
        elev = math.degrees(math.atan2(cam[2], math.hypot(cam[0], cam[1])))
        # Seen from the camera the mirrored half hides behind the observed one: turn 50 deg.
        azim = math.degrees(math.atan2(cam[1], cam[0])) + 50.0
        for col in range(3):
            ax = fig.add_subplot(len(views), 3, 3 * row + col + 1, projection="3d")
            if col == 0:
                p = obs[sel_o] - centre
                ax.scatter(p[:, 0], p[:, 1], p[:, 2], s=0.4, c="tab:blue")
                ax.set_title(f"{v.name}: partial cloud", fontsize=9)
            elif col == 1:
                p, q = obs[sel_o] - centre, mir[sel_m] - centre
                ax.scatter(p[:, 0], p[:, 1], p[:, 2], s=0.4, c="tab:blue")
                ax.scatter(q[:, 0], q[:, 1], q[:, 2], s=0.4, c="tab:orange")
                what = {"mirror": "mirrored", "revolution": "revolved"}.get(kind, "none: hull")
                ax.set_title(f"observed (blue) + {what} (orange)", fontsize=9)
            else:
                if mesh is not None:
                    tri = np.asarray(mesh.triangles) - centre
                    shade = 0.35 + 0.6 * np.clip(np.asarray(mesh.face_normals) @ light, 0, 1)
                    pc = Poly3DCollection(tri, linewidths=0)
                    pc.set_facecolor(np.clip(shade, 0, 1)[:, None] * np.array([0.8, 0.8, 0.85]))
                    ax.add_collection3d(pc)
                ax.set_title(f"Mir7 mesh ({cap})", fontsize=9)
            ax.set_xlim(-half, half)
            ax.set_ylim(-half, half)
            ax.set_zlim(-half, half)
            ax.set_box_aspect((1, 1, 1))
            ax.view_init(elev=elev, azim=azim)
            ax.set_axis_off()
    fig.suptitle("Completion: partial view, completed cloud, Poisson depth 7 (or the hull)")
    fig.tight_layout()
    return _save(fig, path)
