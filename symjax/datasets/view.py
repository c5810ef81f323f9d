"""One benchmark view: a partial observation plus whatever ground truth the data source has.

The simulated benchmark (:func:`symjax.datasets.benchmark`) fills every field; a loader of the
paper's real KTH database produces the same type with ``gt_mesh=None`` and, where no pose is
known, ``gt_pose=None`` and ``symmetry_planes=None``. Downstream code is data-source agnostic.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from symjax.errors import InvalidInputError
from symjax.observation import Observation

__all__ = ["View", "symmetry_truth"]

SymmetryKind = Literal["none", "planar", "rotational", "unknown"]


@dataclass(frozen=True, eq=False)
class View:
    """A view of one object on a table.

    Attributes:
        name: Unique view name, ``"<dataset>/<orientation:03d>"``, e.g. ``"025_mug/045"``.
        dataset: Data set id, e.g. ``"003_cracker_box"`` or ``"003_cracker_box_lying"``.
        object_name: Object name (``"003_cracker_box"`` for both data sets of that object).
        orientation_deg: Object orientation about the table normal, degrees (0 = longest
            table-projected dimension parallel to the image plane).
        observation: The object's partial view: points (N, 3) world metres, mask and object-only
            depth (H, W), camera, table.
        depth: Full-frame depth image (H, W), metres along the optical axis, table included,
            0 = no depth.
        gt_mesh: Ground-truth ``trimesh.Trimesh`` in the world frame as posed, or None.
        gt_pose: Object pose (4, 4) mapping the canonical object frame to the world, or None.
        gt_diagonal: Diagonal of the true object's oriented bounding box, metres (the same in
            every pose; the centroid error divides by it), or None: taken from ``gt_mesh``.
        symmetry: ``"planar"``, ``"rotational"`` (about the vertical axis ``symmetry_axis``),
            ``"none"`` or ``"unknown"``.
        symmetry_planes: True symmetry planes ``(normal (3,), offset)`` of ``{x : n . x = offset}``
            in the world frame; ``[]`` when the object has none, ``None`` when unknown. For a
            rotational object it holds one representative plane: the vertical plane through the
            axis perpendicular to the horizontal viewing direction (the plane that mirrors the
            visible front onto the hidden back); :func:`plane_error` accepts any plane through the
            axis.
        symmetry_axis: ``(point (3,), direction (3,))`` of the rotation axis in the world frame,
            or None.
        flying: Per observation point (N,), True for simulated flying pixels (off the surface by
            construction), or None for real data.
        source: ``"simulated"`` or the name of the real database.
        meta: Extra information (camera distance, elevation, seed, mirrored-mesh deviations).
    """

    name: str
    dataset: str
    object_name: str
    orientation_deg: float
    observation: Observation
    depth: np.ndarray
    gt_mesh: Any | None = None
    gt_pose: np.ndarray | None = None
    gt_diagonal: float | None = None
    symmetry: SymmetryKind = "unknown"
    symmetry_planes: list[tuple[np.ndarray, float]] | None = None
    symmetry_axis: tuple[np.ndarray, np.ndarray] | None = None
    flying: np.ndarray | None = None
    source: str = "simulated"
    meta: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_observation(
        cls,
        observation: Observation,
        name: str,
        dataset: str = "",
        orientation_deg: float = float("nan"),
        depth: np.ndarray | None = None,
        source: str = "real",
        **kwargs: Any,
    ) -> View:
        """A view of real data: an observation without ground truth (symmetry unknown).

        Args:
            observation: The object's observation.
            name: View name.
            dataset: Data set id (default: the part of ``name`` before ``/``).
            orientation_deg: Orientation, degrees (nan when unknown).
            depth: Full-frame depth (H, W), metres; default the observation's object depth.
            source: Data source name.
            **kwargs: Other :class:`View` fields (``gt_mesh``, ``gt_pose``, ``symmetry``...).

        Raises:
            InvalidInputError: If ``observation`` is not an :class:`Observation`.
        """
        if not isinstance(observation, Observation):
            raise InvalidInputError(
                f"observation must be a symjax.Observation, got {type(observation).__name__}"
            )
        return cls(
            name=name,
            dataset=dataset or name.split("/")[0],
            object_name=kwargs.pop("object_name", dataset or name.split("/")[0]),
            orientation_deg=float(orientation_deg),
            observation=observation,
            depth=np.asarray(observation.depth if depth is None else depth, np.float32),
            source=source,
            **kwargs,
        )

    @classmethod
    def from_kth(cls, kth_view: Any) -> View:
        """Wraps a view of the paper's KTH database (``symjax.io.load_kth_view``) as a View.

        The database has no full-frame depth (the object depth stands in), no mesh, pose or
        symmetry ground truth in its files.
        """
        deg = float(getattr(kth_view, "degree", -1))
        obj = getattr(kth_view, "name", "") or "kth"
        return cls.from_observation(
            kth_view.observation,
            name=f"{obj}/{int(deg):03d}" if deg >= 0 else obj,
            dataset=obj,
            orientation_deg=deg if deg >= 0 else float("nan"),
            source="kth",
            meta={"path": str(getattr(kth_view, "path", ""))},
        )

    def true_mesh(self, cache_dir: Any = None):
        """The ground-truth mesh in the world frame, as posed in this view.

        A view read without its object model gets the mesh from the data set (cached in
        ``cache_dir``, default :func:`symjax.datasets.default_cache_dir`) and ``gt_pose``.

        Raises:
            InvalidInputError: A view without ground truth (real data).
        """
        if self.gt_mesh is not None:
            return self.gt_mesh
        if self.gt_pose is None:
            raise InvalidInputError(
                f"view {self.name!r} has no ground truth (source {self.source!r}); expected a"
                " simulated view with gt_pose"
            )
        from symjax.datasets.objects import load_dataset_object

        mesh = load_dataset_object(self.dataset, cache_dir).mesh.copy()
        mesh.apply_transform(np.asarray(self.gt_pose, np.float64))
        return mesh

    @property
    def points(self) -> np.ndarray:
        """The observed object points (N, 3), world frame, metres."""
        return self.observation.valid_points()

    @property
    def camera(self):
        """The view's camera."""
        return self.observation.camera

    @property
    def mask(self) -> np.ndarray:
        """The object's segmentation mask (H, W), bool."""
        return np.asarray(self.observation.mask)


def symmetry_truth(view: View) -> dict[str, Any]:
    """The view's true symmetry as the keyword arguments of :func:`symjax.metrics.plane_error`.

    Raises:
        InvalidInputError: The view's symmetry is unknown (or rotational without an axis).
    """
    centre = _object_centre(view)
    if view.symmetry == "rotational":
        if view.symmetry_axis is None:
            raise InvalidInputError(f"view {view.name!r} is rotational but has no symmetry_axis")
        return {"axis": view.symmetry_axis, "centre": centre}
    if view.symmetry_planes is None or view.symmetry == "unknown":
        raise InvalidInputError(f"view {view.name!r} has no known symmetry to compare with")
    return {"planes": list(view.symmetry_planes), "centre": centre}


def _object_centre(view: View) -> np.ndarray:
    """Centre of the ground truth (mesh bounding box) or, without one, of the observed points."""
    if view.gt_mesh is not None:
        return np.asarray(view.gt_mesh.bounds, np.float64).mean(axis=0)
    pts = view.points
    if len(pts) == 0:
        raise InvalidInputError(f"view {view.name!r} has neither a mesh nor points")
    return pts.mean(axis=0)
