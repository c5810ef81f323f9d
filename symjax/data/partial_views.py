"""Partial views of a data-set object: rendered with the stereo noise model, completed by the
symmetry search and Mir7 (all views of the object in one batched search and one Poisson solve),
and, per hand, the grasps planned on each completion rolled out on the true object.

A view's world frame is its table's: z up, the table at z = 0, the object at ``T_world_object``
(a turn about z and a shift on the table). Grasp poses are stored in the object frame, like the
shard's own grasps.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax.errors import SymjaxError, one_line

__all__ = ["complete_views", "view_grasps"]


def _confidence(res: Any) -> float:
    """Mean visibility plausibility (Eq. 3) of the mirrored points under the chosen plane: 1
    when every mirrored point lies where the camera saw nothing in front of it."""
    valid = np.asarray(res.valid, bool)
    if not valid.any():
        return 0.0
    return float(np.asarray(res.plausibility)[valid].mean())


def complete_views(obj: Any, n_views: int, cfg: Any, seed: int) -> list[dict[str, Any]]:
    """``n_views`` views of ``obj`` (orientations ``360 k / n_views`` deg) and their completions.

    Returns:
        Per view ``{"view", "mesh", "plane", "cloud", "confidence", "error"}``: the
        :class:`symjax.datasets.View`, the cut Mir7 mesh (world frame) or None, the plane
        ``(nx, ny, nz, offset)``, the completed cloud (M, 3) and the confidence; ``error`` says
        why a view has no completion.
    """
    from symjax.cycle.shapes import completed_meshes
    from symjax.datasets import render_view
    from symjax.symmetry import search_batch

    views = [render_view(obj, 360.0 * k / n_views, seed) for k in range(n_views)]
    obs = [v.observation for v in views]
    out = [{"view": v, "mesh": None, "plane": np.full(4, np.nan), "cloud": np.zeros((0, 3)),
            "confidence": 0.0, "error": None} for v in views]  # fmt: skip
    try:
        res = search_batch(obs, cfg.symmetry, cfg.execution)
    except SymjaxError as e:
        for o in out:
            o["error"] = one_line(e, 240)
        return out
    meshes = completed_meshes(obs, [o.table for o in obs], cfg, search=res)
    for i, (o, m) in enumerate(zip(out, meshes, strict=True)):
        if not bool(res.ok[i]):
            o["error"] = one_line(res.errors[i], 240) if res.errors else "no plane"
            continue
        r = res[i]
        o["plane"] = np.r_[np.asarray(r.normal, float), float(r.offset)]
        o["cloud"] = r.completed_cloud().astype(np.float32)
        o["confidence"] = _confidence(r)
        if isinstance(m, SymjaxError):
            o["error"] = one_line(m, 240)
        else:
            o["mesh"] = m
    return out


def view_grasps(completed: dict[str, Any], hand: Any, true_hulls: Any, cfg: Any,
                top: int, generator: str) -> dict[str, Any]:  # fmt: skip
    """The grasps planned on one view's completion, the best ``top`` rolled out on the truth.

    Args:
        completed: One entry of :func:`complete_views`.
        hand: The :class:`symjax.hands.Hand`.
        true_hulls: The true object's :class:`~symjax.decompose.Decomposition`, object frame.
        cfg: The :class:`~symjax.data.GenerateConfig`.
        top: Grasps taken from the plan, best first.
        generator: The hand's candidate generator.

    Returns:
        ``{"candidates", "predicted", "truth", "tcp_world", "error"}``; ``candidates`` is None
        when nothing was planned.
    """
    from symjax import grasp
    from symjax.decompose import decompose

    rec: dict[str, Any] = {"candidates": None, "predicted": np.zeros(0, bool),
                           "truth": np.zeros(0, bool), "error": completed["error"]}  # fmt: skip
    if completed["mesh"] is None:
        return rec
    view = completed["view"]
    table = view.observation.table
    try:
        hulls = decompose(completed["mesh"], cfg.decompose)
        gp = grasp.plan(completed["mesh"], hand, generator, hulls=hulls, table=table,
                        candidates=cfg.candidates, simulation=cfg.simulation,
                        execution=cfg.execution, backend=cfg.generate.backend)  # fmt: skip
    except SymjaxError as e:
        rec["error"] = one_line(e, 240)
        return rec
    n = min(top, len(gp))
    cands = gp.candidates.take(np.arange(n))
    truth = grasp.build_scene(true_hulls.transformed(np.asarray(view.gt_pose)), hand,
                              cfg.simulation, table=table)  # fmt: skip
    out = grasp.simulate(None, cands, hand, scene=truth, backend=cfg.generate.backend,
                         execution=cfg.execution)  # fmt: skip
    rec.update(candidates=cands, predicted=np.asarray(gp.outcomes.success[:n], bool),
               truth=np.asarray(out.success, bool), outcomes=out, error=None)  # fmt: skip
    return rec
