"""The paper's evaluation (Section V-A and V-B): meshes of 128 views against the ground truth.

``run_evaluation(config)`` evaluates the views (batched, resumable), writes ``results.csv``,
``results.json``, the figures (Fig. 10-12 and a gallery) and ``report.md`` under
``config.out_dir``. ``symjax eval`` (and ``scripts/eval_dataset.py``) is its command line.
Modules: ``config``, ``selection`` (which views), ``stages`` (one batch through every stage),
``records`` (typed per-view results and the table), ``driver`` (the resumable job), ``report``,
``figures``.
"""

from symjax.evaluation.config import METHODS, POISSON_DEPTHS, EvalConfig, parse_subset
from symjax.evaluation.driver import evaluate, run_evaluation
from symjax.evaluation.records import MeshResult, PlaneResult, ViewRecord

__all__ = [
    "METHODS",
    "POISSON_DEPTHS",
    "EvalConfig",
    "MeshResult",
    "PlaneResult",
    "ViewRecord",
    "evaluate",
    "parse_subset",
    "run_evaluation",
]
