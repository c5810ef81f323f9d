"""One object's shards: its true mesh decomposed once, its partial views completed once, then
per hand the candidates rolled out on the truth and written as one ACRONYM-keyed file."""

from __future__ import annotations

import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from symjax.data.acronym_file import write_shard
from symjax.data.candidate_mix import mixed_candidates, shard_rng_seed
from symjax.data.objects import ObjectEntry, load_entry
from symjax.data.spec import GENERATORS, HAND_GENERATOR

__all__ = ["mesh_file", "run_object", "shard_file"]

SIM_CHUNK = 512  # candidates per rollout call: the progress bar's step


def shard_file(out_dir: Path, obj: str, hand: str) -> Path:
    """``<out>/grasps/<hand>/<object>.h5``."""
    return Path(out_dir) / "grasps" / hand / f"{obj}.h5"


def mesh_file(obj: str) -> str:
    """The object's mesh, relative to the data set folder (ACRONYM's ``object/file``)."""
    return f"meshes/{obj}.obj"


def _tcp_poses(cands: Any, travel: np.ndarray) -> np.ndarray:
    """(N, 4, 4) TCP frames where the approach stopped: the start pose moved ``travel`` on."""
    a = np.asarray(cands.approach, np.float64)
    T = np.tile(np.eye(4), (len(a), 1, 1))
    T[:, :3, :3] = np.asarray(cands.frames(), np.float64)
    start = np.asarray(cands.start_positions(), np.float64)
    T[:, :3, 3] = start + np.asarray(travel, np.float64)[:, None] * a
    return T


def _object_props(mesh: Any, scene: Any, cfg: Any) -> dict[str, Any]:
    import trimesh

    density = float(cfg.simulation.object_density)
    solid = mesh if mesh.is_watertight and mesh.volume > 0 else mesh.convex_hull
    m = trimesh.Trimesh(solid.vertices, solid.faces, process=False)
    m.density = density
    scale = float(scene.mass) / max(float(m.mass), 1e-12)
    return {
        "object/com": np.asarray(scene.com, np.float64),
        "object/mass": float(scene.mass),
        "object/inertia": np.asarray(m.moment_inertia, np.float64) * scale,
        "object/density": density,
        "object/friction": float(cfg.simulation.object_friction),
        "object/volume": float(scene.mass) / density,
    }


def _view_data(k: int, vc: dict[str, Any], vg: dict[str, Any] | None) -> dict[str, Any]:
    v = vc["view"]
    cam = v.observation.camera
    pose = np.asarray(v.gt_pose, np.float64)
    p = f"views/{k}/"
    d = {
        p + "depth": np.asarray(v.depth, np.float32),
        p + "mask": np.asarray(v.observation.mask, bool),
        p + "camera/K": np.asarray(cam.K, np.float64),
        p + "camera/T_world_camera": np.asarray(cam.T_world_cam, np.float64),
        p + "T_world_object": pose,
        p + "points": np.asarray(v.observation.points, np.float32),
        p + "completion/plane": np.asarray(vc["plane"], np.float64),
        p + "completion/points": np.asarray(vc["cloud"], np.float32),
        p + "completion/confidence": float(vc["confidence"]),
    }
    T = np.zeros((0, 4, 4))
    pred = truth = np.zeros(0, bool)
    if vg is not None and vg["candidates"] is not None:
        world = _tcp_poses(vg["candidates"], np.asarray(vg["outcomes"].travel))
        T = np.linalg.inv(pose)[None] @ world
        pred, truth = vg["predicted"], vg["truth"]
    d.update({p + "grasps/transforms": T, p + "grasps/predicted_success": pred,
              p + "grasps/true_success": truth})  # fmt: skip
    return d


