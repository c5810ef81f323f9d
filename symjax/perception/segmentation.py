"""From a depth frame or a point cloud to one :class:`Observation` per object on the table.

The paper's ``GetObjectHypotheses`` (its reference [17]; the UJI platform clusters the cloud's
connected components with PCL): the table plane by RANSAC refined by least squares, the points
above it inside a workspace, clusters by connectivity, statistical outlier removal, and per
cluster an observation with its own mask and depth image in the camera's image.
"""

from __future__ import annotations

import dataclasses
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from symjax._threads import serial_blas
from symjax.camera import Camera
from symjax.errors import ConfigError, EmptyInputError, InvalidInputError, ShapeError
from symjax.observation import Observation
from symjax.perception.clusters import (
    cloud_clusters,
    grid_outliers,
    image_clusters,
    neighbour_distances,
)
from symjax.perception.config import SegmentationConfig
from symjax.perception.creases import colour_creases, crease_concavity, crease_mask, lab_image
from symjax.perception.depth_pixels import (
    box_shift,
    candidate_boxes,
    enclosed,
    fill_holes,
    in_workspace,
    object_mask,
    pixel_rays_of,
    table_hull,
)
from symjax.perception.dropouts import claim_dropouts
from symjax.perception.footprint import table_footprint
from symjax.perception.fragments import drop_fragments
from symjax.perception.object_info import (
    EMPTY_TABLE,
    ObjectInfo,
    describe_object,
    describe_objects,
    occluder_depth,
    unclaimed_surfaces,
)
from symjax.perception.occluded_halves import join_occluded_halves
from symjax.perception.ransac import fit_table_plane, ransac_plane, subsample
from symjax.perception.round_parts import settle_round_parts
from symjax.perception.round_split import split_round_objects
from symjax.perception.support import join_supported
from symjax.perception.table_frame import in_table_frame
from symjax.table import TablePlane

