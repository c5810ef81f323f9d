"""From a depth frame or a point cloud to one :class:`Observation` per object on the table.

The paper's ``GetObjectHypotheses`` (its reference [17]; the UJI platform clusters the cloud's
connected components with PCL): the table plane by RANSAC refined by least squares, the points
above it inside a workspace, clusters by connectivity, statistical outlier removal, and per
cluster an observation with its own mask and depth image in the camera's image.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from symjax.camera import Camera
from symjax.errors import ConfigError, EmptyInputError, InvalidInputError, ShapeError
from symjax.geometry import pixel_rays
from symjax.observation import Observation, fill_mask
from symjax.perception.clusters import cloud_clusters, grid_outliers, image_clusters
from symjax.perception.config import SegmentationConfig
from symjax.perception.ransac import fit_table_plane, ransac_plane, subsample
from symjax.table import TablePlane

__all__ = ["ObjectInfo", "TableScene", "segment"]


@dataclasses.dataclass(frozen=True)
class ObjectInfo:
    """What the segmentation knows about one object hypothesis.

    Attributes:
        n_points: Points of the object.
        centroid: Centroid (3,) of its points, metres, world frame.
        extent: Largest width of its footprint on the table, metres.
        touches_border: Its mask reaches the image border (the view is cut; the object may be
            larger than seen).
        neighbours: Indices of objects whose masks touch this one in the image.
        occluded_by: The neighbours that are in front of it (they hide part of it).
        maybe_merged: Its footprint is wider than ``max_object_extent``: it may be several
            touching objects that no depth step separates.
    """

    n_points: int
    centroid: np.ndarray
    extent: float
    touches_border: bool
    neighbours: tuple[int, ...]
    occluded_by: tuple[int, ...]
    maybe_merged: bool


@dataclasses.dataclass(frozen=True)
class TableScene:
    """The result of :func:`segment`.

    Attributes:
        table: The table plane (normal towards the camera).
        objects: One observation per object hypothesis, largest first.
        info: One :class:`ObjectInfo` per object.
        labels: (H, W) int32 image: object index per pixel, -1 elsewhere.
        table_mask: (H, W) bool pixels on the table plane (for point-cloud input: the projection
            of the table inliers).
        warnings: Human-readable notes: empty table, objects cut by the border, touching or
            possibly merged objects.
    """

    table: TablePlane
    objects: tuple[Observation, ...]
    info: tuple[ObjectInfo, ...]
    labels: np.ndarray
    table_mask: np.ndarray
    warnings: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.objects)

    def __iter__(self):
        return iter(self.objects)

    def __getitem__(self, i: int) -> Observation:
        return self.objects[i]

    @property
    def empty(self) -> bool:
        """True when no object was found on the table."""
        return not self.objects


_RAYS_CACHE: dict[tuple, np.ndarray] = {}


def _rays(camera: Camera) -> np.ndarray:
    """Camera-frame rays (H, W, 3) with unit z, cached per intrinsics (frames share a camera)."""
    K = np.asarray(camera.K, np.float64)
    key = (K.tobytes(), camera.width, camera.height)
    if key not in _RAYS_CACHE:
        if len(_RAYS_CACHE) > 8:
            _RAYS_CACHE.clear()
        _RAYS_CACHE[key] = pixel_rays(K, camera.height, camera.width).astype(np.float32)
    return _RAYS_CACHE[key]


def _in_workspace(points: np.ndarray, cfg: SegmentationConfig) -> np.ndarray | bool:
    if cfg.workspace_min is None:
        return True
    lo = np.asarray(cfg.workspace_min, np.float32)
    hi = np.asarray(cfg.workspace_max, np.float32)
    return np.all((points >= lo) & (points <= hi), axis=-1)


def _footprint_extent(points: np.ndarray, table: TablePlane) -> float:
    n = np.asarray(table.normal, np.float64)
    q = points - np.outer(points @ n, n)
    q = q - q.mean(axis=0)
    _, _, vt = np.linalg.svd(q[:: max(1, len(q) // 2000)], full_matrices=False)
    a = q @ vt[:2].T
    return float(np.max(a.max(axis=0) - a.min(axis=0)))


def _relations(labels: np.ndarray, depth: np.ndarray, k: int, box, cfg: SegmentationConfig):
    """Neighbours of object ``k`` in the image and which of them are in front of it."""
    import cv2

    pad = cfg.touch_px + 1
    r0, r1 = max(box[0].start - pad, 0), min(box[0].stop + pad, labels.shape[0])
    c0, c1 = max(box[1].start - pad, 0), min(box[1].stop + pad, labels.shape[1])
    lab = labels[r0:r1, c0:c1]
    mk = (lab == k).astype(np.uint8)
    ker = np.ones((2 * cfg.touch_px + 1, 2 * cfg.touch_px + 1), np.uint8)
    ring = (cv2.dilate(mk, ker) > 0) & (mk == 0)
    near = np.unique(lab[ring])
    near = [int(j) for j in near if j >= 0 and j != k]
    occluders = []
    dep = depth[r0:r1, c0:c1]
    for j in near:
        mj = (lab == j).astype(np.uint8)
        theirs = dep[ring & (lab == j)]
        ours = dep[(cv2.dilate(mj, ker) > 0) & (mk > 0)]
        theirs, ours = theirs[theirs > 0], ours[ours > 0]
        if theirs.size and ours.size and np.median(theirs) < np.median(ours):
            occluders.append(j)
    return tuple(near), tuple(occluders)


def _touches_border(mask: np.ndarray, px: int) -> bool:
    b = max(px, 1)
    return bool(mask[:b].any() or mask[-b:].any() or mask[:, :b].any() or mask[:, -b:].any())


def _describe(
    objects, labels, depth, table, cfg: SegmentationConfig
) -> tuple[tuple[ObjectInfo, ...], tuple[str, ...]]:
    from scipy.ndimage import find_objects

    infos, notes = [], []
    boxes = find_objects(labels + 1, max_label=len(objects))
    for k, obs in enumerate(objects):
        pts = obs.valid_points().astype(np.float64)
        box = boxes[k] if k < len(boxes) else None
        mask = np.zeros(labels.shape, bool)
        if box is not None:
            mask[box] = labels[box] == k
        near, occ = _relations(labels, depth, k, box, cfg) if mask.any() else ((), ())
        extent = _footprint_extent(pts, table)
        info = ObjectInfo(
            n_points=len(pts),
            centroid=pts.mean(axis=0),
            extent=extent,
            touches_border=_touches_border(mask, cfg.border_px),
            neighbours=near,
            occluded_by=occ,
            maybe_merged=extent > cfg.max_object_extent,
        )
        infos.append(info)
        if info.touches_border:
            notes.append(f"object {k} is cut by the image border; it may extend beyond the view")
        if occ:
            notes.append(f"object {k} is partly hidden by object(s) {list(occ)} in front of it")
        elif near:
            notes.append(f"object {k} touches object(s) {list(near)} in the image")
        if info.maybe_merged:
            notes.append(
                f"object {k} is {extent:.2f} m wide (> max_object_extent "
                f"{cfg.max_object_extent} m): it may be several touching objects"
            )
    if not objects:
        notes.append("no objects found above the table (empty table)")
    return tuple(infos), tuple(notes)


def _table_hull(on_table: np.ndarray) -> np.ndarray:
    """Convex hull (H, W) bool of the table pixels, from each row's outermost table pixels."""
    import cv2

    rows = np.flatnonzero(on_table.any(axis=1))
    W = on_table.shape[1]
    sub = on_table[rows]
    left = np.argmax(sub, axis=1)
    right = W - 1 - np.argmax(sub[:, ::-1], axis=1)
    pts = np.concatenate([np.stack([left, rows], 1), np.stack([right, rows], 1)]).astype(np.int32)
    hull = np.zeros(on_table.shape, np.uint8)
    cv2.fillConvexPoly(hull, cv2.convexHull(pts), 1)
    return hull > 0


