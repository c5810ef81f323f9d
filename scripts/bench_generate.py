"""Benchmark of ``symjax generate`` (issue 16): labelled grasps per second end to end.

Per hand, one YCB object (default the mustard bottle) and 2,000 candidates (ACRONYM's count):
the whole shard (candidates from the paper's generators and the dense sampler, rollouts on the
true object, the HDF5 file) timed with ``generate_dataset`` into a fresh folder, no partial
views. Compile and run are apart: a first 64-candidate shard warms up the jitted kernels and
fills the coacd cache (``compile_s``); the timed shard is the second. The reference, timed in the
same run, is ``grasp.simulate`` of the same 2,000 candidates on the same scene: the rollouts
alone (``ratio_to_rollouts`` = end-to-end rate / rollout rate). A ``views`` row times one
object's partial views (render, batched search, Mir7, plans on each completion scored on the
truth) per view and hand.

One JSON line per case on stdout; all rows go to ``bench/results/generate.json`` (atomically).

Usage: ``python scripts/bench_generate.py [--hands sdh barrett parallel_jaw] [--n 2000]``
"""

from __future__ import annotations

import dataclasses
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symjax.cli.common import PresetArgs, parse  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    hands: tuple[str, ...] = ("sdh", "barrett", "parallel_jaw")
    """Hands to benchmark."""
    object: str = "006_mustard_bottle"
    """The YCB object."""
    n: int = 2000
    """Candidates of the timed shard."""
    views: int = 2
    """Partial views of the views row (0: no views row)."""
    out: str = str(ROOT / "bench" / "results" / "generate.json")
    """Where the JSON lines go."""


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def main(argv=None) -> int:
    import jax
    import numpy as np

    from symjax import configs, grasp, hands
    from symjax._timing import JsonRows
    from symjax.data import DatasetSpec, GenerateConfig, generate_dataset, load_grasps
    from symjax.data.candidate_mix import mixed_candidates, shard_rng_seed
    from symjax.data.objects import load_entry, resolve_objects
    from symjax.decompose import decompose
    from symjax.table import TablePlane

    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_generate.py", __doc__)
    preset = configs.load(args.config)
    meta = {"machine": platform.machine(), "cpus": os.cpu_count(),
            "jax_backend": jax.default_backend(), "preset": args.config}  # fmt: skip
    emit = JsonRows(args.out, meta).emit

    ex = dataclasses.replace(preset.execution, progress=False)
    with tempfile.TemporaryDirectory() as tmp:
        for hand_name in args.hands:

            def cfg(n, views, out, hand_name=hand_name):
                spec = DatasetSpec(objects=(args.object,), hands=(hand_name,), n_candidates=n,
                                   views=views)  # fmt: skip
                return GenerateConfig.from_preset(preset, generate=spec, execution=ex,
                                                  out_dir=str(Path(tmp) / out))  # fmt: skip

            load0 = _load()
            t0 = time.perf_counter()
            generate_dataset(cfg(64, 0, f"warm_{hand_name}"), log=lambda s: None)
            compile_s = time.perf_counter() - t0
            c = cfg(args.n, 0, f"timed_{hand_name}")
            t0 = time.perf_counter()
            doc = generate_dataset(c, log=lambda s: None)
            run_s = time.perf_counter() - t0
            # Reference: the same candidates' rollouts alone, same scene, same run.
            (entry,) = resolve_objects(c.generate)
            mesh = load_entry(entry).mesh
            hand = hands.load(hand_name)
            table = TablePlane.horizontal(0.0)
            cands, _, _ = mixed_candidates(mesh, hand, c.generate, c.candidates, table,
                                           shard_rng_seed(0, entry.name, hand_name))  # fmt: skip
            scene = grasp.build_scene(decompose(mesh, c.decompose), hand, c.simulation, table=table)
            t0 = time.perf_counter()
            out = grasp.simulate(None, cands, hand, scene=scene, execution=ex)
            ref_s = time.perf_counter() - t0
            (shard,) = doc["shards"]
            rate = shard["n_grasps"] / run_s
            emit({
                "case": "shard", "hand": hand_name, "object": args.object,
                "n": shard["n_grasps"], "compile_s": round(compile_s, 2),
                "run_s": round(run_s, 2), "grasps_per_s": round(rate, 1),
                "floor_per_s": 40 if hand_name == "sdh" else None,
                "success_rate": shard["success_rate"],
                "candidates_by_generator": shard["candidates_by_generator"],
                "rollout_only_s": round(ref_s, 2),
                "rollout_only_per_s": round(len(cands) / ref_s, 1),
                "ratio_to_rollouts": round(rate / (len(cands) / ref_s), 3),
                "labels_match_reference": bool(np.array_equal(
                    load_grasps(Path(c.out_dir) / shard["file"]).success,
                    np.asarray(out.success, bool))),
                "load_avg": load0, "load_avg_end": _load(),
            })  # fmt: skip
        if args.views:
            hand_names = args.hands
            spec = DatasetSpec(objects=(args.object,), hands=hand_names, n_candidates=16,
                               views=args.views)  # fmt: skip
            base = GenerateConfig.from_preset(preset, generate=spec, execution=ex,
                                              out_dir=str(Path(tmp) / "views"))  # fmt: skip
            no_views = dataclasses.replace(
                base, generate=dataclasses.replace(spec, views=0),
                out_dir=str(Path(tmp) / "no_views"))  # fmt: skip
            load0 = _load()
            t0 = time.perf_counter()
            generate_dataset(no_views, log=lambda s: None)
            t1 = time.perf_counter()
            doc = generate_dataset(base, log=lambda s: None)
            t2 = time.perf_counter()
            per = (t2 - t1 - (t1 - t0)) / (args.views * len(hand_names))
            emit({
                "case": "views", "object": args.object, "hands": list(hand_names),
                "views": args.views, "seconds_with_views": round(t2 - t1, 2),
                "seconds_without": round(t1 - t0, 2), "seconds_per_view_and_hand": round(per, 2),
                "views_true_success": {r["hand"]: r["views_true_success"] for r in doc["shards"]},
                "load_avg": load0, "load_avg_end": _load(),
            })  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
