"""The paper's grasp cycle (Algorithm 1): :func:`clear_table` on a simulated table scene or a
frame, with the completed shapes (``C``), the observed points alone (``P``) or the true shapes
(``T``).

Modules: ``config`` (:class:`CycleConfig`, the modes and stages), ``shapes``
(``PredictObjectShape``, ``ConvexDecomposition``), ``world`` (the simulated table,
``ExecuteGrasp``), ``grasp_cycle`` (:func:`clear_table`), ``report`` (:class:`CycleReport`).

Example::

    from symjax import cycle, datasets
    scene = datasets.scan_scene("kth", n_objects=3, seed=0)
    report = cycle.clear_table(scene, "kth", cycle.CycleConfig(mode="C"))
    print(report.cleared_share, [(o.name, o.stage, o.reason) for o in report.objects])
"""

from symjax.cycle.config import MODES, STAGES, CycleConfig
from symjax.cycle.grasp_cycle import GENERATORS, clear_table
from symjax.cycle.report import CycleReport, ObjectOutcome, Round

__all__ = [
    "GENERATORS",
    "MODES",
    "STAGES",
    "CycleConfig",
    "CycleReport",
    "ObjectOutcome",
    "Round",
    "clear_table",
]