def _fill_holes(depth: np.ndarray, valid: np.ndarray, passes: int) -> np.ndarray:
    """Depth with small holes filled by the nearest (smallest) neighbouring depth."""
    import cv2

    if passes == 0 or valid.all():
        return depth
    big = np.float32(1e9)
    filled = np.where(valid, depth, big)
    kernel = np.ones((3, 3), np.uint8)
    for _ in range(passes):
        # Erosion of a float image is the 3x3 minimum: the nearest surface around a hole.
        nearest = cv2.erode(filled, kernel, borderType=cv2.BORDER_REPLICATE)
        filled = np.where(filled < big, filled, nearest)
    return np.where(filled < big, filled, np.float32(0.0))


def _segment_depth(depth: np.ndarray, camera: Camera, cfg: SegmentationConfig) -> TableScene:
    depth = np.asarray(depth, dtype=np.float32)
    hw = (camera.height, camera.width)
    if depth.shape != hw:
        raise ShapeError(f"depth image must have the camera's shape {hw}, got {depth.shape}")
    depth = np.where(np.isfinite(depth), depth, np.float32(0.0))
    if np.any(depth < 0):
        raise InvalidInputError("depth must be >= 0 metres (0 = no measurement)")
    valid = depth > 0
    idx = np.flatnonzero(valid)
    if len(idx) < 3:
        raise EmptyInputError("the depth image has fewer than 3 measured pixels")
    T = np.asarray(camera.T_world_cam, np.float32)
    R, t = T[:3, :3], T[:3, 3]
    rays = _rays(camera)
    flat_rays, flat_depth = rays.reshape(-1, 3), depth.reshape(-1)

    def world(ids):
        return (flat_rays[ids] * flat_depth[ids, None]) @ R.T + t

    # Only the subsamples are back-projected for the plane fit; heights of all pixels follow
    # from the plane expressed in the camera frame.
    rng = np.random.default_rng(cfg.seed)
    sample, refine = subsample(idx, cfg, rng)
    table = ransac_plane(world(sample), world(refine), cfg, np.asarray(camera.position), rng)
    n = np.asarray(table.normal, np.float32)
    conn = _fill_holes(depth, valid, cfg.fill_holes_px)
    height = conn * (rays @ (R.T @ n)) + np.float32(float(n @ t) + float(table.offset))
    on_table = valid & (np.abs(height) < cfg.inlier_threshold)
    cand = (conn > 0) & (height > cfg.grow_height) & (height < cfg.max_height)
    if cfg.table_hull and on_table.any():
        cand &= _table_hull(on_table)
    labels = np.full(hw, -1, np.int32)
    if cand.any():
        # Work on the candidates' bounding box (plus a pixel for the depth steps) only.
        rows, cols = np.flatnonzero(cand.any(axis=1)), np.flatnonzero(cand.any(axis=0))
        r0, r1 = max(rows[0] - 1, 0), min(rows[-1] + 2, hw[0])
        c0, c1 = max(cols[0] - 1, 0), min(cols[-1] + 2, hw[1])
        sl = (slice(r0, r1), slice(c0, c1))
        if cfg.workspace_min is not None:
            ids = np.ravel_multi_index(np.nonzero(cand), hw)
            cand.reshape(-1)[ids] = _in_workspace(world(ids), cfg)
        lab = image_clusters(conn[sl], height[sl], cand[sl], cfg)
        lab[~valid[sl]] = -1
        lab[grid_outliers(depth[sl], rays[sl], lab, cfg)] = -1
        labels[sl] = lab
    from scipy.ndimage import find_objects

    objects = []
    n_obj = int(labels.max()) + 1
    keep = np.full(max(n_obj, 1), -1, np.int32)
    for k, box in enumerate(find_objects(labels + 1, max_label=n_obj)):
        if box is None:
            continue
        m = np.zeros(hw, bool)
        m[box] = labels[box] == k
        r, c = np.nonzero(m[box])
        ids = (r + box[0].start) * hw[1] + (c + box[1].start)
        if len(ids) < 10:
            continue
        keep[k] = len(objects)
        objects.append(
            Observation.create(
                world(ids), camera, table, fill_mask(m, cfg.mask_fill), np.where(m, depth, 0.0)
            )
        )
    labels = np.where(labels >= 0, keep[np.maximum(labels, 0)], -1).astype(np.int32)
    infos, notes = _describe(objects, labels, depth, table, cfg)
    return TableScene(table, tuple(objects), infos, labels, on_table, notes)


