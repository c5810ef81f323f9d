"""Per-candidate results of the grasp rollouts."""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax._pytree import pytree_dataclass, static_field

__all__ = ["GraspOutcomes"]


@pytree_dataclass
class GraspOutcomes:
    """Labels of N rolled-out grasp candidates (every array's leading axis is N).

    Attributes:
        success: The object stayed in the hand through lift and shake, shape (N,), bool.
        force_closure: The contacts at grasp time are in force closure, (N,), bool.
        epsilon: Ferrari-Canny L1 quality of those contacts, (N,), 0 without closure.
        n_fingers: Fingers touching the object at grasp time, (N,), int32 (palm excluded).
        n_contacts: Hand-object contacts at grasp time, (N,), int32.
        penetration: Deepest hand-object penetration at grasp time, (N,), metres.
        start_penetration: Deepest hand penetration of the object or table in the start pose,
            (N,), metres; a start pose inside something fails.
        table_contact: The hand touches the table at grasp time, (N,), bool.
        travel: Distance the hand moved along its approach before it stopped, (N,), metres.
        close_motion: Object displacement during closing (world frame), (N,), metres.
        close_rotation: Object rotation during closing, (N,), radians.
        shake_motion: Object displacement relative to the palm from grasp to the end of the
            shake, (N,), metres.
        shake_rotation: Object rotation relative to the palm over the same span, (N,), radians.
        lift: Rise of the object from grasp to the end of the shake, (N,), metres.
        diverged: The rollout produced NaN/inf (or C MuJoCo reset it); labelled failed, (N,).
        hand_q: The hand's joint positions at grasp time (closed on the object, after the
            settle), (N, J), radians or metres in ``hand.joint_names`` order; 0 when diverged.
        backend: ``"mjx"``, ``"mjx_warp"`` or ``"mujoco"``.
    """

    success: Any
    force_closure: Any
    epsilon: Any
    n_fingers: Any
    n_contacts: Any
    penetration: Any
    start_penetration: Any
    table_contact: Any
    travel: Any
    close_motion: Any
    close_rotation: Any
    shake_motion: Any
    shake_rotation: Any
    lift: Any
    diverged: Any
    hand_q: Any
    backend: str = static_field(default="mjx")

    def __len__(self) -> int:
        return int(np.shape(self.success)[0])

    def numpy(self) -> GraspOutcomes:
        """The same outcomes with numpy arrays (host copies)."""
        import jax

        return jax.tree_util.tree_map(np.asarray, self)

    def take(self, index: Any) -> GraspOutcomes:
        """Outcomes of the candidates ``index`` (an index array or a boolean mask)."""
        import jax

        return jax.tree_util.tree_map(lambda x: np.asarray(x)[index], self)

    def summary(self) -> dict[str, float]:
        """Rates and means over the batch, as plain floats (JSON-ready)."""
        o = self.numpy()
        n = max(len(o), 1)
        return {
            "n": len(o),
            "success_rate": float(o.success.sum() / n),
            "force_closure_rate": float(o.force_closure.sum() / n),
            "mean_epsilon": float(o.epsilon.mean()) if len(o) else 0.0,
            "mean_fingers": float(o.n_fingers.mean()) if len(o) else 0.0,
            "max_penetration": float(o.penetration.max()) if len(o) else 0.0,
            "diverged": int(o.diverged.sum()),
        }

    @staticmethod
    def concatenate(parts: list[GraspOutcomes]) -> GraspOutcomes:
        """Joins outcomes of consecutive chunks."""
        import jax

        return jax.tree_util.tree_map(lambda *xs: np.concatenate([np.asarray(x) for x in xs]),
                                      *parts)  # fmt: skip
