"""Benchmark of normals and Poisson reconstruction (issue 4): one JSON line per case.

Views are synthetic primitives (box, cylinder) completed by mirroring across their true symmetry
plane, subsampled to 5,000 and 40,000 points, with normals from :func:`oriented_completion`.

Cases:
  normals_<n>       outlier filter + kNN normals of one completed view; reference: Open3D's
                    ``estimate_normals`` (kNN 10) + orientation towards the camera.
  poisson_d<d>_<n>  one view at depth 5 / 7: compile time (lowering + XLA, persistent cache off),
                    run time of the jitted solve on device-resident inputs, marching-cubes time and
                    end-to-end time of :func:`poisson_reconstruct` (median); reference: Open3D's
                    Poisson at the same depth on the same oriented points, with the mean deviation
                    between the two meshes both ways and of each from the ground truth.
                    Floor on the 2-core CPU: depth 7 at most 0.5 s per view after compilation.
  batch<B>_d<d>     B views (padded to one point count) solved in one jitted call, then meshed.

Results go to ``bench/results/surface.json``.

Usage: ``python scripts/bench_surface.py [--quick] [--out bench/results/surface.json]``
"""

from __future__ import annotations

import dataclasses
import json
import platform
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import jax

# A bench measures compilation: never read it from the persistent cache.
jax.config.update("jax_enable_compilation_cache", False)

import numpy as np  # noqa: E402
import trimesh  # noqa: E402

from symjax._atomic import atomic_write_json  # noqa: E402
from symjax._timing import median_time  # noqa: E402
from symjax.cli.common import PresetArgs, parse  # noqa: E402
from symjax.datasets.primitives import primitive_view  # noqa: E402
from symjax.geometry import reflect  # noqa: E402
from symjax.metrics import mesh_deviation  # noqa: E402
from symjax.surface import (  # noqa: E402
    NormalsConfig,
    PoissonConfig,
    oriented_completion,
    poisson_reconstruct,
)
from symjax.surface.isosurface import grid_to_mesh  # noqa: E402
from symjax.surface.poisson_grid import (  # noqa: E402
    _poisson_batch_jit,
    _poisson_jit,
    pack_views,
    solve_grids,
)

ROOT = Path(__file__).resolve().parents[1]


def _ground_truth(kind: str, yaw: float) -> trimesh.Trimesh:
    if kind == "box":
        m = trimesh.creation.box(extents=(0.12, 0.07, 0.10))
        m.apply_translation([0, 0, 0.05])
    else:
        m = trimesh.creation.cylinder(radius=0.035, height=0.12, sections=256)
        m.apply_translation([0, 0, 0.06])
    m.apply_transform(trimesh.transformations.rotation_matrix(yaw, [0, 0, 1]))
    return m


def _completed_view(kind: str, yaw: float, azimuth: float, n_points: int, seed: int = 0):
    """Observation subsampled to ~n_points/2 and mirrored across the true plane (oracle)."""
    obs, planes = primitive_view(kind, yaw, azimuth=azimuth)
    pts = obs.valid_points()
    rng = np.random.default_rng(seed)
    half = n_points // 2
    pts = pts[rng.choice(len(pts), half, replace=len(pts) < half)]
    if len(pts) != len(np.unique(pts, axis=0)):
        pts = pts + rng.normal(0, 1e-5, pts.shape)
    view = np.asarray(obs.camera.position)[:2]
    view = np.array([view[0], view[1], 0.0]) / np.linalg.norm(view)
    if planes:  # the symmetry plane most perpendicular to the viewing direction
        normal = max(planes, key=lambda n: abs(float(n @ view)))
        normal = normal * (-np.sign(normal @ view))
    else:
        normal = -view
    mirrored = np.asarray(reflect(pts, normal, 0.0))
    ones = np.ones(len(pts), bool)
    res = SimpleNamespace(
        points=pts,
        normal=normal,
        offset=0.0,
        completed_points=np.concatenate([pts, mirrored]),
        completed_valid=np.concatenate([ones, ones]),
        completed_plausibility=np.ones(2 * len(pts)),
    )
    return res, obs.camera


def _open3d():
    try:
        import open3d as o3d  # optional extra symjax[open3d]
    except ImportError:
        return None
    return o3d


def _o3d_cloud(o3d, points, normals=None):
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, np.float64)))
    if normals is not None:
        pcd.normals = o3d.utility.Vector3dVector(np.asarray(normals, np.float64))
    return pcd