def _segment_cloud(
    points: np.ndarray, camera: Camera | None, viewpoint: Any, cfg: SegmentationConfig
) -> TableScene:
    from symjax.io.point_cloud import cloud_observation
    from symjax.observation import render_points

    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"point cloud must have shape (N, 3), got {p.shape}")
    p = p[np.all(np.isfinite(p), axis=1)]
    if camera is None and viewpoint is None:
        raise InvalidInputError(
            "a point cloud needs a camera (or a viewpoint) to build the objects' masks"
        )
    origin = np.asarray(camera.position) if camera is not None else np.asarray(viewpoint)
    table, inliers = fit_table_plane(p, cfg, viewpoint=origin)
    height = p @ np.asarray(table.normal) + float(table.offset)
    cand = (height > cfg.grow_height) & (height < cfg.max_height) & _in_workspace(p, cfg)
    idx = np.flatnonzero(cand)
    lab = cloud_clusters(p[idx], height[idx], cfg)
    objects = []
    for k in range(int(lab.max(initial=-1)) + 1):
        obj = p[idx[lab == k]]
        if len(obj) < 10:
            continue
        objects.append(
            cloud_observation(obj, table, camera=camera, viewpoint=viewpoint, fill=cfg.mask_fill)
        )
    if camera is not None:
        hw = (camera.height, camera.width)
        labels = np.full(hw, -1, np.int32)
        depth = np.zeros(hw, np.float32)
        # Nearer objects win a pixel, as in the sensor's image.
        order = sorted(
            range(len(objects)),
            key=lambda k: (
                -np.median(np.asarray(objects[k].depth)[np.asarray(objects[k].depth) > 0])
            ),
        )
        for k in order:
            m = np.asarray(objects[k].mask)
            labels[m] = k
            depth[m] = np.asarray(objects[k].depth)[m]
        front = p[inliers]
        table_mask = render_points(front, camera)[0] if len(front) else np.zeros(hw, bool)
    else:
        labels = np.full((1, 1), -1, np.int32)
        depth = np.zeros((1, 1), np.float32)
        table_mask = np.zeros((1, 1), bool)
    infos, notes = _describe(objects, labels, depth, table, cfg)
    return TableScene(table, tuple(objects), infos, labels, table_mask, notes)


