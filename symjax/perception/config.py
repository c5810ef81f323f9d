"""Configuration of the table-top segmentation (the paper's ``GetObjectHypotheses``)."""

from __future__ import annotations

import dataclasses
import math

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["SegmentationConfig"]


@dataclasses.dataclass(frozen=True)
class SegmentationConfig:
    """Parameters of :func:`symjax.perception.segmentation`.

    Attributes:
        ransac_hypotheses: Plane hypotheses (point triples) scored at once in one jitted vmap.
        ransac_sample: Points the hypotheses are scored on (a random subsample; fixed size so the
            kernel compiles once).
        inlier_threshold: Distance (m) under which a point supports a plane; the MSAC cost
            truncates squared residuals here, and the least-squares refinement uses these inliers.
        refine_iterations: Least-squares refinements of the best plane on its inliers.
        refine_sample: Points (a random subsample) the refinement fits the plane to.
        up: Optional world direction (3,) the table normal must be near (e.g. (0, 0, 1) when the
            camera pose is in a z-up world); None accepts any plane.
        max_tilt: Largest angle (rad) between the table normal and ``up``.
        min_table_fraction: Fewest plane inliers, as a fraction of the measured points, for the
            plane to count as a table.
        seed_height: Height (m) above the table a cluster must reach to be an object (hysteresis
            high threshold; keeps sensor noise on the table out).
        grow_height: Height (m) above the table of the points a cluster may grow into (hysteresis
            low threshold; keeps the bottom of the objects).
        max_height: Points higher than this above the table (m) are ignored.
        workspace_min: Optional lower corner (3,) of a world box objects must lie in, metres.
        workspace_max: Optional upper corner (3,) of that box, metres.
        table_hull: Keep only points that project inside the convex hull of the table's inliers
            in the image (depth input).
        fill_holes_px: Missing measurements (depth 0) up to about this many pixels from a measured
            pixel get the nearest surface's depth for the connectivity only (stereo holes would
            otherwise split objects); they stay out of the objects' points.
        depth_jump: Depth step (m) between neighbouring pixels that separates two surfaces ...
        depth_jump_rel: ... plus this fraction of the depth (stereo noise grows with depth).
        crease_threshold: Concavity (``tan`` of half the bend, see
            :func:`symjax.perception.creases.concavity`) above which a pixel is on a crease
            between touching objects; None = split at depth steps only.
        crease_weak: Hysteresis: concavities over this fraction of ``crease_threshold`` are
            creases where they connect to one over it (1 = no hysteresis).
        crease_max_step: The concavity ignores samples farther than this in depth (m) from
            the pixel: the far side of a large step is no crease (the step test cuts it).
        crease_scale_px: Half span (pixels) of the concavity's second difference.
        crease_smooth_px: Diameter (pixels) of the bilateral filter before it; 0 = none.
        crease_smooth_depth: Depth difference (m) that filter still averages across.
        colour_concavity: With a colour image, colour edges are creases where the concavity
            exceeds this (touching objects at a shallow angle; not labels on convex faces).
        colour_weight: With a colour image, cut pixels go to the neighbour that differs least in
            depth plus this many metres per CIELAB unit of colour difference (summed over L, a, b).
        support_height: A part split off by creases with 80 % of its footprint on an adjacent
            part's footprint is joined to that part: a lower one if its own lowest points are
            this high (m) above the table (a bottle's neck), else a larger one.
        support_narrow: A part split off by creases that is narrower than this (m) on the table
            is joined to the adjacent part it shares the longest boundary with, wherever it
            stands (the neck of a bottle whose body is hidden, a sliver of a real object cut
            by stereo noise); thinner objects touching another one come out joined to it.
        cluster_tolerance: Euclidean clustering distance for point-cloud input, metres.
        voxel_size: Voxel edge (m) the cloud is downsampled to before clustering (cloud input).
        min_cluster_points: Fewest seed points (pixels above ``seed_height``) of an object.
        sor_neighbours: Neighbours of the statistical outlier removal (cloud input; depth input
            uses the 8 pixel neighbours).
        sor_std_ratio: A point is an outlier when its mean neighbour distance exceeds the mean
            over the cloud by this many standard deviations.
        border_px: An object whose mask comes this close (pixels) to the image border is flagged
            as cut by the border.
        touch_px: Two objects whose masks come this close (pixels) are flagged as touching.
        max_object_extent: A cluster wider than this (m) on the table is flagged as possibly
            several touching objects.
        mask_fill: Fill of each object's mask, see :meth:`symjax.Observation.from_points`.
        object_holes: Pixels enclosed by one object's mask in the image (none of another
            object) join that object, with their points: the inside of a bowl or a cup seen from
            above lies within millimetres of the table and is not taken for an object by its
            height (a ring lying on the table would take the table inside it too).
        claim_dropouts_px: Pixels without depth within this many pixels of an object whose
            viewing ray passes through the object's column (footprint hull x height) join its
            mask, not its points (:mod:`symjax.perception.dropouts`); 0 = off.
        round_margin: Metres; 0 = off. Parts that meet on one surface give back what they took
            across a round part's wall (:mod:`symjax.perception.round_parts`): pixels whose points
            stand more than this inside a round neighbour's disc go to it, and pixels of a round
            part more than this outside its circle go to a neighbour whose footprint holds them.
            A bottle's circle about the axis its neck marks also takes back, from any part it
            touches, the pieces within it that reach inside it (its shoulder's ring).
        round_residual: A part's wall is round when its points lie within this median distance
            (m) of a circle.
        round_objects: With creases, a part whose wall holds a round object's circle loses the
            piece beyond it (a can tangent to a box face, or the strip of a neighbour it took):
            the piece becomes a part of its own before the joins
            (:mod:`symjax.perception.round_split`).
        halves_extent: Metres; 0 = off. Two parts that do not touch, lie behind one nearer part
            and reach the same top height are the halves of one object that the nearer one cuts
            apart (a box behind a bottle's neck), joined when together they are at most this wide
            on the table (:mod:`symjax.perception.occluded_halves`): the widest object expected;
            the pieces of two objects behind one occluder stand farther apart.
        level_top_px: Pixels; 0 = off. With creases, a part whose top region (the pixels within
            5 mm of its top) erosion by a disc of this radius parts into two tops is cut where
            they meet, when both pieces stand on the table or the cut is at most three radii
            long: two touching objects of one height meet level there, the farther one perhaps
            hidden below its top (:mod:`symjax.perception.level_tops`).
        fragment_px: Pixels; 0 = off. With creases, a piece of surface that they cut off with
            too few seed pixels to be an object but at least this many pixels is a part of its
            own: it takes its share of the cut pixels around it and is dropped only if the joins
            give it to no object (:mod:`symjax.perception.fragments`), so that a strip of a
            bottle seen between two nearer cans no longer grows into the box behind it.
        split_bridges_px: A cluster that erosion by a disc of this radius (pixels) breaks into
            two or more cores of ``min_cluster_points`` seed pixels is split there: two touching
            objects joined through a few pixels where the crease and the depth step both missed
            (:func:`symjax.perception.clusters.image_clusters`); 0 = off.
        unclaimed_occluders: Pieces of surface that no object holds and that touch an object
            (a sliver of a box seen beside a nearer bottle, too small to be a part of its own)
            are occluders in every object's depth image: a surface was seen there, so a mirrored
            point behind it may be hidden (Eq. 3); without this they count as free space seen
            empty (:func:`symjax.perception.object_info.unclaimed_surfaces`: pixels above
            ``seed_height``, the stray points left out, pieces of 20 pixels or more).
        seed: Random seed of the RANSAC sampling (results are deterministic).
    """

    ransac_hypotheses: int = 256
    ransac_sample: int = 4096
    inlier_threshold: float = 0.008
    refine_iterations: int = 2
    refine_sample: int = 32768
    up: tuple[float, float, float] | None = None
    max_tilt: float = math.radians(30.0)
    min_table_fraction: float = 0.05
    seed_height: float = 0.012
    grow_height: float = 0.004
    max_height: float = 0.5
    workspace_min: tuple[float, float, float] | None = None
    workspace_max: tuple[float, float, float] | None = None
    table_hull: bool = True
    fill_holes_px: int = 2
    depth_jump: float = 0.01
    depth_jump_rel: float = 0.02
    crease_threshold: float | None = None
    crease_weak: float = 0.6
    crease_max_step: float = 0.12
    crease_scale_px: int = 4
    crease_smooth_px: int = 9
    crease_smooth_depth: float = 0.01
    colour_concavity: float = 0.0
    colour_weight: float = 0.0005
    support_height: float = 0.02
    support_narrow: float = 0.04
    cluster_tolerance: float = 0.012
    voxel_size: float = 0.005
    min_cluster_points: int = 200
    sor_neighbours: int = 8
    sor_std_ratio: float = 3.0
    border_px: int = 2
    touch_px: int = 3
    max_object_extent: float = 0.4
    mask_fill: str = "close"
    claim_dropouts_px: int = 0
    split_bridges_px: int = 0
    fragment_px: int = 0
    round_margin: float = 0.0
    round_residual: float = 0.001
    halves_extent: float = 0.0
    level_top_px: int = 0
    object_holes: bool = False
    round_objects: bool = False
    unclaimed_occluders: bool = False
    seed: int = 0

    def __post_init__(self) -> None:
        check_fields(self)
        if self.ransac_hypotheses < 1 or self.ransac_sample < 3:
            raise ConfigError(
                f"ransac_hypotheses must be >= 1 and ransac_sample >= 3, got "
                f"{self.ransac_hypotheses}, {self.ransac_sample}"
            )
        positive = {
            "inlier_threshold": self.inlier_threshold,
            "seed_height": self.seed_height,
            "max_height": self.max_height,
            "cluster_tolerance": self.cluster_tolerance,
            "voxel_size": self.voxel_size,
            "sor_std_ratio": self.sor_std_ratio,
            "max_object_extent": self.max_object_extent,
        }
        for k, v in positive.items():
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"{k} must be > 0, got {v}")
        if not 0 <= self.grow_height <= self.seed_height < self.max_height:
            raise ConfigError(
                "need 0 <= grow_height <= seed_height < max_height (m), got "
                f"{self.grow_height}, {self.seed_height}, {self.max_height}"
            )
        if self.depth_jump <= 0 or self.depth_jump_rel < 0:
            raise ConfigError("depth_jump must be > 0 and depth_jump_rel >= 0")
        if self.crease_threshold is not None and not (
            math.isfinite(self.crease_threshold) and self.crease_threshold > 0
        ):
            raise ConfigError(f"crease_threshold must be None or > 0, got {self.crease_threshold}")
        if not 0 < self.crease_weak <= 1:
            raise ConfigError(f"crease_weak must be in (0, 1], got {self.crease_weak}")
        if not self.crease_max_step > 0:
            raise ConfigError(f"crease_max_step must be > 0 m, got {self.crease_max_step}")
        if not (math.isfinite(self.colour_weight) and self.colour_weight >= 0):
            raise ConfigError(
                f"colour_weight must be >= 0 m per CIELAB unit, got {self.colour_weight}"
            )
        if not math.isfinite(self.colour_concavity):
            raise ConfigError(f"colour_concavity must be finite, got {self.colour_concavity}")
        if self.crease_scale_px < 1 or self.crease_smooth_px < 0 or self.crease_smooth_depth <= 0:
            raise ConfigError(
                "crease_scale_px must be >= 1 px, crease_smooth_px >= 0 and crease_smooth_depth"
                f" > 0 m; got {self.crease_scale_px}, {self.crease_smooth_px},"
                f" {self.crease_smooth_depth}"
            )
        if self.refine_sample < 3:
            raise ConfigError(f"refine_sample must be >= 3, got {self.refine_sample}")
        if self.refine_iterations < 0 or self.min_cluster_points < 1 or self.sor_neighbours < 1:
            raise ConfigError(
                "refine_iterations must be >= 0, min_cluster_points and sor_neighbours >= 1"
            )
        if not 0 <= self.min_table_fraction <= 1:
            raise ConfigError(
                f"min_table_fraction must be in [0, 1], got {self.min_table_fraction}"
            )
        if not 0 < self.max_tilt <= math.pi / 2:
            raise ConfigError(f"max_tilt must be in (0, pi/2] rad, got {self.max_tilt}")
        if self.up is not None and (len(self.up) != 3 or not any(self.up)):
            raise ConfigError(f"up must be None or a non-zero 3-vector, got {self.up}")
        if (self.workspace_min is None) != (self.workspace_max is None):
            raise ConfigError("give both workspace_min and workspace_max, or neither")
        if self.workspace_min is not None and (
            len(self.workspace_min) != 3
            or len(self.workspace_max) != 3
            or any(a >= b for a, b in zip(self.workspace_min, self.workspace_max, strict=True))
        ):
            raise ConfigError("workspace_min must be below workspace_max on every axis (3,)")
        if self.fill_holes_px < 0:
            raise ConfigError(f"fill_holes_px must be >= 0, got {self.fill_holes_px}")
        if self.claim_dropouts_px < 0:
            raise ConfigError(
                f"claim_dropouts_px must be >= 0 pixels (0 = off), got {self.claim_dropouts_px}"
            )
        if self.level_top_px < 0:
            raise ConfigError(
                f"level_top_px must be >= 0 pixels (0 = off), got {self.level_top_px}"
            )
        if self.fragment_px < 0:
            raise ConfigError(f"fragment_px must be >= 0 pixels (0 = off), got {self.fragment_px}")
        if self.split_bridges_px < 0:
            raise ConfigError(
                f"split_bridges_px must be >= 0 pixels (0 = off), got {self.split_bridges_px}"
            )
        if not (math.isfinite(self.round_margin) and self.round_margin >= 0):
            raise ConfigError(f"round_margin must be >= 0 m (0 = off), got {self.round_margin}")
        if not (math.isfinite(self.halves_extent) and self.halves_extent >= 0):
            raise ConfigError(f"halves_extent must be >= 0 m (0 = off), got {self.halves_extent}")
        if not (math.isfinite(self.round_residual) and self.round_residual > 0):
            raise ConfigError(f"round_residual must be > 0 m, got {self.round_residual}")
        if self.border_px < 0 or self.touch_px < 0:
            raise ConfigError("border_px and touch_px must be >= 0")
        if self.mask_fill not in ("none", "close", "hull"):
            raise ConfigError(
                f"mask_fill must be 'none', 'close' or 'hull', got {self.mask_fill!r}"
            )