def _o3d_poisson(o3d, op, depth: int) -> trimesh.Trimesh:
    mesh, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(
        _o3d_cloud(o3d, op.points, op.normals), depth=depth
    )
    return trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.triangles), process=False)


def _emit(rows: list, row: dict) -> None:
    rows.append(row)
    print(json.dumps(row), flush=True)


def bench_normals(rows, res, camera, n_points, repeats, o3d) -> None:
    cfg = NormalsConfig()
    t = median_time(lambda: oriented_completion(res, camera, cfg), repeats)
    row = {"case": f"normals_{n_points}", "n_points": n_points, "run_s": t}
    if o3d is not None:
        pts = np.asarray(res.completed_points)

        def ref():
            pcd = _o3d_cloud(o3d, pts)
            pcd.remove_statistical_outlier(nb_neighbors=10, std_ratio=3.0)
            pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=10))
            pcd.orient_normals_towards_camera_location(np.asarray(camera.position, np.float64))

        row["open3d_s"] = median_time(ref, repeats)
        row["ratio_open3d_over_symjax"] = row["open3d_s"] / t
    _emit(rows, row)


def bench_poisson(rows, op, gt, depth, n_points, repeats, o3d) -> None:
    cfg = PoissonConfig(depth=depth)
    P, N, W, V = pack_views([(op.points, op.normals, op.weights)], cfg)
    args = [jax.device_put(a[0]) for a in (P, N, W, V)]
    t0 = time.perf_counter()
    compiled = _poisson_jit.jit.lower(*args, cfg).compile()
    compile_s = time.perf_counter() - t0
    grid = jax.block_until_ready(compiled(*args))
    solve_s = median_time(lambda: jax.block_until_ready(compiled(*args)), repeats)
    grid = jax.device_get(grid)
    mc_s = median_time(lambda: grid_to_mesh(grid, cfg), repeats)
    poisson_reconstruct(op.points, op.normals, op.weights, cfg)  # warm the jit cache
    total_s = median_time(
        lambda: poisson_reconstruct(op.points, op.normals, op.weights, cfg), repeats
    )
    mesh = poisson_reconstruct(op.points, op.normals, op.weights, cfg)
    row = {
        "case": f"poisson_d{depth}_{n_points}",
        "depth": depth,
        "n_points": len(op),
        "compile_s": compile_s,
        "solve_s": solve_s,
        "marching_cubes_s": mc_s,
        "per_view_s": total_s,
        "floor_s": 0.5 if depth == 7 else None,
        "watertight": bool(mesh.is_watertight),
        "faces": int(len(mesh.faces)),
        "dev_gt_mm": mesh_deviation(gt, mesh, n_samples=10000).mean * 1e3,
    }
    if o3d is not None:
        ref = _o3d_poisson(o3d, op, depth)
        row["open3d_s"] = median_time(lambda: _o3d_poisson(o3d, op, depth), repeats)
        row["ratio_open3d_over_symjax"] = row["open3d_s"] / total_s
        row["open3d_watertight"] = bool(ref.is_watertight)
        row["dev_open3d_to_symjax_mm"] = mesh_deviation(ref, mesh, n_samples=10000).mean * 1e3
        row["dev_symjax_to_open3d_mm"] = mesh_deviation(mesh, ref, n_samples=10000).mean * 1e3
        row["open3d_dev_gt_mm"] = mesh_deviation(gt, ref, n_samples=10000).mean * 1e3
    _emit(rows, row)


def _closed_object(name: str, n_points: int):
    """Dense uniform samples with exact normals of a closed object, and its mesh."""
    if name.startswith("sphere"):
        r = float(name[6:]) / 100.0
        gt = trimesh.creation.icosphere(subdivisions=6, radius=r)
    elif name == "box":
        gt = trimesh.creation.box(extents=(0.12, 0.07, 0.10))
    elif name == "box20":
        gt = trimesh.creation.box(extents=(0.20, 0.08, 0.05))
    else:
        gt = trimesh.creation.cylinder(radius=0.035, height=0.12, sections=256)
    pts, face = trimesh.sample.sample_surface(gt, n_points, seed=0)
    nrm = np.asarray(gt.face_normals[face])
    if name.startswith("sphere"):
        nrm = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    op = SimpleNamespace(points=np.asarray(pts), normals=nrm, weights=np.ones(n_points))
    op.__len__ = lambda: n_points
    return op, gt


