"""What a grasp cycle did: per object whether it was cleared (or the stage and reason it was
not), per round the stage times, the objects tried and the execution in simulation."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

__all__ = ["CycleReport", "ObjectOutcome", "Round"]


@dataclasses.dataclass(frozen=True)
class ObjectOutcome:
    """One object of the scene at the end of the cycle.

    Attributes:
        name: The true object's scan name (simulated scene) or ``hypothesis<i>`` (a frame).
        cleared: It rests at the drop-off.
        attempts: Executed picks of it.
        stage: The stage of Algorithm 1 (:data:`symjax.cycle.STAGES`) where its last try
            stopped; empty when cleared.
        reason: Why, in words.
    """

    name: str
    cleared: bool
    attempts: int = 0
    stage: str = ""
    reason: str = ""


@dataclasses.dataclass(frozen=True)
class Round:
    """One perceive-plan-execute round.

    Attributes:
        index: Round number from 0.
        hypotheses: Object hypotheses perceived.
        seconds: Wall time per stage of Algorithm 1 in this round, seconds.
        tried: Per hypothesis planned for, in order: ``{"hypothesis", "object", "stage",
            "reason", "candidates", "stable", "arm_tried"}`` (stage and reason empty when it
            planned).
        target: The executed hypothesis (None when nothing planned).
        target_object: The true object it was matched to.
        execution: The replay on the true objects: ``{"delivered", "lifted", "collisions",
            "slip_mm", "tcp_error_mm", "seconds"}`` (None when nothing was executed).
        plan: The executed plan's summary (grasp index, duration, planners).
    """

    index: int
    hypotheses: int
    seconds: dict[str, float]
    tried: tuple[dict[str, Any], ...]
    target: int | None = None
    target_object: str | None = None
    execution: dict[str, Any] | None = None
    plan: dict[str, Any] | None = None

    @property
    def total_seconds(self) -> float:
        return float(sum(self.seconds.values()))


@dataclasses.dataclass(frozen=True)
class CycleReport:
    """Output of :func:`symjax.cycle.clear_table`.

    Attributes:
        robot: ``"kth"`` or ``"uji"``.
        mode: ``"C"``, ``"K"``, ``"P"`` or ``"T"``.
        objects: One :class:`ObjectOutcome` per object on the table at the start.
        rounds: The rounds, in order.
        stop: Why the cycle stopped: ``"table clear"``, ``"nothing plans"``, ``"attempts
            exhausted"`` or ``"frame only"`` (a real frame: planned, not executed).
        seconds: Wall time of the whole cycle, seconds.
        warnings: Perception warnings of the first frame.
        extras: What the pictures need, when asked for (not in :meth:`to_dict`).
    """

    robot: str
    mode: str
    objects: tuple[ObjectOutcome, ...]
    rounds: tuple[Round, ...]
    stop: str
    seconds: float
    warnings: tuple[str, ...] = ()
    extras: dict[str, Any] = dataclasses.field(default_factory=dict, repr=False, compare=False)

    @property
    def n_cleared(self) -> int:
        return sum(o.cleared for o in self.objects)

    @property
    def cleared_share(self) -> float:
        """Share of the objects cleared, in [0, 1]."""
        return self.n_cleared / max(len(self.objects), 1)

    @property
    def collisions(self) -> int:
        """Executions in which the arm or hand touched the table or a non-target object."""
        return sum(bool(r.execution and r.execution["collisions"]) for r in self.rounds)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (plain types)."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "extras"}
        d["objects"] = [dataclasses.asdict(o) for o in self.objects]
        d["rounds"] = [dict(dataclasses.asdict(r), total_seconds=r.total_seconds)
                       for r in self.rounds]  # fmt: skip
        d.update(n_objects=len(self.objects), n_cleared=self.n_cleared,
                 cleared_share=self.cleared_share, collisions=self.collisions)  # fmt: skip
        return _plain(d)


def _plain(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x
