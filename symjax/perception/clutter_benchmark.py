"""The touching-objects benchmark: a fixed set of clutter scenes, mask matching against the
truth, and symmetry planes of separated objects against the same objects seen alone."""

from __future__ import annotations

import math

import numpy as np

from symjax.errors import ConfigError
from symjax.perception.config import SegmentationConfig
from symjax.perception.synthetic import SyntheticScene, clutter_scene

__all__ = [
    "EXAMINED_CLUTTER",
    "benchmark_scenes",
    "fresh_scenes",
    "held_out_scenes",
    "match_ious",
    "mcnemar_p",
    "plane_error",
    "scan_scenes",
    "score_scenes",
    "symmetry_rows",
    "truth_observation",
]

PAIRS = (("box", "can"), ("can", "can"), ("bottle", "box"))
BEHIND = (("box", "can"), ("can", "box"))
MIN_VISIBLE_PX = 1500  # clutter objects must show this much of themselves to be findable
HIDDEN_PX = 300  # scan-scene objects showing less are hidden (a 26-pixel corner is not findable)
#: The clutter scenes of the draw that were looked at while the segmentation's rules were made
#: (the first 90 until 2026-12-05; 270 since); the scenes drawn after them are held out
#: (:func:`held_out_scenes`).
EXAMINED_CLUTTER = 270
#: The seed of the last examined clutter scene (the draw's 270th that qualifies): the held-out
#: draw starts after it, without rendering the 567 seeds before (about four minutes).
LAST_EXAMINED_SEED = 567


def _clutter_draw(n: int, seed: int = 0) -> list[SyntheticScene]:
    """The first ``n`` clutter scenes of 5-8 objects from ``seed`` on that qualify: >= 3
    contacts and every object at least :data:`MIN_VISIBLE_PX` pixels in view."""
    out: list[SyntheticScene] = []
    while len(out) < n:
        rng = np.random.default_rng(1000 + seed)
        kinds = tuple(str(k) for k in rng.choice(("box", "can", "bottle"), rng.integers(5, 9)))
        sc = clutter_scene(kinds, seed=seed)
        seed += 1
        seen = [(sc.truth == i).sum() for i in range(len(kinds))]
        if len(sc.contacts) >= 3 and min(seen) >= MIN_VISIBLE_PX:
            out.append(sc)
    return out


def benchmark_scenes(n_clutter: int = 30) -> list[tuple[str, SyntheticScene]]:
    """``(group, scene)``: 12 side-by-side pairs, 8 one-behind-the-other, ``n_clutter`` clutter
    scenes of 5-8 objects (the first seeds with >= 3 contacts and every object in view)."""
    out = [("side_by_side", clutter_scene(k, s, "side_by_side")) for k in PAIRS for s in range(4)]
    out += [("front_back", clutter_scene(k, s, "front_back")) for k in BEHIND for s in range(4)]
    return out + [("clutter", sc) for sc in _clutter_draw(n_clutter)]


def held_out_scenes(n: int = 180) -> list[tuple[str, SyntheticScene]]:
    """``("clutter_held_out", scene)``: the ``n`` clutter scenes drawn after the first
    :data:`EXAMINED_CLUTTER` (the same draw as :func:`benchmark_scenes`, from the seed after
    :data:`LAST_EXAMINED_SEED`), none of which was looked at while the segmentation's rules
    were made: what to expect on new clutter."""
    return [("clutter_held_out", sc) for sc in _clutter_draw(n, LAST_EXAMINED_SEED + 1)]


def fresh_scenes(n: int, seed: int) -> list[tuple[str, SyntheticScene]]:
    """``("clutter_fresh", scene)``: the first ``n`` clutter scenes of the same draw from
    ``seed`` on. A seed far past the held-out draw (:func:`held_out_scenes` reaches seed 916 for
    180 scenes) gives scenes that no rule and no held-out check has seen: a second sample of new
    clutter, to tell the rate from the luck of one draw.

    Raises:
        ConfigError: ``n`` is negative, or ``seed`` is one of the examined scenes' seeds.
    """
    if n < 0:
        raise ConfigError(f"the number of fresh scenes must be >= 0, got {n}")
    if seed <= LAST_EXAMINED_SEED:
        raise ConfigError(
            f"fresh clutter scenes start after the examined ones (seed > {LAST_EXAMINED_SEED}),"
            f" got seed {seed}"
        )
    return [("clutter_fresh", sc) for sc in _clutter_draw(n, seed)]