def bench_closed(rows, name: str, depth: int, n_points: int, repeats: int, o3d) -> None:
    """Closed objects with exact normals: symjax against Open3D (needs it installed)."""
    op, gt = _closed_object(name, n_points)
    cfg = PoissonConfig(depth=depth)
    mesh = poisson_reconstruct(op.points, op.normals, op.weights, cfg)
    t = median_time(lambda: poisson_reconstruct(op.points, op.normals, op.weights, cfg), repeats)
    ref = _o3d_poisson(o3d, op, depth)
    t_ref = median_time(lambda: _o3d_poisson(o3d, op, depth), repeats)
    _emit(
        rows,
        {
            "case": f"vs_open3d_{name}_d{depth}",
            "depth": depth,
            "n_points": n_points,
            "extent_m": float(np.max(gt.extents)),
            "per_view_s": t,
            "open3d_s": t_ref,
            "ratio_open3d_over_symjax": t_ref / t,
            "watertight": bool(mesh.is_watertight),
            "dev_open3d_to_symjax_mm": mesh_deviation(ref, mesh, n_samples=10000).mean * 1e3,
            "dev_symjax_to_open3d_mm": mesh_deviation(mesh, ref, n_samples=10000).mean * 1e3,
            "dev_gt_mm": mesh_deviation(gt, mesh, n_samples=10000).mean * 1e3,
            "open3d_dev_gt_mm": mesh_deviation(gt, ref, n_samples=10000).mean * 1e3,
        },
    )


def bench_batch(rows, ops, depth, repeats) -> None:
    cfg = PoissonConfig(depth=depth)
    n_pad = max(len(op) for op in ops)
    P, N, W, V = pack_views([(o.points, o.normals, o.weights) for o in ops], cfg, n_pad)
    args = [jax.device_put(a) for a in (P, N, W, V)]
    # The vmapped path (a GPU's); the CPU default solves one view a call, in threads.
    chunk = max(2, min(8, len(ops)))
    t0 = time.perf_counter()
    _poisson_batch_jit.lower(*args, cfg, chunk).compile()
    compile_s = time.perf_counter() - t0
    grids = jax.block_until_ready(solve_grids(*args, cfg, chunk))
    solve_s = median_time(lambda: jax.block_until_ready(solve_grids(*args, cfg, chunk)), repeats)
    grids = jax.device_get(grids)
    t0 = time.perf_counter()
    meshes = [grid_to_mesh(grids[i], cfg) for i in range(len(ops))]
    mc_s = time.perf_counter() - t0
    b = len(ops)
    _emit(
        rows,
        {
            "case": f"batch{b}_d{depth}",
            "views": b,
            "n_points_padded": n_pad,
            "compile_s": compile_s,
            "chunk_views": chunk,
            "solve_s": solve_s,
            "marching_cubes_s": mc_s,
            "per_view_s": (solve_s + mc_s) / b,
            "all_watertight": all(m.is_watertight for m in meshes),
        },
    )


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    quick: bool = False
    """Fewer repeats and a batch of 16."""
    out: str = str(ROOT / "bench" / "results" / "surface.json")
    """Where the JSON lines go."""


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_surface.py", __doc__)
    repeats = 2 if args.quick else 5
    n_batch = 16 if args.quick else 128
    o3d = _open3d()
    rows: list = []
    for n_points in (5000, 40000):
        res, cam = _completed_view("box", 0.4, 0.0, n_points)
        bench_normals(rows, res, cam, n_points, repeats, o3d)
        op = oriented_completion(res, cam)
        for depth in (5, 7):
            bench_poisson(rows, op, _ground_truth("box", 0.4), depth, n_points, repeats, o3d)
    if o3d is not None:
        for name in ("sphere2.5", "sphere5", "box", "cylinder", "box20"):
            for depth in (5, 7):
                bench_closed(rows, name, depth, 40000, repeats, o3d)
    ops = []
    # 128 views divide into chunks of 8; the default chunk needs no padding views.
    for i in range(n_batch):
        kind = ("box", "cylinder")[i % 2]
        res, cam = _completed_view(kind, 0.1 * i, 0.3 * i, 5000, seed=i)
        ops.append(oriented_completion(res, cam))
    for depth in (5, 7):
        bench_batch(rows, ops, depth, 1 if depth == 7 and not args.quick else repeats)
    meta = {
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "jax": jax.__version__,
        "backend": jax.default_backend(),
        "open3d": None if o3d is None else o3d.__version__,
    }
    atomic_write_json(args.out, {"meta": meta, "cases": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
