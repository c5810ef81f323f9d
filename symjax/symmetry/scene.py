"""The objects of one frame searched together: each neighbour in front as the volume its own
completion gives it, not only its visible surface (beyond the paper).

Eq. 3 excuses a mirrored point that lands behind an occluder's surface: it may be hidden
there. Directly behind that surface, though, lies the occluder itself, and a mirrored point
inside it is as impossible as one in free space. A plane that hides a heavily occluded object's
whole mirror image just behind its neighbours otherwise wins by having nothing to contradict it.
Here each object is searched once, its completion (its points and their kept mirror images)
gives the depth of its back surface on its own pixels, and every object with occluders is
searched again with each occluder pixel's depth pushed back to that surface, so that only a
mirrored point behind the whole neighbour counts as hidden. (An object whose occluder pixels
all stay, surfaces that no object holds and so have no back, keeps its first search.)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from symjax.errors import InvalidInputError, SymjaxError, config_or_default
from symjax.execution import ExecutionConfig
from symjax.observation import Observation
from symjax.symmetry.config import SymmetryConfig
from symjax.symmetry.result import SymmetryResult
from symjax.symmetry.solver import search_batch, stack_results

__all__ = ["back_depth", "behind_neighbours", "search_scene"]


def back_depth(observations: Sequence[Observation], result: SymmetryResult) -> np.ndarray:
    """Depth (H, W) float32, metres along the optical axis, of the back of each object's
    completion on its own mask's pixels: the deepest of its points and kept mirrored points
    there (0 elsewhere, and on the pixels of a view whose search failed).

    Mirrored points are splatted on a pixel each and the image closed with a 3 x 3 maximum:
    the mirror image of an object seen at a slant is sparser than the object. (A far buffer
    in numpy, not :func:`symjax.observation.render_points`: that keeps the nearest point and
    projects with eager JAX, which compiles anew for every cloud size.)

    Args:
        observations: The objects of one frame (one camera, one image size).
        result: Their batched search (:func:`~symjax.symmetry.search_batch`).
    """
    import cv2

    cam = observations[0].camera
    H, W = np.asarray(observations[0].mask).shape
    T = np.asarray(cam.T_world_cam, np.float64)
    K = np.asarray(cam.K, np.float64)
    out = np.zeros((H, W), np.float32)
    ok = np.asarray(result.ok, bool)
    for i, obs in enumerate(observations):
        if not ok[i]:
            continue
        pts = np.concatenate([np.asarray(result.points[i]), np.asarray(result.mirrored[i])])
        keep = np.concatenate([np.asarray(result.valid[i]), np.asarray(result.mirrored_keep[i])])
        x, y, z = ((pts[keep].astype(np.float64) - T[:3, 3]) @ T[:3, :3]).T
        front = z > 1e-6
        x, y, z = x[front], y[front], z[front]
        col = np.round((K[0, 0] * x + K[0, 1] * y) / z + K[0, 2]).astype(np.int64)
        row = np.round(K[1, 1] * y / z + K[1, 2]).astype(np.int64)
        inside = (col >= 0) & (col < W) & (row >= 0) & (row < H)
        img = np.zeros((H, W), np.float32)
        np.maximum.at(img, (row[inside], col[inside]), z[inside].astype(np.float32))
        img = cv2.dilate(img, np.ones((3, 3), np.uint8))
        mask = np.asarray(obs.mask, bool)
        out[mask] = np.maximum(out[mask], img[mask])
    return out


def behind_neighbours(obs: Observation, back: np.ndarray) -> Observation:
    """The observation with each occluder pixel (depth outside its mask) at the depth of the
    occluder's back (:func:`back_depth`) where that lies deeper than its visible surface;
    ``obs`` itself where no pixel moves."""
    depth = np.asarray(obs.depth, np.float32)
    occluder = ~np.asarray(obs.mask, bool) & (depth > 0)
    if not (occluder & (back > depth)).any():
        return obs
    deeper = np.where(occluder, np.maximum(depth, back), depth).astype(np.float32)
    return dataclasses.replace(obs, depth=deeper)


def search_scene(
    observations: Sequence[Observation],
    config: SymmetryConfig | None = None,
    execution: ExecutionConfig | None = None,
    first: SymmetryResult | None = None,
) -> SymmetryResult:
    """The batched search of the objects of one frame (:func:`symjax.perception.segment`'s
    ``objects``), with ``config.neighbour_volumes`` the objects behind others searched again
    against their occluders' completed volumes (see the module's docstring).

    Without ``neighbour_volumes``, or when no object has an occluder, it is
    :func:`~symjax.symmetry.search_batch`. Views without occluders get the same result either way.

    Args:
        observations: The frame's objects, all from one camera and one image size.
        config: Search parameters.
        execution: Chunk sizes; no effect on the result.
        first: Their batched :func:`~symjax.symmetry.search_batch` when the caller ran it
            (the first pass); None runs it here.

    Raises:
        InvalidInputError: The observations do not share one image size.
        SymjaxError: As :func:`~symjax.symmetry.search_batch`.
    """
    cfg = config_or_default(config, SymmetryConfig, "config")
    if cfg.neighbour_volumes and not isinstance(observations, Observation):
        # (anything but Observations is search_batch's to refuse, with its own message)
        shapes = {np.shape(o.mask) for o in observations if isinstance(o, Observation)}
        if len(shapes) > 1:
            raise InvalidInputError(
                "search_scene takes the objects of one frame (one image size); got masks of "
                f"sizes {sorted(shapes)}"
            )
    result = first if first is not None else search_batch(observations, cfg, execution)
    if not cfg.neighbour_volumes:
        return result
    obs = list(observations)
    if not any(_has_occluders(o) for o in obs):
        return result
    back = back_depth(obs, result)
    # Only the views whose occluders move back change: the others keep their first search
    # (surfaces that no object holds have no back, segment's unclaimed_occluders).
    moved = [behind_neighbours(o, back) for o in obs]
    again = [i for i, o in enumerate(moved) if o is not obs[i]]
    if not again:
        return result
    errors = [None if ok else result.errors[i] for i, ok in enumerate(result.ok)]
    single = {i: result[i] for i, ok in enumerate(result.ok) if ok and i not in again}
    try:
        second = search_batch([moved[i] for i in again], cfg, execution)
    except SymjaxError as e:  # none of them could be searched again
        second = None
        for i in again:
            errors[i] = e
    if second is not None:
        for j, i in enumerate(again):
            errors[i] = None if second.ok[j] else second.errors[j]
            if second.ok[j]:
                single[i] = second[j]
    if not single:
        raise InvalidInputError(
            "no view of the frame has a plane: "
            + "; ".join(f"view {i}: {e}" for i, e in enumerate(errors) if e is not None)
        )
    return stack_results(single, errors)


def _has_occluders(obs: Observation) -> bool:
    """Whether the observation has occluder pixels (depth outside its mask)."""
    return bool((~np.asarray(obs.mask, bool) & (np.asarray(obs.depth) > 0)).any())