def scan_scenes(n: int = 8) -> list[tuple[str, SyntheticScene]]:
    """``("scans_apart", scene)``: the grasp cycle's seeded YCB-scan scenes (2-5 objects standing
    apart), ``n`` per robot, as :class:`SyntheticScene` (truth -1 on table and background, and
    on objects hidden behind others but for fewer than ``HIDDEN_PX`` pixels)."""
    from symjax.datasets.scan_scenes import scan_scene

    out = []
    for robot in ("kth", "uji"):
        for s in range(n):
            sc = scan_scene(robot, n_objects=2 + s % 4, seed=s)
            truth = np.where(sc.labels >= 1, sc.labels - 1, -1).astype(np.int32)
            seen = np.bincount(truth[truth >= 0], minlength=len(sc.names))
            keep = np.flatnonzero(seen >= HIDDEN_PX)
            lut = np.full(len(sc.names) + 1, -1, np.int32)
            lut[keep] = np.arange(len(keep))
            truth = lut[truth]  # -1 indexes the last entry
            out.append(("scans_apart", SyntheticScene(sc.depth, sc.camera, truth, (), 0.0)))
    return out


def match_ious(truth: np.ndarray, result) -> tuple[np.ndarray, np.ndarray]:
    """Best one-to-one IoU of each true object with a found one (0 unmatched) and the match."""
    from scipy.optimize import linear_sum_assignment

    n = int(truth.max()) + 1
    iou = np.zeros((n, max(len(result), 1)))
    for i in range(n):
        t = truth == i
        for j, o in enumerate(result.objects):
            m = np.asarray(o.mask)
            iou[i, j] = (t & m).sum() / max((t | m).sum(), 1)
    r, c = linear_sum_assignment(-iou)
    out, match = np.zeros(n), np.full(n, -1)
    out[r], match[r] = iou[r, c], c
    return out, match


def score_scenes(scenes, config: SegmentationConfig, colour: bool = False) -> dict[str, dict]:
    """Per group: scenes, share with the object count right, share with every IoU >= 0.85, and
    the share of objects with IoU >= 0.85; ``colour`` passes each scene's colour image."""
    from symjax.perception.segmentation import segment

    acc: dict[str, list] = {}
    for group, sc in scenes:
        res = segment(sc.depth, sc.camera, config, rgb=sc.rgb if colour else None)
        ious, _ = match_ious(sc.truth, res)
        a = acc.setdefault(group, [0, 0, 0, []])
        right = len(res) == len(ious)
        a[0] += 1
        a[1] += right
        a[2] += bool(right and ious.min() >= 0.85)
        a[3] += list(ious)
    return {
        g: {
            "scenes": a[0],
            "count_right": round(a[1] / a[0], 3),
            "all_iou_085": round(a[2] / a[0], 3),
            "objects_iou_085": round(float(np.mean(np.asarray(a[3]) >= 0.85)), 3),
        }
        for g, a in acc.items()
    }


#: A box whose footprint's half sides differ by at most this (metres) is square: mirrored across
#: a vertical plane at 45 deg to its faces it lands within this of itself (its 90-deg turn), the
#: search's depth tolerance, so those two planes are true mirror planes too.
SQUARE_TOLERANCE = 0.002


def plane_error(scene: SyntheticScene, k: int, normal, offset) -> tuple[float, float]:
    """``(deg, m)`` of a plane against object ``k``'s true mirror planes: a box's two planes
    through its centre along its sides (and the two at 45 deg to them when its footprint is
    square within :data:`SQUARE_TOLERANCE`), any vertical plane through a can's or bottle's
    axis."""
    i = scene.owner.index(k)
    p = scene.primitives[i]
    n = np.asarray(normal, np.float64)
    dist = abs(float(n @ np.asarray(p.pos)) - float(offset))
    if p.kind != "box":
        return math.degrees(math.asin(min(1.0, abs(n[2])))), dist
    w, z = p.quat[0], p.quat[3]
    yaw = 2 * math.atan2(z, w)
    square = abs(float(p.size[0]) - float(p.size[1])) <= SQUARE_TOLERANCE
    turns = (0.0, 0.5, 0.25, 0.75) if square else (0.0, 0.5)
    axes = tuple((math.cos(yaw + t * math.pi), math.sin(yaw + t * math.pi), 0.0) for t in turns)
    deg = min(math.degrees(math.acos(min(1.0, abs(float(n @ a))))) for a in axes)
    return deg, dist


