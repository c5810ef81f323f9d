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
        max_faces: Meshes with more faces are simplified to this many by quadric decimation
            (fast-simplification) before coacd, whose time grows with the surface's detail;
            0 keeps every face.
        preprocess: coacd's manifold pre-processing: ``"auto"`` (only for a mesh that is not
            closed with a consistent winding; Poisson meshes are), ``"on"`` or ``"off"``.
        mcts_max_depth: coacd's cut search depth (fewer is faster, coarser).
        mcts_nodes: coacd's cut candidates per search node.
    """

    threshold: float = 0.15
    max_hulls: int = 16
    max_vertices: int = 64
    resolution: int = 1000
    preprocess_resolution: int = 50
    mcts_iterations: int = 20
    seed: int = 0
    max_faces: int = 2000
    preprocess: str = "auto"
    mcts_max_depth: int = 2
    mcts_nodes: int = 10

    def __post_init__(self):
        check_fields(self)
        if not 0.01 <= self.threshold <= 1.0:
            raise ConfigError(f"threshold must be in [0.01, 1], got {self.threshold}")
        if self.max_hulls == 0 or self.max_hulls < -1:
            raise ConfigError(f"max_hulls must be -1 or positive, got {self.max_hulls}")
        if self.max_vertices < 4:
            raise ConfigError(f"max_vertices must be >= 4 (a tetrahedron), got {self.max_vertices}")
        if self.max_faces != 0 and self.max_faces < 100:
            raise ConfigError(f"max_faces must be 0 (keep all) or >= 100, got {self.max_faces}")
        if self.preprocess not in ("auto", "on", "off"):
            raise ConfigError(f"preprocess must be 'auto', 'on' or 'off', got {self.preprocess!r}")
        if self.mcts_nodes < 1:
            raise ConfigError(f"mcts_nodes must be >= 1, got {self.mcts_nodes}")
        if not 1 <= self.mcts_max_depth <= 10:
            raise ConfigError(f"mcts_max_depth must be in [1, 10], got {self.mcts_max_depth}")
        if self.resolution < 100 or self.preprocess_resolution < 10 or self.mcts_iterations < 1:
            raise ConfigError(
                "resolution >= 100, preprocess_resolution >= 10, mcts_iterations >= 1"
            )
