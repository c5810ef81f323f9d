"""Bad input across every public entry point: the exact SymjaxError subclass, and a message that
names the offending value and what is expected. Never a raw exception, never a silent result.

Each row is ``(id, call, error, needles)``: ``call(d)`` gets a temporary folder ``d``; every
needle must appear in the message.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import subprocess
import sys
from io import StringIO
from pathlib import Path

import numpy as np
import pytest
import trimesh

import symjax
from symjax import (
    completion,
    configs,
    cycle,
    datasets,
    decompose,
    grasp,
    hands,
    io,
    metrics,
    motion,
    perception,
    robots,
    study,
    surface,
)
from symjax.data import (
    DatasetSpec,
    DenseSamplerConfig,
    GenerateConfig,
    generate_dataset,
    load_grasps,
)
from symjax.datasets import benchmark, load_object
from symjax.datasets.primitives import primitive_view
from symjax.errors import (
    CameraError,
    ConfigError,
    DegenerateGeometryError,
    EmptyInputError,
    FileFormatError,
    InvalidInputError,
    MissingFileError,
    OutputError,
    ShapeError,
    SymjaxError,
    UnknownNameError,
)
from symjax.execution import ExecutionConfig
from symjax.perception.clutter_benchmark import fresh_scenes
from symjax.perception.synthetic import clutter_scene
from symjax.symmetry import SymmetryConfig, search, search_batch, search_scene

VIEW, _ = primitive_view("box", math.radians(30), noise=0.001, seed=0)
CAM = VIEW.camera
PTS = VIEW.valid_points()
TABLE = symjax.TablePlane.horizontal()
K = np.asarray(CAM.K)
T = np.asarray(CAM.T_world_cam)
BOX = trimesh.creation.box((0.05, 0.08, 0.12))
BOX.apply_translation([0.5, 0.0, 0.06])
SDH = hands.load("sdh")


def _script_main(name: str):
    """``main`` of ``scripts/<name>.py`` (the benchmarks' own argument checks)."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"_script_{name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module.main


def _cands(**change):
    c = grasp.generate(BOX, "uji", config=configs.load("ci").candidates).candidates
    return dataclasses.replace(c, **{k: np.asarray(v) for k, v in change.items()})


def _write(d: Path, name: str, text: str | bytes) -> Path:
    p = d / name
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    return p


def _ply(n_decl: int, n_rows: int) -> str:
    rows = "\n".join(f"{i * 0.01} 0 {0.5 + i * 0.001}" for i in range(n_rows))
    return (
        f"ply\nformat ascii 1.0\nelement vertex {n_decl}\nproperty float x\nproperty float y\n"
        f"property float z\nend_header\n{rows}\n"
    )


def _pcd(count_x: int = 1) -> str:
    rows = "\n".join(" ".join(["0.1"] * (count_x + 2)) for _ in range(20))
    return (
        f"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT {count_x} 1 1\nWIDTH 20\n"
        f"HEIGHT 1\nPOINTS 20\nDATA ascii\n{rows}\n"
    )


def _crd(rows: list[str], count: int | None = None) -> str:
    return f"{len(rows) if count is None else count}\n" + "\n".join(rows) + "\n"


def _kth(d: Path, scale: float = 1.0, vp_scale: float = 1.0) -> Path:
    """A small view in the KTH layout (millimetres) from the synthetic box view."""
    uv, _ = CAM.project(PTS)
    uv = np.rint(np.asarray(uv)).astype(int)
    rows = [
        " ".join(f"{x:.6f}" for x in p * 1000 * scale) + f" {u} {v} 100 100 100"
        for p, (u, v) in zip(PTS, uv, strict=True)
    ]
    _write(d, "db/obj/segment_000.crd", _crd(rows))
    vp = np.asarray(CAM.position) * 1000 * vp_scale
    _write(d, "db/obj/viewPoint_000.txt", " ".join(f"{x:.6f}" for x in vp))
    k = [K[0, 0], 0, K[0, 2], 0, K[1, 1], K[1, 2], 0, 0, 1, 0, 0, 0, 0]
    nums = k * 2 + [90, 0, 0, 1, 0, 0, 0] + [0] * 9 + [CAM.width, CAM.height] + [0] * 18
    _write(d, "db/obj/calib.txt", " ".join(str(x) for x in nums))
    return d / "db" / "obj" / "segment_000.crd"


def _mm_view():
    """The box view with points and camera in millimetres, as if passed as metres."""
    T2 = T.copy()
    T2[:3, 3] *= 1000
    cam = symjax.Camera.create(K, T2, CAM.width, CAM.height)
    return PTS * 1000, cam


def _depth_frame(d: Path, depth, **camera_extra) -> Path:
    np.save(d / "frame.npy", np.asarray(depth, np.float32))
    cam = {"width": CAM.width, "height": CAM.height, "K": K.tolist(), "T_world_cam": T.tolist()}
    cam.update(camera_extra)
    (d / "frame.json").write_text(json.dumps(cam))
    return d / "frame.npy"


def _turned_camera():
    """The view's camera at the same place, turned to look away from the object."""
    T2 = T.copy()
    T2[:3, :3] = T[:3, :3] @ np.diag([-1.0, 1.0, -1.0])
    return symjax.Camera.create(K, T2, CAM.width, CAM.height)


def _nan_view():
    bad = dataclasses.replace(VIEW, points=np.asarray(VIEW.points).copy())
    bad.points[3] = np.nan
    return bad


def _far_depth_view():
    """A view whose depth image reaches 2 km (the occluders' offset is 1 km)."""
    depth = np.asarray(VIEW.depth).copy()
    depth[0, 0] = 2000.0
    return dataclasses.replace(VIEW, depth=depth)


def _same_point_view():
    p = np.asarray(VIEW.points).copy()
    p[:] = p[0]
    return dataclasses.replace(VIEW, points=p)


def _stray(n=400):
    rng = np.random.default_rng(0)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    p = 0.05 * d
    p[0] = [10.0, 0.0, 0.0]
    return p, d


def _cli(*argv: str, cwd: Path | None = None, process: bool = False) -> None:
    """Runs the symjax command; raises the typed error its stderr names (for the matrix).

    In this process (``symjax.cli.main``, what the console calls) unless ``process``: a new
    interpreter per row cost 5 s of imports on the 2-core CI machine.
    """
    if process:
        exe = Path(sys.executable).with_name("symjax")
        r = subprocess.run([str(exe), *argv], cwd=cwd, capture_output=True, text=True,
                           env={**os.environ, "MPLBACKEND": "Agg"})  # fmt: skip
        status, err = r.returncode, r.stderr
    else:
        from symjax.cli import main

        buf = StringIO()
        with contextlib.redirect_stderr(buf), contextlib.redirect_stdout(StringIO()):
            status = main(list(argv))  # an exception here is the raw trace the rows forbid
        err = buf.getvalue()
    if status == 0:
        return
    assert "Traceback" not in err, err[-2000:]
    flat = " ".join(line.strip(" │╭╰─╮╯") for line in err.splitlines())
    raise _CliError(f"exit {status}: {' '.join(flat.split())}")


class _CliError(SymjaxError):
    """The command failed with a message (exit 2) and no traceback."""


# fmt: off


def _scan_scene(robot="uji"):
    return datasets.ScanScene(robot, ("a",), np.eye(4)[None], (BOX,), CAM, np.zeros((CAM.height, CAM.width)),
                              np.zeros((CAM.height, CAM.width), np.int32), 0.75, 0)


def _empty_report():
    return cycle.CycleReport("kth", "C", (), (), "table clear", 0.0)


def _generate(d: Path, out: Path | None = None, **spec):
    """generate_dataset on ``spec`` (objects, hands, counts) into ``out`` (default d / "o")."""
    cfg = GenerateConfig(generate=DatasetSpec(**{"objects": ("025_mug",), **spec}),
                         out_dir=str(out if out is not None else d / "o"))  # fmt: skip
    return generate_dataset(cfg, log=lambda s: None)


def _mesh_folder(d: Path, **files: bytes) -> str:
    for name, data in files.items():
        _write(d / "meshes", name, data)
    return str(d / "meshes")


def _box_obj(size: float) -> bytes:
    return trimesh.creation.box((size, size, size)).export(file_type="obj").encode()


def _incomplete_h5(d: Path) -> Path:
    import h5py

    with h5py.File(d / "half.h5", "w") as f:
        f["grasps/transforms"] = np.zeros((1, 4, 4))
    return d / "half.h5"


def _hulls():
    b = trimesh.creation.box((0.05, 0.05, 0.1))
    b.apply_translation((0.7, 0.0, 0.8))
    return [(np.asarray(b.vertices), np.asarray(b.faces))]


def _grasp():
    R = np.diag([1.0, -1.0, -1.0])
    return motion.GraspPose((np.array([0.7, 0, 0.95]), R), (np.array([0.7, 0, 0.88]), R), 1)


def _far_grasp():
    R = np.diag([1.0, -1.0, -1.0])
    return motion.GraspPose((np.array([3.0, 0, 0.95]), R), (np.array([3.0, 0, 0.88]), R), 1)


def _nan_grasp():
    g = _grasp()
    return motion.GraspPose((np.full(3, np.nan), g.pregrasp[1]), g.grasp, 1)


def _two_shapes():
    return completion.ShapeSet((BOX, BOX.copy()), np.array([0.75, 0.25]), ("mirror", "fallback"),
                               ("a", "b"))  # fmt: skip


def _decomposition():
    from symjax.decompose import Decomposition

    return Decomposition(tuple(_hulls()), "k", False, 0.0)


def _up_normals():
    return np.tile([0.0, 0.0, 1.0], (len(PTS), 1))


def _blocked_scene():
    """A block around the UJI hand at home."""
    scene = motion.PlanningScene("uji")
    p, _ = scene.tcp_pose(scene.full_q(scene.robot.home))
    b = trimesh.creation.box((0.2, 0.2, 0.2))
    b.apply_translation(p)
    scene.add_object("block", [(np.asarray(b.vertices), np.asarray(b.faces))])
    return scene


CASES = [
    # --- camera and observation --------------------------------------------------------------
    ("camera-K-shape", lambda d: symjax.Camera.create(np.eye(2), T, 64, 48), ShapeError, ["(3, 3)", "(2, 2)"]),
    ("camera-nan", lambda d: symjax.Camera.create(K * np.nan, T, 64, 48), CameraError, ["finite", "NaN"]),
    ("camera-focal", lambda d: symjax.Camera.create(np.diag([-1.0, 1, 1]), T, 64, 48), CameraError, ["fx=-1.0", "> 0"]),
    ("camera-pose", lambda d: symjax.Camera.create(K, np.diag([1.0, 1, -1, 1]), 64, 48), CameraError, ["orthonormal", "det +1"]),
    ("camera-width-float", lambda d: symjax.Camera.create(K, T, 64.9, 48), CameraError, ["width", "64.9", "whole number"]),
    ("camera-width-bool", lambda d: symjax.Camera.create(K, T, True, 48), CameraError, ["width", "True"]),
    ("camera-direct-float", lambda d: symjax.Camera(K=K, T_world_cam=T, width=64.9, height=48), CameraError, ["width", "64.9", "whole number"]),
    ("camera-size", lambda d: symjax.Camera.create(K, T, 0, 48), CameraError, ["0x48", "positive"]),
    ("obs-K-not-camera", lambda d: symjax.Observation.from_points(PTS, K, TABLE), InvalidInputError, ["symjax.Camera", "ndarray"]),
    ("obs-table-type", lambda d: symjax.Observation.create(PTS, CAM, 0.0, VIEW.mask, VIEW.depth), InvalidInputError, ["TablePlane", "float"]),
    ("obs-shape", lambda d: symjax.Observation.from_points(PTS[:, :2], CAM, TABLE), ShapeError, ["(N, 3)", "2)"]),
    ("obs-empty", lambda d: symjax.Observation.from_points(np.zeros((0, 3)), CAM, TABLE), EmptyInputError, ["empty", "at least 10"]),
    ("obs-all-nan", lambda d: symjax.Observation.from_points(np.full((50, 3), np.nan), CAM, TABLE), EmptyInputError, ["no finite points", "50"]),
    ("obs-millimetres", lambda d: symjax.Observation.from_points(*_mm_view(), TABLE), InvalidInputError, ["m across", "millimetres", "max_extent"]),
    ("obs-one-point", lambda d: symjax.Observation.from_points(np.repeat(PTS[:1], 50, 0), CAM, TABLE), DegenerateGeometryError, ["0 mm across", "min_extent"]),
    ("obs-far", lambda d: symjax.Observation.from_points(PTS, CAM, TABLE, limits=symjax.SceneLimits(max_distance=0.3)), InvalidInputError, ["from the camera", "max_distance"]),
    ("obs-behind", lambda d: symjax.Observation.from_points(PTS, _turned_camera(), TABLE), CameraError, ["behind the camera", "T_world_cam"]),
    ("obs-mask-shape", lambda d: symjax.Observation.create(PTS, CAM, TABLE, np.ones((3, 3), bool), VIEW.depth), ShapeError, ["mask", "(3, 3)"]),
    ("obs-depth-nan", lambda d: symjax.Observation.create(PTS, CAM, TABLE, VIEW.mask, VIEW.depth * np.nan), InvalidInputError, ["depth image", "finite"]),
    ("limits-order", lambda d: symjax.SceneLimits(min_extent=1.0, max_extent=0.5), ConfigError, ["min_extent", "1.0", "0.5"]),
    # --- configs ---------------------------------------------------------------------------
    ("sym-n-angles-str", lambda d: SymmetryConfig(n_angles="7"), ConfigError, ["n_angles = '7'", "an integer"]),
    ("sym-w-outside-nan", lambda d: SymmetryConfig(w_outside=math.nan), ConfigError, ["w_outside = nan", "finite"]),
    ("sym-plaus-nan", lambda d: SymmetryConfig(plausibility_px=math.nan), ConfigError, ["plausibility_px", "finite"]),
    ("sym-init", lambda d: SymmetryConfig(init="pca"), ConfigError, ["init = 'pca'", "'eigen'"]),
    ("sym-shift-order", lambda d: SymmetryConfig(shift_min=0.6), ConfigError, ["shift_min 0.6", "shift_max 0.5"]),
    ("sym-w-inside-neg", lambda d: SymmetryConfig(w_inside=-1.0), ConfigError, ["w_inside", ">= 0", "-1.0"]),
    ("sym-box-favour-one", lambda d: SymmetryConfig(box_favour=1.0), ConfigError, ["box_favour", "[0, 1)", "1.0"]),
    ("sym-box-favour-nan", lambda d: SymmetryConfig(box_favour=math.nan), ConfigError, ["box_favour = nan", "finite"]),
    ("sym-box-rectangularity", lambda d: SymmetryConfig(box_rectangularity=0.5), ConfigError, ["box_rectangularity", ">= 1", "0.5"]),
    ("sym-box-fan", lambda d: SymmetryConfig(box_fan=1.5), ConfigError, ["box_fan", "[0, 1]", "1.5"]),
    ("sym-box-axes", lambda d: SymmetryConfig(box_axes=3), ConfigError, ["box_axes", "1 or 2", "3"]),
    ("sym-neighbour-volumes", lambda d: SymmetryConfig(neighbour_volumes="yes"), ConfigError, ["neighbour_volumes", "'yes'", "true or false"]),
    ("sym-outside-huber-neg", lambda d: SymmetryConfig(outside_huber_px=-1.0), ConfigError, ["outside_huber_px", ">= 0", "-1.0"]),
    ("sym-outside-huber-nan", lambda d: SymmetryConfig(outside_huber_px=math.nan), ConfigError, ["outside_huber_px = nan", "finite"]),
    ("sym-other-axis-favour", lambda d: SymmetryConfig(other_axis_favour=1.0), ConfigError, ["other_axis_favour", "[0, 1)", "1.0"]),
    ("poisson-depth", lambda d: surface.PoissonConfig(depth=9), ConfigError, ["depth", "[2, 8]", "9"]),
    ("poisson-depth-float", lambda d: surface.PoissonConfig(depth=7.0), ConfigError, ["depth = 7.0", "an integer"]),
    ("normals-k", lambda d: surface.NormalsConfig(k=2), ConfigError, ["k must be", "3", "2"]),
    ("delaunay-edge", lambda d: surface.DelaunayConfig(edge_factor=math.inf), ConfigError, ["edge_factor = inf", "finite"]),
    ("candidates-distances", lambda d: grasp.CandidateConfig(distances=(-0.1,)), ConfigError, ["distances", "-0.1", "[0, 1]"]),
    ("candidates-n-rays", lambda d: grasp.CandidateConfig(n_rays=0), ConfigError, ["n_rays", ">= 1"]),
    ("robustness-shift", lambda d: grasp.RobustnessConfig(shift=0.5), ConfigError, ["shift", "0.5", "[0, 0.1] m"]),
    ("robustness-no-pose", lambda d: grasp.RobustnessConfig(enabled=True, shift=0.0, roll_deg=0.0), ConfigError, ["no pose to try"]),
    ("robustness-enabled-str", lambda d: grasp.RobustnessConfig(enabled="yes"), ConfigError, ["enabled"]),
    ("sim-timestep", lambda d: grasp.SimulationConfig(timestep=-1.0), ConfigError, ["timestep", "positive", "-1.0"]),
    ("sim-cone", lambda d: grasp.SimulationConfig(cone="square"), ConfigError, ["cone", "'square'", "'pyramidal'"]),
    ("decompose-threshold", lambda d: decompose.DecomposeConfig(threshold=2.0), ConfigError, ["threshold", "[0.01, 1]", "2.0"]),
    ("execution-chunk", lambda d: ExecutionConfig(simulation_chunk=0), ConfigError, ["simulation_chunk", ">= 1", "0"]),
    ("execution-metric-workers", lambda d: ExecutionConfig(metric_workers=-1), ConfigError, ["metric_workers", "-1"]),
    ("execution-bool", lambda d: ExecutionConfig(eval_batch_size=True), ConfigError, ["eval_batch_size", "True"]),
    ("segmentation-seed", lambda d: perception.SegmentationConfig(seed=1.5), ConfigError, ["seed = 1.5", "an integer"]),
    ("platform-hand", lambda d: robots.PlatformConfig(robot="uji", hand="sdh"), ConfigError, ["hand = 'sdh'", "'barrett'"]),
    ("eval-methods", lambda d: symjax.evaluation.EvalConfig(methods=("Del", "Foo")), UnknownNameError, ["'Foo'", "Mir7"]),
    ("eval-subset", lambda d: symjax.evaluation.EvalConfig(subset=("xdeg",)), ConfigError, ["'xdeg'", "45deg"]),
    ("preset-unknown", lambda d: configs.load("papr"), UnknownNameError, ["'papr'", "paper"]),
    ("preset-key", lambda d: configs.load("paper", {"symmetry.n_angle": 3}), ConfigError, ["'n_angle'", "n_angles"]),
    ("preset-type", lambda d: configs.load("paper", {"symmetry.n_angles": "x"}), ConfigError, ["n_angles = 'x'", "an integer"]),
    ("preset-file", lambda d: configs.load(d / "none.toml"), MissingFileError, ["none.toml", "does not exist"]),
    ("preset-toml", lambda d: configs.load(_write(d, "bad.toml", "[x\n")), FileFormatError, ["bad.toml", "not valid TOML"]),
    # --- symmetry ----------------------------------------------------------------------------
    ("search-type", lambda d: search(PTS), InvalidInputError, ["symjax.Observation", "ndarray"]),
    ("search-config-type", lambda d: search(VIEW, {"n_angles": 7}), ConfigError, ["config", "SymmetryConfig", "dict"]),
    ("search-nan-point", lambda d: search(_nan_view()), InvalidInputError, ["NaN or inf", "Observation.create"]),
    ("search-one-point", lambda d: search(_same_point_view()), DegenerateGeometryError, ["0 mm on the table", "0.1 mm"]),
    ("search-depth-beyond-1km", lambda d: search(_far_depth_view()), InvalidInputError, ["2000 m", "below 1000 m"]),
    ("search-batch-empty", lambda d: search_batch([]), InvalidInputError, ["no observations"]),
    ("search-scene-sizes", lambda d: search_scene([VIEW, primitive_view("box", 0.3, width=320, height=240)[0]], SymmetryConfig(neighbour_volumes=True)), InvalidInputError, ["one frame", "(240, 320)", "(480, 640)"]),
    ("search-scene-empty", lambda d: search_scene([], SymmetryConfig(neighbour_volumes=True)), InvalidInputError, ["no observations"]),
    ("search-scene-item", lambda d: search_scene([VIEW, PTS], SymmetryConfig(neighbour_volumes=True)), InvalidInputError, ["item 1", "ndarray"]),
    ("search-batch-single", lambda d: search_batch(VIEW), InvalidInputError, ["sequence", "search()"]),
    ("search-batch-item", lambda d: search_batch([VIEW, PTS]), InvalidInputError, ["item 1", "ndarray"]),
    ("search-batch-all-bad", lambda d: search_batch([_nan_view(), _same_point_view()]), InvalidInputError, ["view 0", "view 1", "could be searched"]),
    ("batch-index-failed", lambda d: search_batch([VIEW, _nan_view()])[1], InvalidInputError, ["view 1 of the batch", "NaN"]),
    ("complete-bad-view", lambda d: symjax.complete([VIEW, _same_point_view()]), DegenerateGeometryError, ["view 1", "0 mm"]),
    ("search-execution-type", lambda d: search(VIEW, None, {"chunk": 2}), ConfigError, ["execution", "ExecutionConfig"]),
    ("poisson-min-component", lambda d: surface.PoissonConfig(min_component=1.5), ConfigError, ["min_component", "[0, 1]", "1.5"]),
    # --- completion choice -------------------------------------------------------------------
    ("completion-batch", lambda d: completion.choose_completion(search_batch([VIEW]), VIEW), ShapeError, ["one view", "index the batch"]),
    ("completion-config-type", lambda d: completion.choose_completion(search(VIEW), VIEW, {"mode": "auto"}), ConfigError, ["config", "CompletionConfig", "dict"]),
    ("completion-mode", lambda d: completion.CompletionConfig(mode="mirrors"), ConfigError, ["mode", "'auto'", "'mirrors'"]),
    ("completion-eps", lambda d: completion.CompletionConfig(support_eps=-1.0), ConfigError, ["support_eps", "> 0"]),
    ("preset-completion", lambda d: configs.load("paper", {"completion.revolution_copies": 1}), ConfigError, ["revolution_copies", ">= 2"]),
    ("support-shape", lambda d: completion.plane_support(PTS[:, :2], [0, 1, 0], 0.0), ShapeError, ["(N, 3)", "(", "2)"]),
    ("support-zero-normal", lambda d: completion.plane_support(PTS, [0, 0, 0], 0.0), ShapeError, ["normal", "non-zero"]),
    ("support-no-points", lambda d: completion.plane_support(np.full((4, 3), np.nan), [0, 1, 0], 0.0), EmptyInputError, ["finite observed point"]),
    ("revolution-normal", lambda d: completion.fit_revolution(surface.oriented_observation(PTS, VIEW.camera), [0, 0, 2]), ShapeError, ["table_normal", "unit vector"]),
    ("footprint-hull-few", lambda d: completion.footprint_hull(PTS[:2], VIEW.table), DegenerateGeometryError, [">= 3 points", "(2, 3)"]),
    ("completion-shapes-count", lambda d: completion.CompletionConfig(shapes=4), ConfigError, ["shapes", "1, 2 or 3", "4"]),
    ("completion-distinct-deg", lambda d: completion.CompletionConfig(distinct_deg=90.0), ConfigError, ["distinct_deg", "(0, 90)"]),
    ("shapeset-weights", lambda d: completion.ShapeSet((BOX, BOX), np.array([0.7, 0.7]), ("a", "b"), ("x", "y")), InvalidInputError, ["weights", "summing to 1"]),
    ("shapeset-lengths", lambda d: completion.ShapeSet((BOX,), np.ones(2) / 2, ("a",), ("x",)), InvalidInputError, ["1 meshes", "weights (2,)"]),
    ("mirror-across-batch", lambda d: symjax.symmetry.mirror_across(search_batch([VIEW]), VIEW, [0, 1, 0], 0.0), ShapeError, ["one view", "index the batch"]),
    ("mirror-across-zero-normal", lambda d: symjax.symmetry.mirror_across(search(VIEW), VIEW, [0, 0, 0], 0.0), InvalidInputError, ["normal", "non-zero"]),
    ("plan-shapes-type", lambda d: grasp.plan(BOX, SDH, "uji", shapes=[BOX, BOX]), InvalidInputError, ["shapes", "ShapeSet", "list"]),
    ("plan-shapes-robust", lambda d: grasp.plan(BOX, SDH, "uji", shapes=completion.ShapeSet.single(BOX), robust="median"), UnknownNameError, ["median", "mean", "quantile"]),
    ("plan-shapes-quantile", lambda d: grasp.plan(BOX, SDH, "uji", shapes=completion.ShapeSet.single(BOX), robust="quantile", quantile=1.0), InvalidInputError, ["quantile", "[0, 1)", "1.0"]),
    ("plan-shapes-hulls", lambda d: grasp.plan(None, SDH, "uji", shapes=_two_shapes(), hulls=_hulls()), InvalidInputError, ["one decomposition per shape", "(2)"]),
    ("plan-shapes-scene", lambda d: grasp.plan(None, SDH, "uji", shapes=_two_shapes(), scene=grasp.build_scene(_hulls(), SDH)), InvalidInputError, ["shapes", "prebuilt scene"]),
    ("study-config-robust", lambda d: study.StudyConfig(robust="median"), ConfigError, ["robust", "'mean'", "'median'"]),
    # --- surface and metrics -----------------------------------------------------------------
    ("poisson-shape", lambda d: surface.poisson_reconstruct(PTS, PTS[:, :2]), ShapeError, ["normals", "shape"]),
    ("poisson-zero-normals", lambda d: surface.poisson_reconstruct(PTS, np.zeros_like(PTS)), DegenerateGeometryError, ["zero length", "unit normals"]),
    ("poisson-few", lambda d: surface.poisson_reconstruct(PTS[:5], PTS[:5]), EmptyInputError, ["5", "20"]),
    ("poisson-stray-point", lambda d: surface.poisson_reconstruct(*_stray()), DegenerateGeometryError, ["far from the rest", "outlier_mask"]),
    ("poisson-batch-empty", lambda d: surface.poisson_reconstruct_batch([]), InvalidInputError, ["empty", "oriented cloud"]),
    ("poisson-batch-item", lambda d: surface.poisson_reconstruct_batch([PTS]), InvalidInputError, ["OrientedPoints", "ndarray"]),
    ("poisson-batch-errors", lambda d: surface.poisson_reconstruct_batch([(PTS, PTS)], errors="ignore"), InvalidInputError, ["'ignore'", "'keep'"]),
    ("normals-shape", lambda d: surface.estimate_normals(PTS[:, :1]), ShapeError, ["(N, 3)"]),
    ("delaunay-few", lambda d: surface.delaunay_mesh(PTS[:5], CAM), EmptyInputError, ["5", "20"]),
    ("deviation-type", lambda d: metrics.mesh_deviation(BOX, "box.ply"), InvalidInputError, ["trimesh.Trimesh", "str"]),
    ("deviation-faces", lambda d: metrics.mesh_deviation(BOX, (BOX.vertices, BOX.faces + 100)), ShapeError, ["face indices", "[0, 8)"]),
    ("surface-distance-shape", lambda d: metrics.surface_distance(PTS[:, :2], BOX), ShapeError, ["(N, 3)", "2)"]),
    ("centroid-diagonal", lambda d: metrics.centroid_error(BOX, BOX, 100, diagonal=-0.1), InvalidInputError, ["diagonal", "positive", "-0.1"]),
    ("deviation-no-area", lambda d: metrics.mesh_deviation(BOX, (np.zeros((4, 3)), np.array([[0, 1, 2], [1, 2, 3], [0, 2, 3], [0, 1, 3]]))), EmptyInputError, ["zero surface area"]),
    ("plane-error-zero", lambda d: metrics.plane_error([0, 0, 0], 0.0, planes=[([1, 0, 0], 0.0)]), InvalidInputError, ["non-zero", "[0.0, 0.0, 0.0]"]),
    ("plane-error-shape", lambda d: metrics.plane_error([1, 0], 0.0), ShapeError, ["(3,)", "(2,)"]),
    # --- files -------------------------------------------------------------------------------
    ("ply-truncated", lambda d: io.read_point_cloud(_write(d, "t.ply", _ply(200, 96))), FileFormatError, ["t.ply", "200 vertex", "96", "truncated"]),
    ("ply-missing", lambda d: io.read_point_cloud(d / "none.ply"), MissingFileError, ["none.ply", "does not exist"]),
    ("pcd-count", lambda d: io.read_point_cloud(_write(d, "c.pcd", _pcd(2))), FileFormatError, ["c.pcd", "'x'", "COUNT 2", "COUNT 1"]),
    ("cloud-format", lambda d: io.read_point_cloud(_write(d, "c.xyz", "1 2 3\n")), FileFormatError, ["c.xyz", ".ply"]),
    ("crd-mixed-rows", lambda d: io.read_kth_segment(_write(d, "m.crd", _crd(["1 2 3 4 5 6 7 8", "1 2 3 4 5 6 7", "1 2 3 4 5 6 7 8 9"]))), FileFormatError, ["m.crd", "line 3", "7 numbers", "8"]),
    ("crd-count", lambda d: io.read_kth_segment(_write(d, "n.crd", _crd(["1 2 3 4 5 6 7 8"], count=5))), FileFormatError, ["n.crd", "5 points", "truncated"]),
    ("crd-metres", lambda d: io.load_kth_view(_kth(d, scale=0.001, vp_scale=0.001)), FileFormatError, ["segment_000.crd", "metres", "millimetres"]),
    ("kth-dir-is-file", lambda d: io.load_kth_directory(_write(d, "f.txt", "x")), InvalidInputError, ["f.txt", "is a file", "folder"]),
    ("kth-dir-missing", lambda d: io.load_kth_directory(d / "nope"), MissingFileError, ["nope", "does not exist"]),
    ("camera-json-bool", lambda d: io.load_depth_frame(_depth_frame(d, VIEW.depth, width=True)), FileFormatError, ["'width'", "True", "a number"]),
    ("camera-json-missing", lambda d: io.load_camera_json(_write(d, "c.json", json.dumps({"width": 64}))), FileFormatError, ["c.json", "'height'"]),
    ("depth-mm-float", lambda d: io.read_depth_image(_depth_frame(d, VIEW.depth * 1000.0)), FileFormatError, ["median depth", "divide it by 1000", "integer depth only"]),
    ("depth-negative", lambda d: io.read_depth_image(_depth_frame(d, -VIEW.depth - 1)), FileFormatError, ["negative", ">= 0"]),
    ("write-cloud-shape", lambda d: io.write_point_cloud(d / "a.ply", np.zeros((5, 2))), ShapeError, ["(N, 3)", "(5, 2)"]),
    ("write-cloud-under-file", lambda d: io.write_point_cloud(_write(d, "f", "x") / "a.ply", PTS), InvalidInputError, ["cannot write", "a.ply", "writable folder"]),
    ("write-cloud-format", lambda d: io.write_point_cloud(d / "a.xyz", PTS), FileFormatError, ["'.xyz'", ".ply"]),
    ("write-depth-negative", lambda d: io.write_depth_png(d / "a.png", -np.ones((4, 4))), InvalidInputError, ["depth", ">= 0"]),
    ("write-mesh-format", lambda d: io.write_mesh(d / "a.abc", BOX), FileFormatError, ["'.abc'", ".obj"]),
    ("mesh-missing", lambda d: io.read_mesh(d / "none.obj"), MissingFileError, ["none.obj"]),
    # --- perception ------------------------------------------------------------------------
    ("segmentation-crease", lambda d: perception.SegmentationConfig(crease_threshold=-0.1), ConfigError, ["crease_threshold", "> 0"]),
    ("segmentation-crease-weak", lambda d: perception.SegmentationConfig(crease_weak=1.5), ConfigError, ["crease_weak", "(0, 1]"]),
    ("segmentation-crease-scale", lambda d: perception.SegmentationConfig(crease_scale_px=0), ConfigError, ["crease_scale_px", ">= 1"]),
    ("segment-no-table-without-pose", lambda d: perception.segment(np.random.default_rng(0).uniform(0.5, 2.0, (CAM.height, CAM.width)), symjax.Camera.create(CAM.K, np.eye(4), CAM.width, CAM.height)), DegenerateGeometryError, ["no table", "min_table_fraction"]),
    ("segmentation-crease-step", lambda d: perception.SegmentationConfig(crease_max_step=0.0), ConfigError, ["crease_max_step", "> 0"]),
    ("segmentation-claim-dropouts", lambda d: perception.SegmentationConfig(claim_dropouts_px=-1), ConfigError, ["claim_dropouts_px", ">= 0", "-1"]),
    ("segmentation-claim-dropouts-type", lambda d: perception.SegmentationConfig(claim_dropouts_px=2.5), ConfigError, ["claim_dropouts_px", "2.5"]),
    ("segmentation-split-bridges", lambda d: perception.SegmentationConfig(split_bridges_px=-2), ConfigError, ["split_bridges_px", ">= 0", "-2"]),
    ("segmentation-split-bridges-type", lambda d: perception.SegmentationConfig(split_bridges_px=1.5), ConfigError, ["split_bridges_px", "1.5"]),
    ("segmentation-fragments", lambda d: perception.SegmentationConfig(fragment_px=-2), ConfigError, ["fragment_px", ">= 0", "-2"]),
    ("segmentation-fragments-type", lambda d: perception.SegmentationConfig(fragment_px=1.5), ConfigError, ["fragment_px", "1.5"]),
    ("segmentation-round-margin", lambda d: perception.SegmentationConfig(round_margin=-0.004), ConfigError, ["round_margin", ">= 0", "-0.004"]),
    ("segmentation-round-margin-nan", lambda d: perception.SegmentationConfig(round_margin=float("nan")), ConfigError, ["round_margin", "nan"]),
    ("segmentation-halves-extent", lambda d: perception.SegmentationConfig(halves_extent=-0.15), ConfigError, ["halves_extent", ">= 0", "-0.15"]),
    ("segmentation-level-top-px", lambda d: perception.SegmentationConfig(level_top_px=-6), ConfigError, ["level_top_px", ">= 0", "-6"]),
    ("segmentation-halves-extent-inf", lambda d: perception.SegmentationConfig(halves_extent=float("inf")), ConfigError, ["halves_extent", "inf"]),
    ("segmentation-round-residual", lambda d: perception.SegmentationConfig(round_residual=0.0), ConfigError, ["round_residual", "> 0", "0.0"]),
    ("segmentation-colour-weight", lambda d: perception.SegmentationConfig(colour_weight=-1.0), ConfigError, ["colour_weight", ">= 0", "-1.0"]),
    ("segmentation-colour-concavity", lambda d: perception.SegmentationConfig(colour_concavity=float("nan")), ConfigError, ["colour_concavity", "finite"]),
    ("segment-rgb-shape", lambda d: perception.segment(np.ones((CAM.height, CAM.width)), CAM, rgb=np.zeros((4, 4, 3), np.uint8)), ShapeError, ["rgb", "(H, W, 3)", "(4, 4, 3)"]),
    ("clutter-kind", lambda d: clutter_scene(("box", "teapot")), InvalidInputError, ["'teapot'", "box", "can", "bottle"]),
    ("clutter-arrangement", lambda d: clutter_scene(("box", "can"), arrangement="pile"), InvalidInputError, ["'pile'", "side_by_side", "front_back", "cluster"]),
    ("segmentation-round-objects", lambda d: perception.SegmentationConfig(round_objects="yes"), ConfigError, ["round_objects", "'yes'", "true or false"]),
    ("segmentation-unclaimed-occluders", lambda d: perception.SegmentationConfig(unclaimed_occluders=1), ConfigError, ["unclaimed_occluders", "1", "true or false"]),
    ("clutter-fresh-count", lambda d: fresh_scenes(-3, 10_000), ConfigError, ["fresh scenes", ">= 0", "-3"]),
    ("clutter-fresh-examined-seed", lambda d: fresh_scenes(5, 100), ConfigError, ["seed > 567", "seed 100"]),
    ("bench-perception-symmetry-held-out", lambda d: _script_main("bench_perception")(["--symmetry-held-out"]), ConfigError, ["--symmetry-held-out", "--held-out-scenes"]),
    ("bench-perception-timing-only", lambda d: _script_main("bench_perception")(["--timing-only", "--fresh-scenes", "270"]), ConfigError, ["--timing-only", "drop --fresh-scenes"]),
    ("bench-perception-symmetry-fresh", lambda d: _script_main("bench_perception")(["--symmetry-fresh"]), ConfigError, ["--symmetry-fresh", "--fresh-scenes"]),
    ("segment-no-camera", lambda d: perception.segment(VIEW.depth), InvalidInputError, ["camera"]),
    ("segment-config", lambda d: perception.segment(PTS, config={"seed": 1}), ConfigError, ["SegmentationConfig", "dict"]),
    # --- grasp, hands, robots, decomposition -------------------------------------------------
    ("hand-unknown", lambda d: hands.load("shadow"), UnknownNameError, ["'shadow'", "barrett", "sdh"]),
    ("hand-type", lambda d: hands.as_hand(3), InvalidInputError, ["Hand", "int"]),
    ("robot-unknown", lambda d: robots.load("pr2"), UnknownNameError, ["'pr2'", "kth", "uji"]),
    ("motion-robot-unknown", lambda d: motion.PlanningScene("pr2"), UnknownNameError, ["'pr2'", "kth", "uji"]),
    ("motion-target-missing", lambda d: motion.PlanningScene("kth", {"a": _hulls()}, target="b"), UnknownNameError, ["target object", "'b'", "a"]),
    ("motion-object-duplicate", lambda d: motion.PlanningScene("kth", {"a": _hulls()}).add_object("a", _hulls()), InvalidInputError, ["'a'", "already"]),
    ("motion-object-empty", lambda d: motion.PlanningScene("kth").add_object("a", []), EmptyInputError, ["hulls"]),
    ("motion-object-nan", lambda d: motion.PlanningScene("kth").add_object("a", [(np.full((4, 3), np.nan), np.zeros((4, 3), int))]), InvalidInputError, ["NaN"]),
    ("motion-object-pose-shape", lambda d: motion.PlanningScene("kth").add_object("a", _hulls(), np.eye(3)), ShapeError, ["(4, 4)", "(3, 3)"]),
    ("motion-move-unknown", lambda d: motion.PlanningScene("kth").move_object("z", np.eye(4)), UnknownNameError, ["'z'"]),
    ("motion-pose-nan", lambda d: motion.GraspPose.from_poses(np.full((4, 4), np.nan), np.eye(4)), InvalidInputError, ["pregrasp", "NaN"]),
    ("motion-pose-not-rotation", lambda d: motion.GraspPose.from_poses(np.eye(4), np.diag([2.0, 1, 1, 1])), InvalidInputError, ["grasp", "rotation"]),
    ("motion-grasp-nan", lambda d: motion.plan_arm(motion.PlanningScene("uji"), _nan_grasp()), InvalidInputError, ["NaN", "pregrasp"]),
    ("motion-start-shape", lambda d: motion.plan_arm(motion.PlanningScene("uji"), _grasp(), start=np.zeros(3)), ShapeError, ["(7,)", "(3,)"]),
    ("motion-start-nan", lambda d: motion.plan_arm(motion.PlanningScene("uji"), _grasp(), start=np.full(7, np.nan)), InvalidInputError, ["NaN"]),
    ("segment-depth-camera-tuple", lambda d: perception.segment((np.zeros((CAM.height, CAM.width)), CAM)), InvalidInputError, ["not a numeric array", "segment(depth, camera)"]),
    ("scan-scene-camera-robot", lambda d: datasets.head_camera("pr2"), UnknownNameError, ["'pr2'", "kth"]),
    ("candidates-take-range", lambda d: _cands().take([10**6]), InvalidInputError, ["out of range"]),
    ("candidates-take-mask", lambda d: _cands().take(np.ones(3, bool)), ShapeError, ["mask", "shape"]),
    ("candidates-take-float", lambda d: _cands().take([0.5]), InvalidInputError, ["integers", "float"]),
    ("candidates-concatenate-empty", lambda d: grasp.Candidates.concatenate([]), InvalidInputError, ["non-empty list"]),
    ("grasp-plan-scene-hand", lambda d: grasp.plan(BOX, hands.load("sdh"), "uji", scene=grasp.build_scene(_hulls(), hands.load("barrett"))), InvalidInputError, ["GraspScene", "same hand"]),
    ("decomposition-move-nan", lambda d: _decomposition().transformed(np.full((4, 4), np.nan)), InvalidInputError, ["decomposition pose", "NaN"]),
    ("decomposition-move-shape", lambda d: _decomposition().transformed(np.eye(3)), ShapeError, ["decomposition pose"]),
    ("observation-normals-camera", lambda d: surface.oriented_observation(PTS, np.zeros(2)), ShapeError, ["camera", "(3,)"]),
    ("poisson-table-type", lambda d: surface.poisson_reconstruct(PTS, _up_normals(), table=0.75), InvalidInputError, ["TablePlane", "float"]),
    ("poisson-tables-count", lambda d: surface.poisson_reconstruct_batch([(PTS, _up_normals())], tables=[None, None]), InvalidInputError, ["2 tables", "1 views"]),
    ("view-true-mesh-real", lambda d: datasets.View.from_observation(VIEW, "box/real").true_mesh(), InvalidInputError, ["no ground truth", "real"]),
    ("scan-scene-n-objects", lambda d: datasets.scan_scene("kth", 0), InvalidInputError, ["n_objects", "[1, 6]", "0"]),
    ("scan-scene-too-many", lambda d: datasets.scan_scene("kth", 3, objects=("025_mug",)), InvalidInputError, ["n_objects", "[1, 1]"]),
    ("scan-scene-robot", lambda d: datasets.scan_scene("pr2", 2), UnknownNameError, ["'pr2'", "kth"]),
    ("motion-start-joint-limit", lambda d: motion.plan_arm(motion.PlanningScene("uji"), _grasp(), start=np.full(7, 4.0)), InvalidInputError, ["start joint 0", "outside its range"]),
    ("motion-closing-sweep-steps", lambda d: __import__("symjax.motion.closing", fromlist=["x"]).closing_contacts(motion.PlanningScene("uji"), np.zeros(3), 1), ShapeError, ["full configuration", "(15,)"]),
    ("motion-start-in-collision", lambda d: motion.plan_arm(_blocked_scene(), _grasp()), motion.StartInCollisionError, ["start configuration", "obj/block"]),
    ("motion-grasp-type", lambda d: motion.plan_arm_batch(motion.PlanningScene("uji"), [3]), InvalidInputError, ["GraspPose", "int"]),
    ("motion-grasp-source", lambda d: motion.grasp_poses("plan"), InvalidInputError, ["GraspPlan", "str"]),
    ("motion-config-range", lambda d: motion.MotionConfig(velocity_scale=1.5), ConfigError, ["velocity_scale", "(0, 1]"]),
    ("motion-config-type", lambda d: motion.plan_arm(motion.PlanningScene("uji"), _grasp(), config={"a": 1}), ConfigError, ["MotionConfig", "dict"]),
    ("motion-replay-failed", lambda d: motion.replay(motion.plan_arm(motion.PlanningScene("uji"), _far_grasp()), motion.PlanningScene("uji")), InvalidInputError, ["'ok'"]),
    ("motion-segment-unknown", lambda d: motion.plan_arm(motion.PlanningScene("uji"), _grasp()).segment("dance"), UnknownNameError, ["'dance'", "approach"]),
    ("generate-method", lambda d: grasp.generate(BOX, "gpd"), UnknownNameError, ["'gpd'", "kth", "openrave"]),
    ("generate-hand-name", lambda d: grasp.generate(BOX, "uji", hand="shadow"), UnknownNameError, ["'shadow'", "sdh"]),
    ("generate-mesh-type", lambda d: grasp.generate("box", "uji"), InvalidInputError, ["mesh", "trimesh.Trimesh", "str"]),
    ("generate-mesh-nan", lambda d: grasp.generate((BOX.vertices * np.nan, BOX.faces), "uji"), DegenerateGeometryError, ["NaN or inf"]),
    ("generate-float-faces", lambda d: grasp.generate((BOX.vertices, BOX.faces * 1.0), "uji"), ShapeError, ["integer", "float64"]),
    ("generate-grasp-points", lambda d: grasp.generate(BOX, "uji", grasp_points=np.zeros((2, 3))), InvalidInputError, ["grasp_points", "'kth'"]),
    ("generate-preshape", lambda d: grasp.generate(BOX, "uji", config=grasp.CandidateConfig(preshapes=(9,)), hand=SDH), InvalidInputError, ["9", "expected 0 to"]),
    ("simulate-hand-unknown", lambda d: grasp.simulate(BOX, _cands(), "shadow"), UnknownNameError, ["'shadow'", "sdh"]),
    ("simulate-backend", lambda d: grasp.simulate(BOX, _cands(), SDH, backend="physx"), UnknownNameError, ["'physx'", "mjx", "mujoco"]),
    ("simulate-candidates-type", lambda d: grasp.simulate(BOX, np.zeros((3, 3)), SDH), InvalidInputError, ["Candidates", "ndarray"]),
    ("simulate-approach-length", lambda d: grasp.simulate(BOX, _cands(approach=_cands().approach * 5), SDH), InvalidInputError, ["not unit length", "5"]),
    ("simulate-approach-zero", lambda d: grasp.simulate(BOX, _cands(approach=_cands().approach * 0), SDH), InvalidInputError, ["not unit length", "0"]),
    ("simulate-nan", lambda d: grasp.simulate(BOX, _cands(point=_cands().point * np.nan), SDH), InvalidInputError, ["NaN or inf"]),
    ("simulate-preshape", lambda d: grasp.simulate(BOX, _cands(preshape=_cands().preshape + 7), SDH), InvalidInputError, ["pre-shape", "expected 0 to", "pinch"]),
    ("rank-by", lambda d: grasp.rank(None, by="beauty"), UnknownNameError, ["'beauty'", "quality", "success"]),
    ("build-scene-hand", lambda d: grasp.build_scene(BOX, "shadow"), UnknownNameError, ["'shadow'", "sdh"]),
    ("probe-points-preshape", lambda d: hands.probe_points(SDH, "fist"), UnknownNameError, ["'fist'", "pinch"]),
    ("mesh-key-type", lambda d: decompose.mesh_key("box"), InvalidInputError, ["mesh", "str"]),
    ("plan-mesh-type", lambda d: grasp.plan(42, SDH), InvalidInputError, ["mesh", "int"]),
    ("inside-mesh-type", lambda d: grasp.inside_mesh(PTS, "mesh"), InvalidInputError, ["mesh", "str"]),
    ("cast-rays-shape", lambda d: grasp.cast_rays(PTS, PTS[:3], BOX), ShapeError, ["origins", "directions", "must match"]),
    ("decompose-faces", lambda d: decompose.decompose((BOX.vertices, BOX.faces + 99), use_cache=False), ShapeError, ["face indices", "[0, 8)"]),
    # --- data sets -------------------------------------------------------------------------
    ("benchmark-unknown", lambda d: benchmark("no_such_object"), UnknownNameError, ["no_such_object"]),
    ("load-object-missing", lambda d: load_object(d / "none.obj"), MissingFileError, ["none.obj"]),
    # --- grasp cycle and study ----------------------------------------------------------------
    ("cycle-scene-type", lambda d: cycle.clear_table("scene", "kth"), InvalidInputError, ["ScanScene", "DepthFrame", "str"]),
    ("cycle-robot-mismatch", lambda d: cycle.clear_table(_scan_scene("uji"), "kth"), InvalidInputError, ["'uji'", "'kth'"]),
    ("cycle-robot-unknown", lambda d: cycle.clear_table(_scan_scene("uji"), "pr2"), UnknownNameError, ["'pr2'", "kth"]),
    ("cycle-truth-on-frame", lambda d: cycle.clear_table(io.DepthFrame(np.zeros((CAM.height, CAM.width), np.float32), CAM), "kth", cycle.CycleConfig(mode="T")), InvalidInputError, ["mode T", "ScanScene"]),
    ("cycle-config-mode", lambda d: cycle.CycleConfig(mode="X"), ConfigError, ["mode", "'X'"]),
    ("cycle-config-grasps", lambda d: cycle.CycleConfig(arm_grasps=-1), ConfigError, ["arm_grasps = -1", ">= 0"]),
    ("cycle-config-dropoff", lambda d: cycle.CycleConfig(dropoff_radius=-0.1), ConfigError, ["dropoff_radius", "> 0"]),
    ("cycle-config-type", lambda d: cycle.clear_table(_scan_scene("kth"), "kth", {"mode": "C"}), ConfigError, ["CycleConfig", "dict"]),
    ("cycle-scenes-count", lambda d: __import__("symjax.cycle.batch", fromlist=["x"]).scene_specs(("kth",), 0, 0, (2, 5)), InvalidInputError, [">= 1 scenes", "got 0"]),
    ("cycle-scenes-objects", lambda d: __import__("symjax.cycle.batch", fromlist=["x"]).scene_specs(("kth",), 2, 0, (4, 9)), InvalidInputError, ["max objects <= 6", "(4, 9)"]),
    ("cycle-out-is-file", lambda d: __import__("symjax.cycle.batch", fromlist=["x"]).run_scenes([], ("C",), cycle.CycleConfig(), _write(d, "f", "x")), FileFormatError, ["is a file", "folder"]),
    ("cycle-picture-none", lambda d: __import__("symjax.cycle.pictures", fromlist=["x"]).cycle_picture(_empty_report(), d / "p.png"), InvalidInputError, ["no pictures", "pictures=True"]),
    ("scene-rearranged-poses", lambda d: datasets.rearranged(_scan_scene(), [0], np.eye(3)[None]), InvalidInputError, ["(1, 4, 4)", "(1, 3, 3)"]),
    ("scene-rearranged-index", lambda d: datasets.rearranged(_scan_scene(), [3], np.eye(4)[None]), InvalidInputError, ["keep", "[0, 1)", "[3]"]),
    ("study-config-top", lambda d: study.StudyConfig(top=0), ConfigError, ["top", ">= 1"]),
    ("study-config-generator", lambda d: study.StudyConfig(hands=(("sdh", "magic"),)), ConfigError, ["'magic'", "kth"]),
    ("study-out-is-file", lambda d: study.run_study(study.StudyConfig(out_dir=str(_write(d, "f", "x")))), FileFormatError, ["is a file", "folder"]),
    ("grasp-obstacles-one-hull", lambda d: grasp.build_scene(_hulls(), SDH, obstacles=_hulls()[0]), InvalidInputError, ["obstacles", "[(vertices, faces)]"]),
    ("grasp-obstacles-nan", lambda d: grasp.build_scene(_hulls(), SDH, obstacles=[(np.full((4, 3), np.nan), np.zeros((4, 3), int))]), InvalidInputError, ["obstacle", "finite vertices"]),
    ("grasp-obstacles-type", lambda d: grasp.plan(BOX, SDH, "uji", obstacles="box"), InvalidInputError, ["obstacles", "str"]),
    ("motion-config-approach-margin", lambda d: motion.MotionConfig(approach_margin=0.01), ConfigError, ["approach_margin", "check_margin"]),
    ("motion-config-obstacle-margin", lambda d: motion.MotionConfig(obstacle_margin=0.002), ConfigError, ["obstacle_margin", "check_margin"]),
    ("cli-clear-table-objects", lambda d: _cli("clear-table", "--min-objects", "7", "--out-dir", str(d / "o")), _CliError, ["exit 2", "min objects", "(7, 5)"]),
    ("cli-clear-table-robot", lambda d: _cli("clear-table", "--robots", "pr2", "--out-dir", str(d / "o")), _CliError, ["exit 2", "pr2"]),
    ("cli-eval-completion-mode", lambda d: _cli("eval", "--completion.mode", "mirrors", "--out-dir", str(d / "o")), _CliError, ["exit 2", "mirrors"]),
    ("cli-eval-revolution-copies", lambda d: _cli("eval", "--completion.revolution-copies", "1", "--out-dir", str(d / "o")), _CliError, ["exit 2", "revolution_copies", ">= 2"]),
    ("cli-study-top", lambda d: _cli("study", "--top", "0", "--out-dir", str(d / "o")), _CliError, ["exit 2", "top", ">= 1"]),
    # --- grasp training data (symjax generate) ---------------------------------------------------
    ("data-unknown-object", lambda d: _generate(d, objects=("no_such_scan",)), UnknownNameError, ["'no_such_scan'", "025_mug"]),
    ("data-mesh-folder-missing", lambda d: _generate(d, objects=(), mesh_folder=str(d / "nope")), MissingFileError, ["mesh_folder", "nope", "not a folder"]),
    ("data-mesh-folder-empty", lambda d: _generate(d, objects=(), mesh_folder=str(_write(d, "m/readme.txt", "x").parent)), MissingFileError, ["holds no", ".obj"]),
    ("data-mesh-unreadable", lambda d: _generate(d, objects=(), mesh_folder=_mesh_folder(d, **{"bad.ply": b"ply\nformat nonsense\n"})), FileFormatError, ["bad.ply"]),
    ("data-mesh-scale", lambda d: _generate(d, objects=(), mesh_folder=_mesh_folder(d, **{"cube.obj": _box_obj(50.0)})), InvalidInputError, ["cube.obj", "50 m across", "generate.scales"]),
    ("data-scales-unknown-file", lambda d: _generate(d, objects=(), mesh_folder=_mesh_folder(d, **{"cube.obj": _box_obj(0.05)}), scales=(("cone.obj", 0.001),)), InvalidInputError, ["generate.scales", "cone.obj"]),
    ("data-hand-unknown", lambda d: DatasetSpec(hands=("shadow",)), ConfigError, ["'shadow'", "sdh", "parallel_jaw"]),
    ("data-shares-sum", lambda d: DatasetSpec(shares=(("kth", 0.8), ("uji", 0.5))), ConfigError, ["add up to 1.300", "at most 1"]),
    ("data-shares-generator", lambda d: DatasetSpec(shares=(("dense", 0.5),)), ConfigError, ["'dense'", "openrave"]),
    ("data-candidates-zero", lambda d: DatasetSpec(n_candidates=0), ConfigError, ["n_candidates", ">= 1", "got 0"]),
    ("data-no-objects", lambda d: DatasetSpec(objects=()), ConfigError, ["no objects", "mesh_folder"]),
    ("data-dense-cone", lambda d: DenseSamplerConfig(cone_deg=95.0), ConfigError, ["cone_deg", "[0, 90)", "95"]),
    ("data-out-under-file", lambda d: _generate(d, out=_write(d, "f", "x") / "sub"), OutputError, ["cannot be written", "writable folder"]),
    ("data-out-is-file", lambda d: _generate(d, out=_write(d, "f", "x")), OutputError, ["is a file", "folder"]),
    ("data-load-missing", lambda d: load_grasps(d / "x.h5"), MissingFileError, ["x.h5", "does not exist"]),
    ("data-load-not-hdf5", lambda d: load_grasps(_write(d, "x.h5", "junk")), FileFormatError, ["x.h5", "not a readable HDF5"]),
    ("data-load-incomplete", lambda d: load_grasps(_incomplete_h5(d)), FileFormatError, ["half.h5", "incomplete"]),
    ("cli-generate-object", lambda d: _cli("generate", "--generate.objects", "no_such_scan", "--out-dir", str(d / "o")), _CliError, ["exit 2", "no_such_scan"]),
    ("cli-generate-candidates", lambda d: _cli("generate", "--generate.n-candidates", "0", "--out-dir", str(d / "o")), _CliError, ["exit 2", "n_candidates", ">= 1"]),
    # --- command line ------------------------------------------------------------------------
    ("cli-unknown-command", lambda d: _cli("evaluate", process=True), _CliError, ["unknown command 'evaluate'", "eval"]),
    ("cli-preset", lambda d: _cli("eval", "--config", "papr"), _CliError, ["exit 2", "unknown preset 'papr'", "paper"]),
    ("cli-int-flag", lambda d: _cli("eval", "--n-samples", "lots"), _CliError, ["exit 2", "lots", "int"]),
    ("cli-range", lambda d: _cli("eval", "--n-samples", "3"), _CliError, ["exit 2", "n_samples", ">= 100", "got 3"]),
    ("cli-nan-weight", lambda d: _cli("eval", "--symmetry.w-outside", "nan"), _CliError, ["exit 2", "w_outside", "finite"]),
    ("cli-out-under-file", lambda d: _cli("eval", "--out-dir", str(_write(d, "f", "x") / "sub")), _CliError, ["exit 2", "cannot write", "output folder"]),
    ("cli-data-is-file", lambda d: _cli("eval", "--data", str(_write(d, "f.crd", "1")), "--out-dir", str(d / "o")), _CliError, ["exit 2", "is a file", "folder"]),
    ("cli-demo-out", lambda d: _cli("demo", "--out-dir", str(_write(d, "g", "x") / "sub")), _CliError, ["exit 2", "cannot write"]),
]
# fmt: on


def test_the_matrix_is_large_enough():
    assert len(CASES) >= 80
    assert len({c[0] for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input(case, tmp_path):
    _, call, error, needles = case
    with pytest.raises(SymjaxError) as info:
        call(tmp_path)
    assert type(info.value) is error, f"{type(info.value).__name__}: {info.value}"
    message = str(info.value)
    for needle in needles:
        assert needle in message, (needle, message)
