"""Benchmark of PlanGrasp rollouts (issue 8): candidates per second, MJX against C MuJoCo.

For SDH and Barrett on a coacd-decomposed mug (a hollow cylinder: 8 convex hulls), batches of
64, 512 and 4,096 candidates are rolled out with ``backend="mujoco"`` (C MuJoCo,
``mujoco.rollout`` on every core) and ``backend="mjx"`` (MuJoCo XLA, ``impl="jax"``: the
pure-JAX implementation, the one that runs on CPU and on any GPU; MJX-Warp needs an NVIDIA GPU
and the ``warp`` package). Compilation is timed apart from the rollouts: C MuJoCo's first call
compiles the small JAX control-schedule and label kernels; MJX's first chunk compiles the whole
rollout. Both backends see the same candidates in the same run, so every MJX row also reports
its success-label agreement with C MuJoCo and the count of diverged (NaN) rollouts.

On a CPU-only machine MJX runs only the batch sizes in ``--mjx-sizes`` (default 64): at the
measured 600-750 env-steps/s (2 cores) a 4,096 batch would take about 1.5 hours. A
``paper_budget`` row times 100 candidates end to end with the default backend (scene build and
compilation included): the paper's budget is a minute.

``--gpu`` is the one GPU command (issue 16): batches of 1,024, 4,096 and 16,384 with MJX-JAX
and MJX-Warp (``backend="mjx_warp"``, where ``mujoco-mjx[warp]`` is installed), the labels of
each batch's first 512 candidates against C MuJoCo (timed: the reference of the ratio), in
under 5 minutes (no case starts after ``--gpu-budget-s``, 270 s); rows go to ``--gpu-out``
(``bench/results/grasp_gpu.json``). Without a GPU it says so and stops, unless
the sizes are tiny (``--gpu --gpu-sizes 16``: a dry run of the same code on the CPU).

One JSON line per case on stdout; all rows go to ``bench/results/grasp.json`` (atomically).

Usage: ``python scripts/bench_grasp.py [--sizes 64 512 4096] [--mjx-sizes 64] [--hands sdh
barrett] [--out bench/results/grasp.json]`` or ``python scripts/bench_grasp.py --gpu``
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import jax
import numpy as np
import trimesh

from symjax import grasp, hands
from symjax._timing import JsonRows
from symjax.cli.common import PresetArgs, parse  # noqa: E402
from symjax.decompose import DecomposeConfig, decompose
from symjax.execution import ExecutionConfig
from symjax.grasp.config import CandidateConfig
from symjax.grasp.sim_config import SimulationConfig
from symjax.table import TablePlane

ROOT = Path(__file__).resolve().parents[1]


def mug() -> tuple[np.ndarray, np.ndarray]:
    m = trimesh.creation.annulus(0.03, 0.045, 0.1, sections=24)
    m.apply_translation([0.5, 0.0, 0.05])
    return np.asarray(m.vertices), np.asarray(m.faces)


def pool(v, f, hand, n: int) -> grasp.Candidates:
    """n candidates: all three generators' outputs, tiled in a fixed shuffled order."""
    cfg = CandidateConfig(n_approach=10, n_rays=512, n_rolls=4)
    table = TablePlane.horizontal(0.0)
    parts = [grasp.generate((v, f), m, config=cfg, table=table, hand=hand).candidates
             for m in grasp.METHODS]  # fmt: skip
    allc = jax.tree_util.tree_map(lambda *xs: np.concatenate(xs), *parts)
    idx = np.random.default_rng(0).permutation(len(allc))
    idx = np.resize(idx, n)
    return jax.tree_util.tree_map(lambda x: np.asarray(x)[idx], allc)


def _take(c, n):
    return jax.tree_util.tree_map(lambda x: x[:n], c)


def bench_mujoco(scene, cands, hand, n_steps):
    t0 = time.perf_counter()
    grasp.simulate(None, _take(cands, 8), hand, backend="mujoco", scene=scene)
    warm = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = grasp.simulate(None, cands, hand, backend="mujoco", scene=scene).numpy()
    run = time.perf_counter() - t0
    return out, {"compile_s": warm, "run_s": run}


