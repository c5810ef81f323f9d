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
from symjax.grasp.robustness import RobustnessConfig, pose_robustness
from symjax.grasp.rollout import simulate
from symjax.grasp.scene import GraspScene, build_scene
from symjax.grasp.sim_config import SimulationConfig

__all__ = ["RANKINGS", "ROBUST", "GraspPlan", "plan", "rank", "robust_scores"]

RANKINGS = ("success", "quality")
#: Criteria across plausible shapes: the weighted mean success, or a weighted lower quantile.
ROBUST = ("mean", "quantile")


@dataclasses.dataclass(frozen=True)
class GraspPlan:
    """Output of :func:`plan`: the candidates, best first, with their outcomes.

    Attributes:
        candidates: Ranked candidates (a :class:`Candidates` batch).
        outcomes: Their :class:`GraspOutcomes`, same order.
        order: Index of each ranked candidate in the generator's output, shape (N,).
        candidate_set: The generator's output (counts of dropped candidates).
        backend: Simulation backend used.
        seconds: ``{"candidates", "scene", "simulate"}`` wall times (with ``shapes``, also
            ``"shapes"``: the other shapes' scenes and rollouts).
        shape_success: With ``shapes``: (K, N) success of each ranked candidate on each shape;
            else None.
        robust: With ``shapes``: (N,) the ranking's score across the shapes (the weighted mean
            success, the planner's predicted success); else None.
        robustness: With ``robustness`` enabled: (N,) the share of hand poses (the planned one
            and the perturbed ones) at which each ranked candidate holds; else None.
    """

    candidates: Candidates
    outcomes: GraspOutcomes
    order: np.ndarray
    candidate_set: CandidateSet
    backend: str
    seconds: dict[str, float]
    shape_success: np.ndarray | None = None
    robust: np.ndarray | None = None
    robustness: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.order)

    @property
    def best(self) -> int:
        """Index (in the generator's output) of the best candidate."""
        return int(self.order[0])