def segment(
    data: Any, camera: Camera | None = None, config: SegmentationConfig | None = None
) -> TableScene:
    """Finds the table and the object hypotheses on it.

    Args:
        data: A :class:`symjax.io.DepthFrame`, a depth image (H, W) in metres (0 = none) with
            ``camera``, a :class:`symjax.io.PointCloud`, or a cloud (N, 3) in metres, world frame.
        camera: The camera; required for a bare depth image, optional for a cloud that has a
            viewpoint (each object then gets a virtual camera at the viewpoint looking at it).
        config: Settings; defaults to :class:`SegmentationConfig`.

    Returns:
        A :class:`TableScene`; an empty table gives no objects and a warning, objects cut by the
        image border or touching each other are flagged in :attr:`TableScene.info`.

    Raises:
        InvalidInputError: Unsupported input, or a depth image or cloud without a camera.
        ShapeError: A depth image that does not match the camera, or a cloud not (N, 3).
        EmptyInputError: Fewer than 3 measurements.
        DegenerateGeometryError: No table plane in the data.
    """
    from symjax.io.depth_frame import DepthFrame
    from symjax.io.point_cloud import PointCloud

    config = config or SegmentationConfig()
    if not isinstance(config, SegmentationConfig):
        raise ConfigError(f"config must be a SegmentationConfig, got {type(config).__name__}")
    if camera is not None and not isinstance(camera, Camera):
        raise InvalidInputError(f"camera must be a symjax.Camera, got {type(camera).__name__}")
    if isinstance(data, DepthFrame):
        return _segment_depth(data.depth, camera or data.camera, config)
    if isinstance(data, PointCloud):
        return _segment_cloud(data.points, camera, data.viewpoint, config)
    try:
        arr = np.asarray(data, np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"data must be a DepthFrame, a PointCloud, a depth image (H, W) or a cloud (N, 3);"
            f" got {type(data).__name__} that is not a numeric array (pass the camera as the"
            " second argument: segment(depth, camera))"
        ) from None
    if camera is not None and arr.shape == (camera.height, camera.width):
        return _segment_depth(arr, camera, config)
    if arr.ndim == 2 and arr.shape[1] == 3:
        return _segment_cloud(arr, camera, None, config)
    if camera is None and arr.ndim == 2:
        raise InvalidInputError("a depth image needs its camera: segment(depth, camera)")
    raise ShapeError(
        f"expected a depth image (H, W) matching the camera or a cloud (N, 3), got {arr.shape}"
    )
