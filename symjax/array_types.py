"""Type aliases of the public signatures.

Array shapes and units are given in each function's Google docstring (``points: (N, 3) metres``);
these aliases say what may be passed: any array a numpy or JAX function accepts, and the one
accepted mesh input.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, TypeAlias, Union

import jax
import numpy as np

if TYPE_CHECKING:  # trimesh is heavy; the alias only documents it
    import trimesh

__all__ = ["ArrayLike", "MeshLike"]

#: A numpy or JAX array, or nested sequences of numbers.
ArrayLike: TypeAlias = np.ndarray | jax.Array | Sequence[float] | Sequence[Sequence[float]]

#: A ``trimesh.Trimesh`` or a ``(vertices (V, 3), faces (F, 3))`` pair, metres.
MeshLike: TypeAlias = Union["trimesh.Trimesh", tuple[ArrayLike, ArrayLike]]
