"""Grasp rollouts (paper Section IV-A, ``PlanGrasp``): every candidate simulated in parallel.

The scene is :mod:`symjax.grasp.scene`, the open-loop inputs :mod:`symjax.grasp.schedule`, the
labels :mod:`symjax.grasp.labels`; the backends in :mod:`symjax.grasp.backends` run the same
inputs and return the same :class:`GraspOutcomes`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax.errors import (
    InvalidInputError,
    config_or_default,
    unknown_name,
)
from symjax.execution import ExecutionConfig
from symjax.grasp.backends import BACKENDS, default_backend
from symjax.grasp.candidates import Candidates
from symjax.grasp.outcomes import GraspOutcomes
from symjax.grasp.scene import GraspScene, build_scene
from symjax.grasp.schedule import candidate_params, check_candidates
from symjax.grasp.sim_config import SimulationConfig

__all__ = ["simulate"]


def simulate(
    obj: Any,
    candidates: Candidates,
    hand: Any,
    config: SimulationConfig | None = None,
    backend: str | None = None,
    *,
    table: Any = None,
    scene: GraspScene | None = None,
    execution: ExecutionConfig | None = None,
) -> GraspOutcomes:
    """Rolls out every grasp candidate and labels it (paper IV-A, ``PlanGrasp``).

    Args:
        obj: The object (see :func:`build_scene`); ignored when ``scene`` is given.
        candidates: The :class:`Candidates` batch, world frame.
        hand: The :class:`symjax.hands.Hand`.
        config: :class:`SimulationConfig` (default settings when None).
        backend: ``"mjx"``, ``"mjx_warp"``, ``"mujoco"`` or None (:func:`default_backend`).
        table: Table height or plane (see :func:`build_scene`).
        scene: A scene from :func:`build_scene` to reuse (its compiled MJX function is cached).
        execution: Chunk size and threads (:class:`symjax.execution.ExecutionConfig`); no
            effect on the labels.

    Returns:
        :class:`GraspOutcomes`, one row per candidate, in order.

    Raises:
        UnknownNameError: Unknown backend.
        EmptyInputError, ShapeError, InvalidInputError: Bad candidates or object.
        SimulationError: The scene does not compile.
    """
    from symjax.hands import as_hand

    hand = as_hand(hand)
    ex = config_or_default(execution, ExecutionConfig, "execution")
    backend = default_backend() if backend is None else backend
    if backend not in BACKENDS:
        raise unknown_name("simulation backend", backend, BACKENDS)
    check_candidates(candidates)
    if scene is None:
        scene = build_scene(obj, hand, config, table)
    elif config is not None and config != scene.config:
        raise InvalidInputError("config differs from the scene's; rebuild the scene")
    if scene.hand.name != hand.name:
        raise InvalidInputError(f"scene was built for hand {scene.hand.name}, not {hand.name}")
    if np.any(np.asarray(candidates.preshape) >= len(hand.preshape_names)) or np.any(
        np.asarray(candidates.preshape) < 0
    ):
        raise InvalidInputError(
            f"candidate pre-shape index out of range for the hand {hand.name}: expected 0 to"
            f" {len(hand.preshape_names) - 1} ({', '.join(hand.preshape_names)})"
        )
    params = candidate_params(scene, candidates)
    return BACKENDS[backend](scene, params, ex)
