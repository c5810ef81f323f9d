"""Configuration of the completion choice: mirror, revolution or fallback (beyond the paper)."""

from __future__ import annotations

import dataclasses
from typing import Literal

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["CompletionConfig"]


@dataclasses.dataclass(frozen=True)
class CompletionConfig:
    """How a view's completed shape is chosen and how sure the choice is.

    The paper mirrors every view across the plane of Eq. 4. Beyond it: the plane's support (the
    share of mirrored points that land on an observed point, the paper's case i, which Eq. 3
    leaves out) gives a confidence; objects whose visible surface is a surface of revolution
    about the table normal are revolved about the fitted axis; and below the confidence
    threshold a conservative shape replaces the mirror.

    Attributes:
        mode: ``"mirror"`` (the paper: always the mirror), ``"auto"`` (revolution for rotational
            surfaces, the fallback below ``min_confidence``, else the mirror), or one of
            ``"revolution"``/``"fallback"`` for every view that allows it.
        support_eps: A mirrored point supports the plane when an observed point lies within this
            distance, metres (about the stereo noise of the benchmark: 2 mm).
        support_samples: Observed points mirrored to measure the support (a seeded subset).
        rival_angles_deg: Orientations, relative to the found plane, of the rival planes whose
            support the found plane's is compared with.
        rival_shift: Half-range of the rivals' shifts, metres (5 shifts each).
        revolution_residual: A surface is rotational when the median distance of its normal
            lines from the fitted axis is at most this share of its radius.
        revolution_min_tilt: Points whose normal's horizontal part is shorter than this enter
            no axis fit (lids, rims).
        revolution_min_points: Fewest tilted points for an axis fit.
        revolution_copies: Turned copies of the observed surface around the full circle.
        min_confidence: ``mode="auto"`` replaces the mirror by the fallback below this (the
            flag's threshold by default; 0: never).
        fallback: What replaces the mirror (:mod:`symjax.completion.fallback`): ``"support"``,
            the mirror across the near-best plane of the search that the view supports best
            (kept as the mirror when none beats the found plane by ``support_gain``), or
            ``"hull"``, the hull of the visible points and their footprint on the table.
        support_vote_ratio: Near-best planes: a vote of Eq. 3 within this factor of the best.
        support_gain: The least support by which a near-best plane must beat the found one.
        flag_below: A plane whose confidence is below this is flagged as likely wrong.
        shapes: The most plausible shapes of a view for grasping under shape uncertainty
            (:func:`symjax.completion.plausible_shapes`): the chosen completion, the mirror
            across the best distinct plane of the search, the footprint hull (1 to 3).
        distinct_deg: A plane of the search counts as distinct from the found one when their
            orientations differ by at least this, degrees.
    """

    mode: Literal["mirror", "auto", "revolution", "fallback"] = "auto"
    support_eps: float = 0.002
    support_samples: int = 3000
    rival_angles_deg: tuple[float, ...] = (-40.0, -25.0, -15.0, 15.0, 25.0, 40.0)
    rival_shift: float = 0.02
    revolution_residual: float = 0.17
    revolution_min_tilt: float = 0.3
    revolution_min_points: int = 50
    revolution_copies: int = 8
    min_confidence: float = 0.5
    flag_below: float = 0.5
    shapes: int = 3
    distinct_deg: float = 20.0
    fallback: Literal["support", "hull"] = "support"
    support_vote_ratio: float = 1.5
    support_gain: float = 0.1

    def __post_init__(self) -> None:
        check_fields(self)
        for name in ("support_eps", "revolution_residual"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if self.mode not in ("mirror", "auto", "revolution", "fallback"):
            raise ConfigError(
                f"mode must be 'mirror', 'auto', 'revolution' or 'fallback', got {self.mode!r}"
            )
        if self.fallback not in ("support", "hull"):
            raise ConfigError(f"fallback must be 'support' or 'hull', got {self.fallback!r}")
        if not self.support_vote_ratio >= 1.0:
            raise ConfigError(f"support_vote_ratio must be >= 1, got {self.support_vote_ratio!r}")
        if not 0.0 <= self.support_gain <= 1.0:
            raise ConfigError(f"support_gain must be in [0, 1], got {self.support_gain!r}")
        if not self.rival_shift >= 0:
            raise ConfigError(f"rival_shift must be >= 0 metres, got {self.rival_shift!r}")
        for name in ("revolution_min_tilt", "min_confidence", "flag_below"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ConfigError(f"{name} must be in [0, 1], got {getattr(self, name)!r}")
        if not 1 <= self.shapes <= 3:
            raise ConfigError(f"shapes must be 1, 2 or 3, got {self.shapes!r}")
        if not 0.0 < self.distinct_deg < 90.0:
            raise ConfigError(f"distinct_deg must be in (0, 90) degrees, got {self.distinct_deg!r}")
        for name, low in (("support_samples", 10), ("revolution_min_points", 3),
                          ("revolution_copies", 2)):  # fmt: skip
            if getattr(self, name) < low:
                raise ConfigError(f"{name} must be >= {low}, got {getattr(self, name)!r}")