def run_object(
    entry: ObjectEntry,
    hands_todo: list[tuple[str, str]],
    cfg: Any,
    progress: Callable[[int], None] = lambda n: None,
) -> list[dict[str, Any]]:
    """Computes and writes the shards of one object.

    Args:
        entry: The object.
        hands_todo: ``(hand, shard key)`` of the shards to compute.
        cfg: The :class:`~symjax.data.GenerateConfig`.
        progress: Called with the number of candidates just labelled.

    Returns:
        One manifest row per shard written.
    """
    import symjax
    from symjax import grasp, hands
    from symjax._atomic import atomic_write_bytes
    from symjax.data.partial_views import complete_views, view_grasps
    from symjax.decompose import decompose
    from symjax.table import TablePlane

    t0 = time.perf_counter()
    spec = cfg.generate
    obj = load_entry(entry, cfg.cache_dir)
    mesh = obj.mesh
    out = Path(cfg.out_dir)
    atomic_write_bytes(out / mesh_file(entry.name), mesh.export(file_type="obj").encode())
    table = TablePlane.horizontal(0.0)
    dec = decompose(mesh, cfg.decompose)
    views = complete_views(obj, spec.views, cfg, spec.seed) if spec.views else []
    shared_s = time.perf_counter() - t0
    rows = []
    for hand_name, key in hands_todo:
        t1 = time.perf_counter()
        hand = hands.load(hand_name)
        seed = shard_rng_seed(spec.seed, entry.name, hand_name)
        cands, codes, counts = mixed_candidates(mesh, hand, spec, cfg.candidates, table, seed)
        scene = grasp.build_scene(dec, hand, cfg.simulation, table=table)
        parts = []
        for s in range(0, len(cands), SIM_CHUNK):
            c = cands.take(np.arange(s, min(s + SIM_CHUNK, len(cands))))
            parts.append(grasp.simulate(None, c, hand, scene=scene, backend=spec.backend,
                                        execution=cfg.execution))  # fmt: skip
            progress(len(c))
        o = grasp.GraspOutcomes.concatenate(parts)
        data: dict[str, Any] = {
            "grasps/transforms": _tcp_poses(cands, o.travel),
            "grasps/qualities/flex/object_in_gripper": np.asarray(o.success, np.int64),
            "grasps/qualities/flex/object_motion_during_closing_linear": o.close_motion,
            "grasps/qualities/flex/object_motion_during_closing_angular": o.close_rotation,
            "grasps/qualities/flex/object_motion_during_shaking_linear": o.shake_motion,
            "grasps/qualities/flex/object_motion_during_shaking_angular": o.shake_rotation,
            "object/file": mesh_file(entry.name),
            "object/scale": 1.0,
            **_object_props(mesh, scene, cfg),
            "gripper/type": hand_name,
            "gripper/configuration": np.asarray(hand.preshape_qpos)[hand.preshape_index("open")],
            "gripper/joint_names": np.array([j.encode() for j in hand.joint_names]),
            "gripper/tcp_in_base": _tcp_in_base(hand),
            "symjax/success": np.asarray(o.success, bool),
            "symjax/force_closure": np.asarray(o.force_closure, bool),
            "symjax/epsilon": o.epsilon,
            "symjax/n_fingers": o.n_fingers,
            "symjax/penetration": o.penetration,
            "symjax/start_penetration": o.start_penetration,
            "symjax/table_contact": np.asarray(o.table_contact, bool),
            "symjax/lift": o.lift,
            "symjax/diverged": np.asarray(o.diverged, bool),
            "symjax/closed_joint_positions": o.hand_q,
            "symjax/preshape": cands.preshape,
            "symjax/approach": cands.approach,
            "symjax/roll": cands.roll,
            "symjax/distance": cands.distance,
            "symjax/grasp_point": cands.point,
            "symjax/travel": o.travel,
            "symjax/generator": codes,
        }
        confidences = []
        for k, vc in enumerate(views):
            vg = view_grasps(vc, hand, dec, cfg, spec.view_top, HAND_GENERATOR[hand_name])
            data.update(_view_data(k, vc, vg))
            confidences.append(vc["confidence"])
        n = len(cands)
        row = {
            "file": str(shard_file(Path("."), entry.name, hand_name)),
            "object": entry.name,
            "source": entry.source,
            "scale": entry.scale,
            "hand": hand_name,
            "n_grasps": n,
            "n_success": int(np.sum(o.success)),
            "success_rate": round(float(np.mean(o.success)) if n else 0.0, 4),
            "candidates_by_generator": counts,
            "n_views": len(views),
            "views_true_success": _views_rate(data, len(views)),
            "seed": spec.seed,
            "config_hash": key,
            "symjax_version": symjax.__version__,
            "wall_s": round(time.perf_counter() - t1 + shared_s / len(hands_todo), 3),
            "host": platform.node(),
        }
        attrs = {"symjax_key": key, "symjax_manifest_row": row,
                 "symjax_preshape_names": list(hand.preshape_names),
                 "symjax_generator_names": list(GENERATORS)}  # fmt: skip
        write_shard(shard_file(out, entry.name, hand_name), data, attrs)
        rows.append(row)
    return rows


def _views_rate(data: dict[str, Any], n_views: int) -> float | None:
    t = [np.asarray(data[f"views/{k}/grasps/true_success"]) for k in range(n_views)]
    t = np.concatenate(t) if t else np.zeros(0)
    return round(float(t.mean()), 4) if t.size else None


def _tcp_in_base(hand: Any) -> np.ndarray:
    from symjax.geometry import quat_to_matrix

    T = np.eye(4)
    T[:3, :3] = np.asarray(quat_to_matrix(np.asarray(hand.tcp_quat)), np.float64)
    T[:3, 3] = np.asarray(hand.tcp_pos, np.float64)
    return T
