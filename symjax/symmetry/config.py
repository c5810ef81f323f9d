"""Configuration of the symmetry-plane search (paper Section II-A)."""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["SymmetryConfig"]


@dataclasses.dataclass(frozen=True)
class SymmetryConfig:
    """Parameters of the generate-and-test search for the planar reflection symmetry.

    The paper samples ``n`` orientations in [-20 deg, +20 deg] around the initial axis and ``m``
    shifts along the plane normal, 35 hypotheses in all (its text says "n = 6 and m = 5 yielding
    35 hypotheses"; 6 x 5 is 30, so symjax uses 7 x 5 = 35). The paper does not give the shift
    range; symjax shifts the plane from the centroid ``c`` of the visible cloud by
    ``d_j in linspace(shift_min, shift_max, n_shifts) * L`` along the plane normal, where the
    normal points away from the camera and ``L`` is the larger 2-D extent (2nd-98th percentile) of
    the table-projected cloud. The visible centroid lies in front of the true plane (the back is
    missing), so the range is skewed backwards: by default from 0.1 L towards the camera to 0.5 L
    away from it, a step of 0.15 L.

    Beyond the paper, ``init="eigen+box"`` also fans the n x m hypotheses out around an axis of
    the minimum-area rectangle bounding the table-projected cloud: seen across a corner, a box's
    eigenvectors are diagonal, 45 deg from either symmetry plane and out of the paper's +-20 deg
    reach, while the rectangle's axes are its faces. Of the rectangle's two axes, the one chosen
    by Eq. 1's rule is used (the plane whose normal is closest to the viewing direction): the other
    plane maps the visible surface onto itself, so it votes well but completes nothing.
    ``box_axes=2`` searches it too, for box-like footprints only (see ``box_fan``).
    ``init="eigen"`` is the paper's Eq. 1 alone.

    Also beyond the paper, ``n_refine`` coarse-to-fine levels re-grid the same n x m hypotheses
    around the best one with the previous level's step as half-range (level 0 is the paper's
    grid). With ``n_refine=0`` the search is exactly the paper's.

    Chunk sizes, which change speed but never the result, are in
    :class:`symjax.execution.ExecutionConfig`.

    Attributes:
        init: Initial axes: ``"eigen"`` (paper, Eq. 1) or ``"eigen+box"`` (Eq. 1 plus the
            view-facing axis of the minimum-area bounding rectangle).
        n_angles: Number of plane orientations per level.
        n_shifts: Number of plane shifts per level.
        angle_range: Half-range of orientations around the initial axis, radians (paper: 20 deg).
        shift_min: Smallest shift, in units of the extent L (negative = towards the camera).
        shift_max: Largest shift, in units of L.
        n_refine: Coarse-to-fine refinement levels after the paper's grid.
        n_chains: Orientations per initial axis refined on their own (the best shift of each of
            the best ``n_chains`` orientations of the level-0 fan).
        start_margin: A bounding-box axis wins over the paper's axis only when its vote is lower
            by more than this fraction. Rotational objects (cans, cups) score all planes through
            their axis alike, and among those the paper's, perpendicular to the view, completes
            the back of the object; wrong planes score several times worse, far beyond 5%.
        box_favour: Beyond the paper; 0 = off. When the table-projected cloud is box-like (its
            bounding rectangle's area varies over orientations by more than
            ``box_rectangularity`` times: 2 for a square footprint, 1 for a disc), the
            bounding-box axis wins unless the paper's axis votes better by more than this
            fraction (its vote is scaled by ``1 - box_favour`` instead of ``1 + start_margin``).
            A nearly square box seen across a corner votes about as well for its diagonal,
            the paper's axis there, as for its faces, and a few pixels of mask decide between
            them; its faces are its symmetry planes unless it is square.
        box_rectangularity: The ratio of the largest to the smallest bounding-rectangle area
            over orientations above which ``box_favour``, ``box_fan`` and the other axis apply.
        box_fan: Beyond the paper; 1 = off. For a box-like footprint, the rectangle axes' fans
            span this fraction of ``angle_range`` (and so do their refinements). The rectangle's
            axis lies within about a degree of a box face even when most of the box is hidden
            (0.1-1.5 deg for the held-out clutter boxes examined), while a full fan lets a
            heavily hidden box's chain drift 10-30 deg to a plane whose mirror image hides
            behind a neighbour.
        box_axes: 1 searches the rectangle axis that Eq. 1's rule keeps (the paper's choice
            among eigenvectors); 2 (beyond the paper) also the other one, for box-like
            footprints: when neighbours hide most of a box, the rule's axis can be the face
            whose mirror image falls on them.
        other_axis_favour: With ``box_axes=2``, the other axis wins unless another start votes
            better by this fraction (its vote is scaled by ``1 - other_axis_favour``).
        neighbour_volumes: Beyond the paper; read by :func:`symjax.symmetry.search_scene`
            only (the objects of one frame). An object behind others is searched again with
            each occluder pixel pushed back to the back of that occluder's own completion, so
            that a mirrored point just behind a neighbour's visible surface, inside the
            neighbour, contradicts the plane instead of hiding there.
        outside_huber_px: Beyond the paper; 0 = off (Eq. 3's squared distance). Above this
            distance (pixels) outside the mask a mirrored point's delta_1 grows linearly, as
            Huber's loss does (``c (2 d - c)`` instead of ``d^2``; the distance transform is at
            least 1 pixel outside the mask, so 1 makes every outside point's delta_1 ``2 d - 1``).
            A neighbour's few points along a seam that the segmentation drew a pixel or two wrong
            mirror far outside the object, and their squares outweigh the rest of the view. The
            vote only: the completion's plausibility keeps the square.
        w_outside: Weight of E[delta_1], the squared distance (pixels^2) of mirrored points that
            fall outside the segmentation mask (Eq. 3, first term; see ``outside_huber_px``).
        w_inside: Weight of E[delta_2], the depth difference (metres) of mirrored points that fall
            inside the mask in front of the observed surface (Eq. 3, second term). The default
            1000 reads depth in millimetres, as the reference implementation's units do.
        depth_tolerance: A mirrored point counts as in front of the observed surface only when it
            is closer than the observed depth by more than this (metres); absorbs sensor noise.
        normalize: ``"subset"`` takes each expectation over the points of its own case, as Eq. 3
            writes it; ``"all"`` divides both sums by the number of mirrored points, so that a few
            violating points weigh less than many.
        plausibility_px: Pixel scale of the per-point plausibility ``exp(-delta_1 / px^2)``.
        plausibility_depth: Depth scale (metres) of the plausibility ``exp(-delta_2 / depth)``.
    """

    init: Literal["eigen", "eigen+box"] = "eigen+box"
    n_angles: int = 7
    n_shifts: int = 5
    angle_range: float = math.radians(20.0)
    shift_min: float = -0.1
    shift_max: float = 0.5
    n_refine: int = 2
    n_chains: int = 2
    start_margin: float = 0.05
    box_favour: float = 0.0
    box_rectangularity: float = 1.5
    box_fan: float = 1.0
    box_axes: int = 1
    other_axis_favour: float = 0.0
    neighbour_volumes: bool = False
    outside_huber_px: float = 0.0
    w_outside: float = 1.0
    w_inside: float = 1000.0
    depth_tolerance: float = 0.002
    normalize: Literal["subset", "all"] = "subset"
    plausibility_px: float = 3.0
    plausibility_depth: float = 0.01

    def __post_init__(self) -> None:
        check_fields(self)
        if self.n_angles < 1 or self.n_shifts < 1:
            raise ConfigError(
                f"n_angles and n_shifts must be >= 1, got {self.n_angles}, {self.n_shifts}"
            )
        if self.init not in ("eigen", "eigen+box"):
            raise ConfigError(f"init must be 'eigen' or 'eigen+box', got {self.init!r}")
        if self.n_refine < 0:
            raise ConfigError(f"n_refine must be >= 0, got {self.n_refine}")
        if self.n_chains < 1:
            raise ConfigError(f"n_chains must be >= 1, got {self.n_chains}")
        if not self.start_margin >= 0.0:
            raise ConfigError(f"start_margin must be >= 0, got {self.start_margin}")
        if not 0.0 <= self.box_favour < 1.0:
            raise ConfigError(f"box_favour must be in [0, 1), got {self.box_favour}")
        if not 0.0 <= self.other_axis_favour < 1.0:
            raise ConfigError(f"other_axis_favour must be in [0, 1), got {self.other_axis_favour}")
        if not 0.0 <= self.box_fan <= 1.0:
            raise ConfigError(f"box_fan must be in [0, 1], got {self.box_fan}")
        if self.box_axes not in (1, 2):
            raise ConfigError(f"box_axes must be 1 or 2, got {self.box_axes!r}")
        if not self.box_rectangularity >= 1.0:
            raise ConfigError(f"box_rectangularity must be >= 1, got {self.box_rectangularity}")
        if not (0.0 <= self.angle_range <= math.pi / 2):
            raise ConfigError(f"angle_range must be in [0, pi/2] rad, got {self.angle_range}")
        if not self.shift_min <= self.shift_max:
            raise ConfigError(f"shift_min {self.shift_min} must be <= shift_max {self.shift_max}")
        for name in (
            "w_outside", "w_inside", "depth_tolerance", "outside_huber_px", "shift_min", "shift_max"
        ):  # fmt: skip
            v = getattr(self, name)
            # NaN fails every comparison: test for the accepted range, not against it.
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ConfigError(f"{name} must be a finite number, got {v!r}")
        for name in ("w_outside", "w_inside", "depth_tolerance", "outside_huber_px"):
            if not getattr(self, name) >= 0:
                raise ConfigError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if self.normalize not in ("subset", "all"):
            raise ConfigError(f"normalize must be 'subset' or 'all', got {self.normalize!r}")
        for name in ("plausibility_px", "plausibility_depth"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ConfigError(f"{name} must be a finite number > 0, got {v!r}")

    @property
    def n_hypotheses(self) -> int:
        """Hypotheses scored per view: the level-0 fan and each refinement level, per start."""
        refined = self.n_refine * min(self.n_chains, self.n_angles)
        return self.n_angles * self.n_shifts * self.n_starts * (1 + refined)

    @property
    def n_starts(self) -> int:
        """Initial axes the level-0 grid fans out around."""
        return 1 if self.init == "eigen" else 1 + self.box_axes
