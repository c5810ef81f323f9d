"""The paper's evaluation (Section V-A and V-B): meshes of 128 views against the ground truth.

``run_evaluation(cfg)`` evaluates the views (batched, resumable), writes ``results.csv``,
``results.json``, the figures (Fig. 10-12 and a gallery) and ``report.md`` under ``cfg.out_dir``.
``scripts/eval_dataset.py`` is its command line.
"""

from symjax.evaluation.config import METHODS, POISSON_DEPTHS, EvalConfig, parse_subset
from symjax.evaluation.run import run_evaluation

__all__ = ["METHODS", "POISSON_DEPTHS", "EvalConfig", "parse_subset", "run_evaluation"]