__all__ = ["ObjectInfo", "TableScene", "segment"]


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
        frame: The world frame of the results: ``"given"`` (the camera's pose, or the cloud's
            frame) or ``"table"`` (the camera had no pose: z along the table normal towards the
            camera, origin on the table below the objects' centre, x along the optical axis
            projected on the table).
        T_world_input: (4, 4) transform from the input's frame (the camera frame when the pose
            was unknown) to ``frame``; identity for ``"given"``.
    """

    table: TablePlane
    objects: tuple[Observation, ...]
    info: tuple[ObjectInfo, ...]
    labels: np.ndarray
    table_mask: np.ndarray
    warnings: tuple[str, ...]
    frame: str = "given"
    T_world_input: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(4))

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


def _segment_depth(
    depth: np.ndarray, camera: Camera, cfg: SegmentationConfig, rgb=None
) -> TableScene:
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
    rays = pixel_rays_of(camera)
    flat_rays, flat_depth = rays.reshape(-1, 3), depth.reshape(-1)

    def world(ids):
        return (flat_rays[ids] * flat_depth[ids, None]) @ R.T + t

    # Only the subsamples are back-projected for the plane fit; heights of all pixels follow
    # from the plane expressed in the camera frame.
    rng = np.random.default_rng(cfg.seed)
    with ThreadPoolExecutor(1) as pool:  # the holes filled on a second core meanwhile
        conn = pool.submit(fill_holes, depth, valid, cfg.fill_holes_px)
        sample, refine = subsample(idx, cfg, rng)
        table = ransac_plane(world(sample), world(refine), cfg, np.asarray(camera.position), rng)
        conn = conn.result()
    n = np.asarray(table.normal, np.float32)
    height = conn * (rays @ (R.T @ n)) + np.float32(float(n @ t) + float(table.offset))
    on_table = valid & (np.abs(height) < cfg.inlier_threshold)
    cand = (conn > 0) & (height > cfg.grow_height) & (height < cfg.max_height)
    if cfg.table_hull and on_table.any():
        cand &= table_hull(on_table)
    labels = np.full(hw, -1, np.int32)
    surface = None  # with unclaimed_occluders: the candidates measured (box sl), less strays
    # Work on the box of the candidates that can be objects only (not the table's specks).
    sl, every = candidate_boxes(cand, cfg) if cand.any() else (None, None)
    if sl is not None:
        if cfg.workspace_min is not None:
            ids = np.ravel_multi_index(np.nonzero(cand), hw)
            cand.reshape(-1)[ids] = in_workspace(world(ids), cfg)
        # What does not depend on the labels runs on a second core while this one segments:
        # numpy's and OpenCV's loops release the GIL (segment() used one core of two).
        with ThreadPoolExecutor(1) as pool:
            crease_on = cfg.crease_threshold is not None
            colour = pool.submit(lab_image, rgb[sl]) if rgb is not None and crease_on else None
            kappa = crease = None
            if crease_on:  # (two threads of its own: the distances wait until it is done)
                focal = float(np.sqrt(camera.K[0, 0] * camera.K[1, 1]))
                kappa = crease_concavity(conn[sl], focal, cfg)
            distances = pool.submit(neighbour_distances, depth[sl], rays[sl])
            if crease_on:
                crease = crease_mask(kappa, cfg)
            colour = None if colour is None else colour.result()
            cut = None if colour is None else colour_creases(colour, kappa, cfg)
            lab, fragment = image_clusters(
                conn[sl], height[sl], cand[sl], cfg, crease, colour, cut, kappa, with_fragments=True
            )
            if kappa is not None and lab.max() > 0:
                foot = table_footprint(lab, rays[sl], conn[sl], T, n)
                if cfg.round_objects:  # (before the joins: they give a strip back)
                    lab = split_round_objects(lab, foot, height[sl], cfg.min_cluster_points)
                lab = join_occluded_halves(lab, foot, height[sl], conn[sl], cfg)
                lab, smooth, touch = join_supported(
                    lab, foot, height[sl], cfg, depth=conn[sl], with_contacts=True
                )
                if cfg.round_margin > 0:  # (joins relabel parts, not pixels: foot holds)
                    lab = settle_round_parts(lab, foot, height[sl], conn[sl], cfg, smooth, touch)
            if fragment is not None:  # (those that joined no object)
                lab = drop_fragments(lab, fragment)
            lab[~valid[sl]] = -1
            stray = grid_outliers(depth[sl], rays[sl], lab, cfg, distances.result())
            lab[stray] = -1
            if cfg.unclaimed_occluders:  # (the sensor's stray points are no surface)
                surface = cand[sl] & valid[sl] & (height[sl] > cfg.seed_height) & ~stray
        labels[sl] = lab
    from scipy.ndimage import find_objects

    n_obj = int(labels.max()) + 1
    keep = np.full(max(n_obj, 1), -1, np.int32)
    found = []  # (label, its pixels' flat indices)
    boxes = find_objects(labels + 1, max_label=n_obj)
    for k, box in enumerate(boxes):
        if box is None:
            continue
        r, c = np.nonzero(labels[box] == k)
        ids = (r + box[0].start) * hw[1] + (c + box[1].start)
        if len(ids) >= 10:
            found.append((k, ids))
    points = {k: world(ids) for k, ids in found}
    claimed_ids, claimed_by = np.zeros(0, np.int64), np.zeros(0, np.int32)  # pixel, object
    if cfg.claim_dropouts_px > 0 and found:  # (on the box of all candidates: claims reach far)
        e0, f0 = every[0].start, every[1].start
        crop_boxes = [None if b is None else box_shift(b, -e0, -f0) for b in boxes]
        claimed = claim_dropouts(labels[every], valid[every], rays[every], T, points, n,
                                 float(table.offset), cfg.claim_dropouts_px,
                                 crop_boxes)  # fmt: skip
        rr, cc = np.nonzero(claimed >= 0)
        claimed_ids = (rr + e0) * hw[1] + (cc + f0)
        claimed_by = claimed[rr, cc]

    # Each object's mask on its box, not the frame; then, one object after the other, the free
    # pixels each mask encloses (no longer free for the next). The per-object steps run one after
    # the other: they are short numpy calls, and two threads passing the GIL back and forth took
    # 1.06-1.11x their time (10 clutter scenes, 640 x 480 and 1280 x 720).
    made = []  # (points, box, mask and measured pixels on it)
    free = valid & (labels == -1)
    for k, ids in found:
        box, m, mask = object_mask(ids, claimed_ids[claimed_by == k], hw, cfg.mask_fill)
        if cfg.object_holes:
            hole = enclosed(mask, free[box])
            if hole.any():
                labels[box][hole], m = k, m | hole
                free[box] &= ~hole
                rr, cc = np.nonzero(hole)
                at = (rr + box[0].start) * hw[1] + (cc + box[1].start)
                points[k] = np.concatenate([points[k], world(at)])
        keep[k] = len(made)
        made.append((points[k], box, mask | m, m))
    labels = np.append(keep, np.int32(-1))[labels]  # -1 indexes the appended -1
    boxes = find_objects(labels + 1, max_label=len(made))
    # Depth of the pieces of surface above the table that no object holds, 0 elsewhere.
    unclaimed = None
    if surface is not None and made:  # (on the candidates' box sl, as surface)
        piece = unclaimed_surfaces(labels[sl], surface, depth[sl])
        if piece is not None:
            unclaimed = np.zeros(hw, np.float32)
            unclaimed[sl] = piece

    def finish(i: int):
        p, box, mask_box, m = made[i]
        mask = np.zeros(hw, bool)
        mask[box] = mask_box
        seen = np.zeros(hw, np.float32)
        seen[box] = np.where(m, depth[box], np.float32(0.0))
        obs = Observation.create(p, camera, table, mask, seen)
        info, notes = describe_object(i, obs, labels, depth, table, cfg, boxes[i])
        if info.occluded_by or unclaimed is not None:
            # Neighbours in front hide part of the object: their pixels keep their depth
            # outside its mask, so that the symmetry search does not take them for empty
            # space (Eq. 3); so do the surfaces no object holds (the sets are disjoint).
            occ = occluder_depth(labels, depth, info.occluded_by, boxes)
            occ = occ if unclaimed is None else occ + unclaimed
            occ[box] = np.where(mask_box, seen[box], occ[box])
            obs = dataclasses.replace(obs, depth=occ)
        return obs, info, notes

    done = [finish(i) for i in range(len(made))]
    objects = [obs for obs, _, _ in done]
    infos = tuple(info for _, info, _ in done)
    notes = tuple(n for _, _, said in done for n in said) + (() if made else (EMPTY_TABLE,))
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
    cand = (height > cfg.grow_height) & (height < cfg.max_height) & in_workspace(p, cfg)
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
    infos, notes = describe_objects(objects, labels, depth, table, cfg)
    return TableScene(table, tuple(objects), infos, labels, table_mask, notes)


def _rgb(rgb, depth) -> np.ndarray | None:
    if rgb is None:
        return None
    img = np.asarray(rgb)
    if img.shape != np.shape(depth) + (3,):
        raise ShapeError(f"rgb must be (H, W, 3) like the depth {np.shape(depth)}, got {img.shape}")
    return img.astype(np.uint8) if img.dtype != np.uint8 else img


def segment(
    data: Any,
    camera: Camera | None = None,
    config: SegmentationConfig | None = None,
    rgb: Any = None,
) -> TableScene:
    """Finds the table and the object hypotheses on it.

    Args:
        data: A :class:`symjax.io.DepthFrame`, a depth image (H, W) in metres (0 = none) with
            ``camera``, a :class:`symjax.io.PointCloud`, or a cloud (N, 3) in metres, world frame.
        camera: The camera; required for a bare depth image, optional for a cloud that has a
            viewpoint (each object then gets a virtual camera at the viewpoint looking at it).
        config: Settings; defaults to :class:`SegmentationConfig`.
        rgb: Colour image (H, W, 3) uint8 of a depth image (a :class:`DepthFrame`'s own by
            default): with the crease cut on, its edges are a further cue where objects meet.

    Returns:
        A :class:`TableScene`; an empty table gives no objects and a warning, objects cut by the
        image border or touching each other are flagged in :attr:`TableScene.info`. A depth
        image whose camera has no pose (``T_world_cam`` the identity) is answered in the table
        frame the plane defines (:attr:`TableScene.frame` says which).

    Raises:
        InvalidInputError: Unsupported input, or a depth image or cloud without a camera.
        ShapeError: A depth image that does not match the camera, or a cloud not (N, 3).
        EmptyInputError: Fewer than 3 measurements.
        DegenerateGeometryError: No table plane in the data.
    """
    with serial_blas():
        return _segment(data, camera, config, rgb)


def _segment(data: Any, camera: Camera | None, config, rgb) -> TableScene:
    from symjax.io.depth_frame import DepthFrame
    from symjax.io.point_cloud import PointCloud

    config = config or SegmentationConfig()
    if not isinstance(config, SegmentationConfig):
        raise ConfigError(f"config must be a SegmentationConfig, got {type(config).__name__}")
    if camera is not None and not isinstance(camera, Camera):
        raise InvalidInputError(f"camera must be a symjax.Camera, got {type(camera).__name__}")
    if isinstance(data, DepthFrame):
        return in_table_frame(
            _segment_depth(
                data.depth,
                camera or data.camera,
                config,
                _rgb(rgb if rgb is not None else data.rgb, data.depth),
            ),
            camera or data.camera,
        )
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
        return in_table_frame(_segment_depth(arr, camera, config, _rgb(rgb, arr)), camera)
    if arr.ndim == 2 and arr.shape[1] == 3:
        return _segment_cloud(arr, camera, None, config)
    if camera is None and arr.ndim == 2:
        raise InvalidInputError("a depth image needs its camera: segment(depth, camera)")
    raise ShapeError(
        f"expected a depth image (H, W) matching the camera or a cloud (N, 3), got {arr.shape}"
    )
