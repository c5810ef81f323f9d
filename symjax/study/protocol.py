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
        meshes: ``{"C": mesh or error, "P": mesh or error}`` (world frame); ``T`` is the truth.
        cfg: The study's config.

    Returns:
        ``{"view", "dataset", "object", "orientation_deg", "seconds", "hands": {hand: {mesh:
        {"planned", "predicted", "truth", "error"}}}}``: per planning mesh the number of
        candidates planned, and per top grasp its predicted success (on its own mesh) and
        its success on the truth.
    """
    from symjax import grasp, hands
    from symjax.decompose import decompose
    from symjax.grasp.candidate_set import Candidates

    t0 = time.perf_counter()
    table = view.observation.table
    meshes = {"T": view.gt_mesh, **meshes}
    decs: dict[str, Any] = {}
    for k in PLANNING_MESHES:
        m = meshes.get(k)
        if m is None or isinstance(m, (str, SymjaxError)):
            decs[k] = m if m is not None else "no mesh"
            continue
        try:
            decs[k] = decompose(m, cfg.decompose)
        except SymjaxError as e:
            decs[k] = one_line(e, 240)
    if isinstance(decs["T"], str):
        raise SymjaxError(f"{view.name}: the true mesh cannot be decomposed: {decs['T']}")
    rec: dict[str, Any] = {"view": view.name, "dataset": view.dataset, "object": view.object_name,
                           "orientation_deg": float(view.orientation_deg), "hands": {}}  # fmt: skip
    for hand_name, gen in cfg.hands:
        hand = hands.load(hand_name)
        truth = grasp.build_scene(decs["T"], hand, cfg.simulation, table=table)
        rows: dict[str, Any] = {}
        tops = []
        for k in PLANNING_MESHES:
            if isinstance(decs[k], str):
                rows[k] = {"planned": 0, "predicted": [], "error": str(decs[k])}
                continue
            try:
                gp = grasp.plan(meshes[k], hand, gen, hulls=decs[k], table=table,
                                scene=truth if k == "T" else None, candidates=cfg.candidates,
                                simulation=cfg.simulation, execution=cfg.execution,
                                backend=cfg.backend)  # fmt: skip
            except SymjaxError as e:
                rows[k] = {"planned": 0, "predicted": [], "error": one_line(e, 240)}
                continue
            n = min(cfg.top, len(gp))
            rows[k] = {
                "planned": len(gp),
                "error": None,
                "predicted": [bool(x) for x in np.asarray(gp.outcomes.success)[:n]],
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
        for k in PLANNING_MESHES:
            rows[k].setdefault("truth", [])
        rec["hands"][hand_name] = rows
    rec["seconds"] = round(time.perf_counter() - t0, 3)
    return rec
