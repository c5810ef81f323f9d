"""The stage configs a job that chains perception, completion, meshing and grasping carries:
one frozen dataclass to extend (the grasp cycle's and the study's configs), filled from a
preset by field name."""

from __future__ import annotations

import dataclasses

from symjax.completion.config import CompletionConfig
from symjax.decompose.config import DecomposeConfig
from symjax.execution import ExecutionConfig
from symjax.grasp.config import CandidateConfig
from symjax.grasp.robustness import RobustnessConfig
from symjax.grasp.sim_config import SimulationConfig
from symjax.surface.config import DelaunayConfig, NormalsConfig, PoissonConfig
from symjax.symmetry.config import SymmetryConfig

__all__ = ["ShapeToGraspStages"]

#: The Poisson depth of the paper's Mir7, which the grasping jobs plan on.
MIR7_DEPTH = 7


@dataclasses.dataclass(frozen=True)
class ShapeToGraspStages:
    """The configs from a partial view to rolled-out grasps (extend it with a job's own fields).

    Attributes:
        symmetry, completion, normals, poisson, delaunay, decompose, candidates, simulation,
            robustness, execution: The stages' configs (``poisson.depth`` 7 is the paper's
            Mir7).
    """

    symmetry: SymmetryConfig = dataclasses.field(default_factory=SymmetryConfig)
    completion: CompletionConfig = dataclasses.field(default_factory=CompletionConfig)
    normals: NormalsConfig = dataclasses.field(default_factory=NormalsConfig)
    poisson: PoissonConfig = dataclasses.field(
        default_factory=lambda: PoissonConfig(depth=MIR7_DEPTH)
    )
    delaunay: DelaunayConfig = dataclasses.field(default_factory=DelaunayConfig)
    decompose: DecomposeConfig = dataclasses.field(default_factory=DecomposeConfig)
    candidates: CandidateConfig = dataclasses.field(default_factory=CandidateConfig)
    simulation: SimulationConfig = dataclasses.field(default_factory=SimulationConfig)
    robustness: RobustnessConfig = dataclasses.field(default_factory=RobustnessConfig)
    execution: ExecutionConfig = dataclasses.field(default_factory=ExecutionConfig)

    @classmethod
    def from_preset(cls, preset, **fields):
        """Every field named like a table of the :class:`symjax.configs.Preset` from it (Poisson
        at depth 7), then ``fields``."""
        names = {f.name for f in dataclasses.fields(cls)}
        stages = {k: getattr(preset, k) for k in names if hasattr(preset, k) and k != "poisson"}
        stages["poisson"] = dataclasses.replace(preset.poisson, depth=MIR7_DEPTH)
        return cls(**{**stages, **fields})