def bench_mjx(scene, cands, hand, ex):
    chunk = ex.simulation_chunk
    first = _take(cands, min(len(cands), chunk))
    t0 = time.perf_counter()
    grasp.simulate(None, first, hand, backend="mjx", scene=scene, execution=ex)
    first_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = grasp.simulate(None, cands, hand, backend="mjx", scene=scene, execution=ex).numpy()
    run = time.perf_counter() - t0
    n_chunks = -(-len(cands) // chunk)
    return out, {"compile_s": max(first_s - run / n_chunks, 0.0), "run_s": run}


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    sizes: tuple[int, ...] = (64, 512, 4096)
    """Candidate batch sizes of the C MuJoCo rows."""
    mjx_sizes: tuple[int, ...] | None = None
    """Batch sizes of the MJX rows (None: the C MuJoCo sizes on a GPU, 64 on a CPU)."""
    hands: tuple[str, ...] = ("sdh", "barrett")
    """Hands to benchmark."""
    out: str = str(ROOT / "bench" / "results" / "grasp.json")
    """Where the JSON lines go."""
    simulation: SimulationConfig = dataclasses.field(default_factory=SimulationConfig)
    """The rollouts."""
    gpu: bool = False
    """GPU mode: batches of 1,024, 4,096 and 16,384 with MJX-JAX and MJX-Warp (where installed),
    each against C MuJoCo on its first 512 candidates; stops starting cases after 270 s."""
    gpu_sizes: tuple[int, ...] = (1024, 4096, 16384)
    """Batch sizes of GPU mode."""
    gpu_budget_s: float = 270.0
    """GPU mode starts no case after this many seconds."""
    gpu_out: str = str(ROOT / "bench" / "results" / "grasp_gpu.json")
    """Where GPU mode's JSON lines go."""


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_grasp.py", __doc__)
    if args.gpu:
        return bench_gpu(args)
    gpu = jax.default_backend() == "gpu"
    mjx_sizes = args.mjx_sizes if args.mjx_sizes is not None else (args.sizes if gpu else [64])
    meta = {
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "jax_backend": jax.default_backend(),
        "device": str(jax.devices()[0]),
        "mjx_impl": "jax",
    }
    v, f = mug()
    t0 = time.perf_counter()
    hulls = decompose((v, f), DecomposeConfig(max_hulls=8, max_vertices=32))
    decompose_s = time.perf_counter() - t0
    emit = JsonRows(args.out, meta).emit

    for hand_name in args.hands:
        hand = hands.load(hand_name)
        # Paper budget: 100 candidates, end to end, default backend, nothing warmed up.
        t0 = time.perf_counter()
        scene100 = grasp.build_scene(hulls, hand, args.simulation)
        c100 = pool(v, f, hand, 100)
        out = grasp.simulate(
            None, c100, hand, scene=scene100, execution=ExecutionConfig(simulation_chunk=128)
        ).numpy()
        emit({
            "case": "paper_budget", "hand": hand_name, "backend": out.backend, "n": 100,
            "seconds_total": time.perf_counter() - t0, "under_a_minute":
            time.perf_counter() - t0 < 60.0, "success_rate": float(out.success.mean()),
            "diverged": int(out.diverged.sum()), "n_hulls": len(hulls.hulls),
            "decompose_s": decompose_s,
        })  # fmt: skip
        for n in args.sizes:
            cfg = args.simulation
            ex = ExecutionConfig(simulation_chunk=min(n, 512))
            scene = grasp.build_scene(hulls, hand, cfg)
            cands = pool(v, f, hand, n)
            steps = cfg.n_steps
            ref, t = bench_mujoco(scene, cands, hand, steps)
            ref_rate = n / t["run_s"]
            emit({
                "case": "rollout", "hand": hand_name, "backend": "mujoco", "n": n,
                "compile_s": t["compile_s"], "run_s": t["run_s"],
                "candidates_per_s": n / t["run_s"], "env_steps_per_s": n * steps / t["run_s"],
                "steps_per_rollout": steps, "threads": os.cpu_count(),
                "success_rate": float(ref.success.mean()),
                "force_closure_rate": float(ref.force_closure.mean()),
                "diverged": int(ref.diverged.sum()),
                "nan_in_outputs": bool(any(np.isnan(np.asarray(x, float)).any()
                                           for x in jax.tree_util.tree_leaves(ref))),
            })  # fmt: skip
            if n not in mjx_sizes:
                continue
            out, t = bench_mjx(scene, cands, hand, ex)
            emit({
                "case": "rollout", "hand": hand_name, "backend": "mjx", "n": n,
                "chunk": ex.simulation_chunk, "compile_s": t["compile_s"], "run_s": t["run_s"],
                "candidates_per_s": n / t["run_s"], "env_steps_per_s": n * steps / t["run_s"],
                "steps_per_rollout": steps, "success_rate": float(out.success.mean()),
                "force_closure_rate": float(out.force_closure.mean()),
                "diverged": int(out.diverged.sum()),
                "nan_in_outputs": bool(any(np.isnan(np.asarray(x, float)).any()
                                           for x in jax.tree_util.tree_leaves(out))),
                "ratio_to_mujoco": (n / t["run_s"]) / ref_rate,
                "success_agreement_with_mujoco": float((out.success == ref.success).mean()),
                "closure_agreement_with_mujoco":
                    float((out.force_closure == ref.force_closure).mean()),
            })  # fmt: skip


def bench_gpu(args: Args) -> int:
    """Candidates per second of both MJX implementations at large batches (one JSON line each)."""
    from symjax.grasp.backends import warp_backend

    t_start = time.perf_counter()
    impls = ["mjx"] + (["mjx_warp"] if warp_backend.available() else [])
    meta = {"machine": platform.machine(), "cpus": os.cpu_count(),
            "jax_backend": jax.default_backend(), "devices": [str(d) for d in jax.devices()],
            "load_avg": [round(x, 2) for x in os.getloadavg()]}  # fmt: skip
    if jax.default_backend() != "gpu" and max(args.gpu_sizes) > 64:
        print(json.dumps({"case": "gpu", "skipped": "no GPU: JAX runs on the CPU (a dry run"
                          " takes --gpu-sizes 16)", **meta}))  # fmt: skip
        return 0
    if "mjx_warp" not in impls:
        skip = "MuJoCo Warp not installed (pip install 'symjax[warp]')"
        print(json.dumps({"case": "gpu", "backend": "mjx_warp", "skipped": skip}))
    v, f = mug()
    hulls = decompose((v, f), DecomposeConfig(max_hulls=8, max_vertices=32))
    results = JsonRows(args.gpu_out)
    for hand_name in args.hands:
        hand = hands.load(hand_name)
        scene = grasp.build_scene(hulls, hand, args.simulation)
        for n in args.gpu_sizes:
            cands = pool(v, f, hand, n)
            sub = _take(cands, 512)
            grasp.simulate(None, _take(sub, 8), hand, backend="mujoco", scene=scene)
            t0 = time.perf_counter()
            ref = grasp.simulate(None, sub, hand, backend="mujoco", scene=scene).numpy()
            ref_s = time.perf_counter() - t0
            for impl in impls:
                if time.perf_counter() - t_start > args.gpu_budget_s:
                    skip = f"past the {args.gpu_budget_s:g} s budget"
                    print(json.dumps({"case": "gpu", "hand": hand_name, "backend": impl, "n": n,
                                      "skipped": skip}))  # fmt: skip
                    continue
                ex = ExecutionConfig(simulation_chunk=n)
                t0 = time.perf_counter()
                grasp.simulate(None, _take(cands, n), hand, backend=impl, scene=scene, execution=ex)
                first = time.perf_counter() - t0
                t0 = time.perf_counter()
                out = grasp.simulate(None, cands, hand, backend=impl, scene=scene,
                                     execution=ex).numpy()  # fmt: skip
                run = time.perf_counter() - t0
                agree = float((out.success[:512] == ref.success).mean())
                row = {"case": "gpu_rollout", "hand": hand_name, "backend": impl, "n": n,
                       "compile_s": round(max(first - run, 0.0), 2), "run_s": round(run, 3),
                       "candidates_per_s": round(n / run, 1), "target_per_s": 5000,
                       "success_rate": float(out.success.mean()),
                       "diverged": int(out.diverged.sum()),
                       "success_agreement_with_mujoco_512": agree,
                       "reference_mujoco_per_s": round(len(sub.point) / ref_s, 1),
                       "ratio_to_mujoco": round(n / run / (len(sub.point) / ref_s), 2),
                       **meta}  # fmt: skip
                results.emit(row)
    print(json.dumps({"case": "gpu_total", "seconds": round(time.perf_counter() - t_start, 1)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
