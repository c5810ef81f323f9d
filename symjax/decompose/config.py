"""Settings of the convex decomposition."""

from __future__ import annotations

import dataclasses

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["DecomposeConfig"]


@dataclasses.dataclass(frozen=True)
class DecomposeConfig:
    """coacd settings and the hull vertex cap.

    Attributes:
        threshold: coacd concavity threshold (0.01-1); lower gives more, tighter hulls.
        max_hulls: Upper bound on the number of hulls (coacd merges down to it); -1 for none.
        max_vertices: Vertex cap per hull. MJX's convex collision cost grows with the vertex
            count, so hulls are reduced to at most this many vertices.
        resolution: coacd sampling resolution.
        preprocess_resolution: coacd manifold pre-processing resolution.
        mcts_iterations: coacd search iterations (fewer is faster, coarser).
        seed: coacd random seed; a decomposition is reproducible for a given seed.
    """

    threshold: float = 0.08
    max_hulls: int = 16
    max_vertices: int = 64
    resolution: int = 2000
    preprocess_resolution: int = 50
    mcts_iterations: int = 100
    seed: int = 0

    def __post_init__(self):
        check_fields(self)
        if not 0.01 <= self.threshold <= 1.0:
            raise ConfigError(f"threshold must be in [0.01, 1], got {self.threshold}")
        if self.max_hulls == 0 or self.max_hulls < -1:
            raise ConfigError(f"max_hulls must be -1 or positive, got {self.max_hulls}")
        if self.max_vertices < 4:
            raise ConfigError(f"max_vertices must be >= 4 (a tetrahedron), got {self.max_vertices}")
        if self.resolution < 100 or self.preprocess_resolution < 10 or self.mcts_iterations < 1:
            raise ConfigError(
                "resolution >= 100, preprocess_resolution >= 10, mcts_iterations >= 1"
            )