def mcnemar_p(b: int, c: int) -> float:
    """Exact two-sided McNemar p-value of ``b`` and ``c`` discordant pairs (the binomial test of
    ``b`` of ``b + c`` at 1/2), to three significant digits: on a large sample it can lie far
    below 0.001, which three decimals would print as 0. 1.0 without discordant pairs."""
    from scipy.stats import binomtest

    return float(f"{binomtest(b, b + c, 0.5).pvalue:.3g}") if b + c else 1.0


#: Inner edges of the buckets of the share of an object's silhouette that its neighbours hide.
HIDDEN_EDGES = (0.02, 0.15, 0.35)


def truth_observation(
    scene: SyntheticScene, k: int, table, silhouette, occluders: str, config: SegmentationConfig
):
    """Object ``k`` of a clutter scene as a perfect segmentation would give it: its true visible
    pixels as mask (with those without depth) and points, and as occluders (Eq. 3) either the
    neighbours that the segmentation's rule says are in front (``"rule"``,
    :func:`symjax.perception.object_info.occluder_depth`) or exactly the neighbours' pixels that
    cover the object's ``silhouette`` (``"hidden"``: (H, W) bool, the object rendered alone).
    ``config`` gives the outlier removal and the mask's fill, as in the segmentation.

    Separated objects measured against these two tell what the segmentation's masks and its
    occluder rule cost the symmetry search, and what is left with perfect perception.
    """
    import dataclasses

    from scipy.ndimage import find_objects

    from symjax.geometry import backproject
    from symjax.observation import Observation, fill_mask
    from symjax.perception.clusters import grid_outliers
    from symjax.perception.depth_pixels import pixel_rays_of
    from symjax.perception.object_info import _relations, occluder_depth

    depth = np.asarray(scene.depth, np.float32)
    labels = np.asarray(scene.truth, np.int32)
    rays = pixel_rays_of(scene.camera)
    # As the segmentation does: the sensor's stray points off (statistical outliers), and the
    # object's pixels without depth in its mask (the segmentation claims them).
    stray = grid_outliers(depth, rays, np.where(depth > 0, labels, -1), config)
    seen = (labels == k) & (depth > 0) & ~stray
    mask = fill_mask((labels == k) & ~stray, config.mask_fill) | seen
    cam = scene.camera
    points = backproject(depth, cam.K, cam.T_world_cam, seen)
    obs = Observation.create(points, cam, table, mask, depth * seen)
    if occluders == "hidden":
        occ = np.where(silhouette & (labels >= 0) & ~mask, depth, np.float32(0.0))
    else:
        boxes = find_objects(labels + 1)
        _, front = _relations(labels, depth, k, boxes[k], config)
        occ = occluder_depth(labels, depth, front, boxes)
    return dataclasses.replace(obs, depth=np.where(mask, depth, occ).astype(np.float32))


