"""``symjax eval``: the paper's mesh evaluation (Section V-A/V-B) with figures and a report.

For every view: symmetry search on the observation, Poisson meshes of the completed cloud at
depth 5 (Mir5) and 7 (Mir7), the Delaunay baseline of the observed points (Del), and each mesh
against the ground truth (mean/variance of the deviation, centroid error over the oriented-box
diagonal), plus the symmetry plane error and per-stage timings. Writes under --out-dir:
views/*.json (one file per view; a rerun resumes), results.csv/.json, fig10-12 and gallery.png,
report.md. Default data: the embedded 128-view benchmark (rendered into the cache on first use);
--data DIR evaluates a folder in the paper's KTH database layout (no ground truth there).
--subset items: a data set id (025_mug), a view (025_mug/045), an orientation (90deg) or a count
N of views, e.g. --subset 4, --subset 025_mug 003_cracker_box, --subset 0deg 180deg 10.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Annotated

import tyro

from symjax.cli.common import PresetArgs, parse, run
from symjax.evaluation.config import EvalConfig

__all__ = ["EvalCommand", "main"]


@dataclasses.dataclass(frozen=True)
class EvalCommand(PresetArgs):
    """Runs the paper's evaluation.

    Attributes:
        evaluation: The evaluation's settings.
    """

    evaluation: Annotated[EvalConfig, tyro.conf.arg(name="")] = dataclasses.field(
        default_factory=EvalConfig
    )


def _body(argv: list[str]) -> int:
    from symjax.evaluation import run_evaluation

    cfg = parse(EvalCommand, argv, "symjax eval", __doc__).evaluation
    t0 = time.perf_counter()
    out = run_evaluation(cfg)
    s = out["summary"]
    for m in cfg.methods:
        v = s["methods"][m]
        if math.isfinite(v["dev_mean_mm"]):
            print(
                f"{m:5s} mean deviation {v['dev_mean_mm']:.2f} mm, centroid error"
                f" {100 * v['centroid_error']:.1f} %, failed {v['n_failed']}/{v['n']}"
            )
        else:
            print(f"{m:5s} no ground truth, failed {v['n_failed']}/{v['n']}")
    for k, c in s["checks"].items():
        state = "n/a" if c["holds"] is None else ("holds" if c["holds"] else "DOES NOT HOLD")
        print(f"  {k}: {state} ({c['detail']})")
    print(f"done in {time.perf_counter() - t0:.0f} s; report: {out['files']['report']}")
    return 0


def main(argv: list[str] | None = None, prog: str = "symjax eval") -> int:
    """Command line entry point; returns the exit status (0 ok, 2 bad arguments or data)."""
    return run(prog, _body, argv)
