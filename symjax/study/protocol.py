"""One view of the study: grasps planned on the true mesh (T), the completion (C) and the observed
points alone (P), each mesh's top grasps (ranked on that mesh) rolled out on the true object.

Every grasp is a hand pose and a pre-shape in the world frame, so the same candidates run in the
true object's scene unchanged; all of a view's top grasps go in one rollout batch per hand.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from symjax.errors import SymjaxError, one_line
from symjax.study.config import PLANNING_MESHES, StudyConfig

__all__ = ["study_view"]


def study_view(view: Any, meshes: dict[str, Any], cfg: StudyConfig) -> dict[str, Any]:
    """The study's record of one view.

    Args:
        view: A :class:`symjax.datasets.View` with its true mesh.
        meshes: ``{"C": mesh or error, "P": mesh or error}`` (world frame), and optionally
            ``"K"``: the completion's :class:`~symjax.completion.ShapeSet` (its first mesh is
            C's) or error; ``T`` is the truth.
        cfg: The study's config.

    Returns:
        ``{"view", "dataset", "object", "orientation_deg", "seconds", "hands": {hand: {mesh:
        {"planned", "predicted", "truth", "error"}}}}``: per planning mesh the number of
        candidates planned, and per top grasp its predicted success (on its own mesh; for
        ``K`` the weighted mean over the shapes) and its success on the truth; ``K`` also has
        ``"shapes"`` (kinds, weights and each shape's success of the top grasps) and ``"seconds"``
        (its extra planning time).
    """
    from symjax import grasp, hands
    from symjax.decompose import decompose
    from symjax.grasp.candidate_set import Candidates

    t0 = time.perf_counter()
    table = view.observation.table
    meshes = {"T": view.gt_mesh, **meshes}
    decs: dict[str, Any] = {}
    dec_s: dict[str, float] = {}
    for k in PLANNING_MESHES:
        m = meshes.get(k)
        if k not in meshes:
            continue
        if m is None or isinstance(m, (str, SymjaxError)):
            decs[k] = m if m is not None else "no mesh"
            continue
        t1 = time.perf_counter()
        try:
            if k != "K":
                decs[k] = decompose(m, cfg.decompose)
            else:  # the first shape is C's mesh: its decomposition is C's
                first = decs.get("C") if m.meshes[0] is meshes.get("C") else None
                first = decompose(m.meshes[0], cfg.decompose) if first is None else first
                if isinstance(first, str):
                    raise SymjaxError(first)
                decs[k] = [first] + [decompose(x, cfg.decompose) for x in m.meshes[1:]]
        except SymjaxError as e:
            decs[k] = one_line(e, 240)
        dec_s[k] = time.perf_counter() - t1
    if isinstance(decs["T"], str):
        raise SymjaxError(f"{view.name}: the true mesh cannot be decomposed: {decs['T']}")
    rec: dict[str, Any] = {"view": view.name, "dataset": view.dataset, "object": view.object_name,
                           "orientation_deg": float(view.orientation_deg), "hands": {}}  # fmt: skip
    for hand_name, gen in cfg.hands:
        hand = hands.load(hand_name)
        truth = grasp.build_scene(decs["T"], hand, cfg.simulation, table=table)
        rows: dict[str, Any] = {}
        tops = []
        for k in (k for k in PLANNING_MESHES if k in decs):
            if isinstance(decs[k], str):
                rows[k] = {"planned": 0, "predicted": [], "error": str(decs[k])}
                continue
            t1 = time.perf_counter()
            try:
                gp = grasp.plan(None if k == "K" else meshes[k], hand, gen, hulls=decs[k],
                                table=table, scene=truth if k == "T" else None,
                                candidates=cfg.candidates, simulation=cfg.simulation,
                                execution=cfg.execution, backend=cfg.backend,
                                shapes=meshes[k] if k == "K" else None,
                                robust=cfg.robust, robustness=cfg.robustness)  # fmt: skip
            except SymjaxError as e:
                rows[k] = {"planned": 0, "predicted": [], "error": one_line(e, 240)}
                continue
            n = min(cfg.top, len(gp))
            predicted = np.asarray(gp.outcomes.success, float)[:n] if gp.robust is None else (
                np.asarray(gp.robust, float)[:n])  # fmt: skip
            rows[k] = {"planned": len(gp), "error": None,
                       "predicted": [round(float(x), 4) for x in predicted]}  # fmt: skip
            # Planning time of this mesh: its decomposition and plan (the rollouts on the truth
            # are shared by all meshes).
            rows[k]["seconds"] = round(time.perf_counter() - t1 + dec_s[k], 3)
            rows[k]["decompose_seconds"] = round(dec_s[k], 3)
            if k == "K":
                # Each shape's rollout of the top grasps, so other criteria can be scored later.
                shape_success = np.zeros((len(meshes[k]), 0)) if gp.shape_success is None else (
                    np.asarray(gp.shape_success, float)[:, :n])  # fmt: skip
                rows[k]["shapes"] = {
                    "kinds": list(meshes[k].kinds),
                    "weights": [round(float(w), 4) for w in meshes[k].weights],
                    "success": [[int(x) for x in row] for row in shape_success],
                }
            tops.append((k, gp.candidates.take(np.arange(n))))
        if tops:
            out = grasp.simulate(
                None,
                Candidates.concatenate([c for _, c in tops]),
                hand,
                scene=truth,
                backend=cfg.backend,
                execution=cfg.execution,
            )
            ok = np.asarray(out.success, bool)
            i = 0
            for k, c in tops:
                rows[k]["truth"] = [bool(x) for x in ok[i : i + len(c)]]
                i += len(c)
        for k in rows:
            rows[k].setdefault("truth", [])
        rec["hands"][hand_name] = rows
    rec["seconds"] = round(time.perf_counter() - t0, 3)
    return rec
