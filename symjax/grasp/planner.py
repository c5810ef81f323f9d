"""``PlanGrasp`` (paper Algorithm 1, Section IV-A): candidates, rollouts, ranking."""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import jax
import numpy as np

from symjax.array_types import ArrayLike, MeshLike
from symjax.errors import EmptyInputError, InvalidInputError, unknown_name
from symjax.execution import ExecutionConfig
from symjax.geometry import mesh_arrays
from symjax.grasp.backends import default_backend
from symjax.grasp.candidate_set import Candidates, CandidateSet
from symjax.grasp.candidates import generate
from symjax.grasp.config import CandidateConfig
from symjax.grasp.outcomes import GraspOutcomes
from symjax.grasp.rollout import simulate
from symjax.grasp.scene import GraspScene, build_scene
from symjax.grasp.sim_config import SimulationConfig

__all__ = ["RANKINGS", "GraspPlan", "plan", "rank"]

RANKINGS = ("success", "quality")


@dataclasses.dataclass(frozen=True)
class GraspPlan:
    """Output of :func:`plan`: the candidates, best first, with their outcomes.

    Attributes:
        candidates: Ranked candidates (a :class:`Candidates` batch).
        outcomes: Their :class:`GraspOutcomes`, same order.
        order: Index of each ranked candidate in the generator's output, shape (N,).
        candidate_set: The generator's output (counts of dropped candidates).
        backend: Simulation backend used.
        seconds: ``{"candidates", "scene", "simulate"}`` wall times.
    """

    candidates: Candidates
    outcomes: GraspOutcomes
    order: np.ndarray
    candidate_set: CandidateSet
    backend: str
    seconds: dict[str, float]

    def __len__(self) -> int:
        return len(self.order)

    @property
    def best(self) -> int:
        """Index (in the generator's output) of the best candidate."""
        return int(self.order[0])


def rank(outcomes: GraspOutcomes, by: str = "success") -> np.ndarray:
    """Candidate order, best first.

    Args:
        outcomes: The rollouts' :class:`GraspOutcomes`.
        by: ``"success"``: the lift-and-shake result first, then force closure, epsilon and
            fingers in contact; ``"quality"``: the paper's static criterion alone (force
            closure, epsilon, fingers in contact), as a planner without the dynamic test
            would rank.

    Returns:
        Indices into ``outcomes``, shape (N,). Ties keep the generator's order (stable sort).

    Raises:
        UnknownNameError: ``by`` is neither.
    """
    if by not in RANKINGS:
        raise unknown_name("ranking", by, RANKINGS)
    o = outcomes.numpy()
    keys = [
        -np.asarray(o.n_fingers, float),
        -np.asarray(o.epsilon, float),
        -np.asarray(o.force_closure, float),
    ]
    if by == "success":
        keys.append(-np.asarray(o.success, float))
    return np.lexsort(keys)


def plan(
    mesh: MeshLike,
    hand: Any,
    method: str = "uji",
    *,
    hulls: Any = None,
    scene: Any = None,
    table: Any = None,
    obstacles: Any = None,
    candidates: CandidateConfig | None = None,
    simulation: SimulationConfig | None = None,
    execution: ExecutionConfig | None = None,
    backend: str | None = None,
    grasp_points: ArrayLike = None,
    seed: int = 0,
) -> GraspPlan:
    """Generates grasp candidates for an object, rolls them all out, and ranks them.

    Args:
        mesh: The object's closed mesh, a ``trimesh.Trimesh`` or ``(vertices (V, 3), faces
            (F, 3))``, world frame, metres (completed by symmetry, or ground truth).
        hand: A :class:`symjax.hands.Hand`.
        method: Candidate generator (``"openrave"``, ``"kth"``, ``"uji"``).
        hulls: Convex hulls to simulate (a :class:`symjax.decompose.Decomposition` or a list
            of ``(vertices, faces)``); default: coacd decomposition of ``obj`` (cached).
        scene: A prebuilt :class:`symjax.grasp.GraspScene` of this object and hand (from
            :func:`build_scene`) to simulate in instead of building one from ``hulls``.
        table: A horizontal :class:`symjax.table.TablePlane` or a height; default: the mesh's
            lowest point.
        obstacles: The other objects on the table as fixed hulls, world frame (see
            :func:`symjax.grasp.build_scene`); ignored with a prebuilt ``scene``.
        candidates: :class:`CandidateConfig` for the generator.
        simulation: :class:`SimulationConfig`.
        execution: Chunk size and threads; no effect on the labels.
        backend: ``"mjx"``, ``"mjx_warp"``, ``"mujoco"`` or None (by device).
        grasp_points: ``"kth"`` grasp points, shape (2, 3).
        seed: Seed of the ``"openrave"`` sampling.

    Returns:
        A :class:`GraspPlan`.

    Raises:
        EmptyInputError: Every candidate was dropped before simulation.
    """
    from symjax.hands import as_hand
    from symjax.table import TablePlane

    hand = as_hand(hand)
    v, f = mesh_arrays(mesh)
    t0 = time.perf_counter()
    if table is None:
        table = float(v[:, 2].min())
    plane = TablePlane.horizontal(float(table)) if isinstance(table, (int, float)) else table
    cs = generate(
        (v, f), method, config=candidates, table=plane, hand=hand,
        grasp_points=grasp_points, seed=seed,
    )  # fmt: skip
    t1 = time.perf_counter()
    if len(cs) == 0:
        raise EmptyInputError(f"every {method} candidate was dropped ({cs.n_generated} made)")
    if scene is None:
        if hulls is None:
            from symjax.decompose import decompose

            hulls = decompose((v, f))
        scene = build_scene(hulls, hand, simulation, table=plane, obstacles=obstacles)
    elif not isinstance(scene, GraspScene) or scene.hand.name != hand.name:
        raise InvalidInputError(
            "scene must be a GraspScene of the same hand (from symjax.grasp.build_scene)"
        )
    t2 = time.perf_counter()
    backend = default_backend() if backend is None else backend
    out = simulate(None, cs.candidates, hand, backend=backend, scene=scene, execution=execution)
    t3 = time.perf_counter()
    order = rank(out)
    ranked = jax.tree_util.tree_map(lambda x: np.asarray(x)[order], cs.candidates)
    return GraspPlan(
        candidates=ranked,
        outcomes=out.take(order),
        order=order,
        candidate_set=cs,
        backend=backend,
        seconds={"candidates": t1 - t0, "scene": t2 - t1, "simulate": t3 - t2},
    )
