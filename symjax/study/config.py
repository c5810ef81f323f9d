"""Settings of the study "plan on the completion, score on the truth"."""

from __future__ import annotations

import dataclasses
import json
from typing import Literal

from symjax.configs.stages import ShapeToGraspStages
from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["PLANNING_MESHES", "StudyConfig"]

#: The meshes grasps are planned on: ``T`` the true mesh, ``C`` the completion (Mir7), ``K`` the
#: completion's plausible shapes (``completion.shapes`` of them, ranked by ``robust`` across
#: them; left out when ``completion.shapes`` is 1), ``P`` the observed points alone (the
#: Delaunay baseline).
PLANNING_MESHES = ("T", "C", "K", "P")


@dataclasses.dataclass(frozen=True)
class StudyConfig(ShapeToGraspStages):
    """Parameters of :func:`symjax.study.run_study`.

    Attributes:
        out_dir: Output folder (``views/*.json`` per view, ``results.json``, ``report.md``,
            ``study.png``).
        hands: ``(hand, generator)`` pairs: each hand planned with that candidate generator.
        top: Grasps taken from each planning mesh, best first, and rolled out on the truth.
        subset: Benchmark subset items (see :func:`symjax.datasets.benchmark`); empty = all 128.
        extra_scans: Other scans (not in the benchmark) to add views of.
        extra_orientations: Orientations of each extra scan, degrees.
        batch: Views completed per batched symmetry search and Poisson solve.
        backend: Rollout backend (``"mujoco"``, ``"mjx"``, ``"mjx_warp"`` or None: by device).
        seed: Seed of the benchmark's rendering.
        cache_dir: The benchmark's cache (None = the default).
        robust: How ``K`` ranks a grasp across the shapes (see
            :func:`symjax.grasp.robust_scores`): ``"mean"`` or ``"quantile"``.

    The stage configs are :class:`~symjax.configs.stages.ShapeToGraspStages`' (Poisson at the
    Mir7 depth).
    """

    out_dir: str = "out/study"
    hands: tuple[tuple[str, str], ...] = (("sdh", "kth"), ("barrett", "uji"))
    top: int = 5
    subset: tuple[str, ...] = ()
    extra_scans: tuple[str, ...] = (
        "002_master_chef_can",
        "010_potted_meat_can",
        "013_apple",
        "024_bowl",
    )
    extra_orientations: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0)
    batch: int = 16
    backend: Literal["mujoco", "mjx", "mjx_warp"] | None = None
    seed: int = 0
    cache_dir: str | None = None
    robust: Literal["mean", "quantile"] = "mean"

    def __post_init__(self) -> None:
        check_fields(self)
        if self.top < 1 or self.batch < 1:
            raise ConfigError(
                f"StudyConfig.top and batch must be >= 1, got {self.top}, {self.batch}"
            )
        if not self.hands:
            raise ConfigError("StudyConfig.hands is empty; expected (hand, generator) pairs")
        for _, g in self.hands:
            if g not in ("kth", "uji", "openrave"):
                raise ConfigError(
                    f"StudyConfig.hands: generator {g!r}; expected kth, uji, openrave"
                )

    def key(self) -> str:
        """Hash of what a view's result depends on (not the output folder or batch size)."""
        import hashlib

        d = dataclasses.asdict(self)
        for k in ("out_dir", "batch", "subset", "extra_scans", "extra_orientations"):
            d.pop(k)
        return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]