def rank(
    outcomes: GraspOutcomes, by: str = "success", scores: Any = None, robustness: Any = None
) -> np.ndarray:
    """Candidate order, best first.

    Args:
        outcomes: The rollouts' :class:`GraspOutcomes`.
        by: ``"success"``: the lift-and-shake result first, then force closure, epsilon and
            fingers in contact; ``"quality"``: the paper's static criterion alone (force
            closure, epsilon, fingers in contact), as a planner without the dynamic test
            would rank.
        scores: Keys ranked before all of these, most important first, each (N,), larger is
            better (the robust scores across shapes, :func:`robust_scores`), or None.
        robustness: (N,) key ranked right after the success, larger is better (the share of
            perturbed hand poses that hold, :func:`~symjax.grasp.robustness.pose_robustness`),
            or None.

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
        if robustness is not None:
            keys.append(-np.asarray(robustness, float))
        keys.append(-np.asarray(o.success, float))
    keys += [-np.asarray(k, float) for k in reversed(list(scores or []))]
    return np.lexsort(keys)


def robust_scores(
    success: ArrayLike, weights: ArrayLike, criterion: str = "mean", quantile: float = 0.25
) -> list[np.ndarray]:
    """Ranking keys of candidates rolled out on several plausible shapes, most important first.

    Args:
        success: (K, N) success of each candidate on each shape.
        weights: (K,) the shapes' probabilities.
        criterion: ``"mean"``: the weighted mean success; ``"quantile"``: the weighted lower
            ``quantile`` of the success (1 when the shapes it fails on weigh at most
            ``quantile``), then the mean.
        quantile: The quantile of ``"quantile"``, in [0, 1).

    Returns:
        ``[mean]`` or ``[lower quantile, mean]``, each (N,).
    """
    if criterion not in ROBUST:
        raise unknown_name("robust criterion", criterion, ROBUST)
    if not 0.0 <= quantile < 1.0:
        raise InvalidInputError(f"quantile must be in [0, 1), got {quantile!r}")
    s = np.asarray(success, float)
    w = np.asarray(weights, float)
    mean = w @ s
    if criterion == "mean":
        return [mean]
    return [((w @ (1.0 - s)) <= quantile + 1e-12).astype(float), mean]


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
    shapes: Any = None,
    robust: str = "mean",
    quantile: float = 0.25,
    robustness: RobustnessConfig | None = None,
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
        shapes: The object's plausible shapes, a :class:`symjax.completion.ShapeSet` (from
            :func:`symjax.completion.plausible_shapes`); ``mesh`` may then be None (the most
            plausible shape). The candidates are generated on ``mesh``, rolled out on every
            shape (the same hand poses; ``hulls``, if given, one decomposition per shape) and
            ranked by ``robust`` across them, then as :func:`rank` on ``mesh``.
        robust: ``"mean"`` or ``"quantile"`` (:func:`robust_scores`).
        quantile: The lower quantile of ``robust="quantile"``.
        robustness: :class:`~symjax.grasp.robustness.RobustnessConfig`; when enabled, the
            stable candidates (the ``max_grasps`` best) are rolled out again at perturbed hand
            poses (on ``mesh``) and ranked, after their success, by the share of poses that
            hold.

    Returns:
        A :class:`GraspPlan`.

    Raises:
        EmptyInputError: Every candidate was dropped before simulation.
    """
    from symjax.hands import as_hand
    from symjax.table import TablePlane

    hand = as_hand(hand)
    shape_hulls: list = []
    if shapes is not None:
        from symjax.completion.shapes import ShapeSet

        if not isinstance(shapes, ShapeSet):
            raise InvalidInputError(
                f"shapes must be a symjax.completion.ShapeSet, got {type(shapes).__name__}"
            )
        robust_scores(np.zeros((len(shapes), 0)), shapes.weights, robust, quantile)  # checks
        mesh = shapes.meshes[0] if mesh is None else mesh
        if hulls is not None:
            if not isinstance(hulls, (list, tuple)) or len(hulls) != len(shapes):
                raise InvalidInputError(
                    f"with shapes, hulls must be one decomposition per shape ({len(shapes)})"
                )
            hulls, shape_hulls = hulls[0], list(hulls[1:])
        if scene is not None:
            raise InvalidInputError("shapes and a prebuilt scene exclude each other")
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
    seconds = {"candidates": t1 - t0, "scene": t2 - t1, "simulate": t3 - t2}
    success = keys = None
    if shapes is not None and len(shapes) > 1:
        success = np.stack([np.asarray(out.success, float)] + [
            np.asarray(simulate(None, cs.candidates, hand, backend=backend, execution=execution,
                                scene=build_scene(h, hand, simulation, table=plane,
                                                  obstacles=obstacles)).success, float)
            for h in _other_hulls(shapes, shape_hulls)
        ])  # fmt: skip
        keys = robust_scores(success, shapes.weights, robust, quantile)
        seconds["shapes"] = time.perf_counter() - t3
    rob = None
    if robustness is not None and robustness.enabled:
        t4 = time.perf_counter()
        rob = pose_robustness(
            cs.candidates, out.success, config=robustness, order=rank(out, scores=keys),
            rollout=lambda c: simulate(None, c, hand, backend=backend, scene=scene,
                                       execution=execution).success,
        )  # fmt: skip
        seconds["robustness"] = time.perf_counter() - t4
    order = rank(out, scores=keys, robustness=rob)
    ranked = jax.tree_util.tree_map(lambda x: np.asarray(x)[order], cs.candidates)
    return GraspPlan(
        candidates=ranked,
        outcomes=out.take(order),
        order=order,
        candidate_set=cs,
        backend=backend,
        seconds=seconds,
        shape_success=None if success is None else success[:, order],
        robust=None if keys is None else keys[-1][order],
        robustness=None if rob is None else rob[order],
    )


def _other_hulls(shapes: Any, given: list) -> list:
    """The decompositions of the shapes after the first: the given ones, else coacd's (cached)."""
    if given:
        return given
    from symjax.decompose import decompose

    return [decompose(m) for m in shapes.meshes[1:]]