def symmetry_rows(
    scenes, config: SegmentationConfig, truth: bool = False, symmetry=None, colour: bool = False
) -> dict:
    """Share of separated objects (IoU >= 0.85) whose symmetry plane is within 10 deg and 10 mm
    of the truth, and the same for each of them segmented from a frame where it stands alone.

    The two shares are paired (the same objects): also the objects right only separated and
    only alone, and the exact two-sided McNemar p-value of that difference (the binomial test
    of the discordant pairs), which says whether the two rates differ beyond chance. The
    objects are also counted by the share of their silhouette that the neighbours hide
    (``by_hidden``: objects, right separated, right alone).

    With ``truth``, the same objects also as a perfect segmentation would give them
    (:func:`truth_observation`): the true masks with the segmentation's occluder rule, and the
    true masks with the true occluders (perfect perception), each against the objects alone,
    and the separated objects against perfect perception (``..._vs_perfect``). ``symmetry`` is the
    search's :class:`symjax.symmetry.SymmetryConfig` (None = the default). The separated objects
    of a frame are searched together (:func:`symjax.symmetry.search_scene`: with
    ``neighbour_volumes``, against their neighbours' completed volumes, and so are the true
    masks with the rule's occluders). With ``colour`` each frame, the separated and the alone,
    is segmented with its colour image too (the cut pixels' colour and the colour creases).
    """
    from symjax.perception.segmentation import segment
    from symjax.symmetry import SymmetryConfig, search, search_batch, search_scene
    from symjax.symmetry.scene import back_depth, behind_neighbours

    symmetry = symmetry if symmetry is not None else SymmetryConfig()
    kinds = ("separated", "truth_masks", "truth_masks_and_occluders")
    kinds = kinds if truth else kinds[:1]
    ok = {name: [] for name in (*kinds, "alone")}
    bounds = (0.0, *HIDDEN_EDGES, 1.0)
    buckets = {f"{a:.2f}-{b:.2f}": [0, 0, 0] for a, b in zip(bounds[:-1], bounds[1:], strict=True)}
    for _, sc in scenes:
        res = segment(sc.depth, sc.camera, config, rgb=sc.rgb if colour else None)
        ious, match = match_ious(sc.truth, res)
        if res.objects and (ious >= 0.85).any():
            # the frame's objects searched together, as the product does (search_scene)
            first = search_batch(res.objects, symmetry)
            together = search_scene(res.objects, symmetry, first=first)
            back = back_depth(res.objects, first) if symmetry.neighbour_volumes else None
        for k in np.flatnonzero(ious >= 0.85):
            alone = clutter_scene_alone(sc, int(k))
            solo = segment(alone.depth, alone.camera, config, rgb=alone.rgb if colour else None)
            if len(solo) != 1:
                continue
            obs = {"alone": solo.objects[0]}
            found = {"separated": together[int(match[k])]}
            silhouette = alone.truth >= 0
            if truth:
                # the true masks with the rule's occluders, as deep as the segmentation's
                # objects' completions make them; the true occluders exactly as rendered
                o = truth_observation(sc, int(k), res.table, silhouette, "rule", config)
                obs["truth_masks"] = o if back is None else behind_neighbours(o, back)
                obs["truth_masks_and_occluders"] = truth_observation(
                    sc, int(k), res.table, silhouette, "hidden", config
                )
            found |= {name: search(o, symmetry) for name, o in obs.items()}
            for name, out in found.items():
                deg, dist = plane_error(sc, int(k), out.normal, out.offset)
                ok[name].append(deg <= 10.0 and dist <= 0.010)
            hidden = 1.0 - (sc.truth == k).sum() / max(int(silhouette.sum()), 1)
            b = list(buckets.values())[int(np.searchsorted(HIDDEN_EDGES, hidden, "right"))]
            b[0] += 1
            b[1] += ok["separated"][-1]
            b[2] += ok["alone"][-1]
    n = len(ok["alone"])
    alone = np.asarray(ok["alone"], bool)
    row = {"objects": n}
    for name in kinds:
        v = np.asarray(ok[name], bool)
        tag = "" if name == "separated" else f"_{name}"
        b, c = int((v & ~alone).sum()), int((alone & ~v).sum())
        row[f"plane_ok_{name}"] = round(float(v.mean()) if n else 0.0, 3)
        row[f"right_only_{name}"], row[f"right_only_alone{tag}"] = b, c
        row[f"mcnemar_p{tag}"] = mcnemar_p(b, c)
        if name == "separated":
            row["plane_ok_alone"] = round(float(alone.mean()) if n else 0.0, 3)
    if truth:
        # The segmentation against perfect perception, paired: what the masks and the occluder
        # rule cost, apart from what the neighbours' occlusion costs any segmentation.
        sep, perfect = (np.asarray(ok[k], bool) for k in ("separated", kinds[-1]))
        b, c = int((sep & ~perfect).sum()), int((perfect & ~sep).sum())
        row["right_only_separated_vs_perfect"], row["right_only_perfect"] = b, c
        row["mcnemar_p_separated_vs_perfect"] = mcnemar_p(b, c)
    row["by_hidden"] = buckets
    row["criterion"] = "within 10 deg and 10 mm of a true mirror plane"
    return row


def clutter_scene_alone(scene: SyntheticScene, k: int) -> SyntheticScene:
    """Object ``k`` of a benchmark scene rendered alone (same layout, camera, noise stream)."""
    return clutter_scene(**scene.recipe, only=k)
