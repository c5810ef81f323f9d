"""A simulated KTH-like stereo head: camera placement and a documented stereo noise model.

The KTH active head of the paper (Section V-A.1) sees a table-top object from about 0.6-1 m,
looking down at 30-50 deg. Depth from stereo comes from a disparity ``d = f * B / z`` (focal length
``f`` in pixels, baseline ``B`` in metres, depth ``z``). The noise model works on that disparity:

1. **Disparity noise**: ``d' = d + e``, ``e ~ N(0, disparity_sigma^2)`` truncated at
   ``disparity_clip`` sigmas (stereo matchers reject outlying matches by a left-right check).
2. **Sub-pixel quantisation**: ``d'`` is rounded to multiples of ``subpixel`` (1/16 px, as the
   fixed-point disparities of block matchers), then ``z' = f * B / d'``. Depth error therefore
   grows with the square of depth: ``|z' - z| <= z^2 * delta / (f * B - z * delta)`` with
   ``delta = disparity_clip * disparity_sigma + subpixel / 2`` (:meth:`StereoNoise.depth_bound`).
3. **Grazing surfaces**: pixels whose surface normal makes more than ``grazing_deg`` with the
   viewing ray have no depth (no texture match on strongly foreshortened surfaces).
4. **Borders**: each pixel of the one-pixel bands on both sides of the object outline loses its
   depth with probability ``border_drop`` (occlusion-boundary matching failures).
5. **Flying pixels**: a fraction ``flying_fraction`` of the object's outline pixels (at least
   ``flying_min`` where the outline allows) takes a depth interpolated between the object and the
   background behind it (at least ``flying_min_gap`` deeper), ``z_obj + t * (z_bg - z_obj)``,
   ``t ~ U(flying_t)``: the mixed pixels of window-based matching. They are flagged, since they
   are off the surface by construction.

Everything is drawn from a ``numpy.random.Generator`` the caller seeds, so a view is a pure
function of its seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from symjax.array_types import ArrayLike
from symjax.camera import Camera
from symjax.errors import ConfigError
from symjax.geometry import pixel_rays
from symjax.validation import check_fields

__all__ = ["StereoHead", "StereoNoise", "simulate_stereo", "outline_bands"]


@dataclass(frozen=True)
class StereoHead:
    """The stereo head's cameras and where it stands relative to the object.

    Defaults: 640x480 images, focal length 575 px, the KTH head's 91.5 mm baseline (see
    ``calib.txt`` of the KTH demo view), camera 0.6-1.0 m from the object centre, elevation 30-50
    deg. Within the distance range, the head stands closer to small objects and further from
    large ones (a distance is drawn so that the object covers about ``target_pixels`` pixels),
    which keeps the clouds within the paper's 2k-40k points.

    Attributes:
        width: Image width, pixels.
        height: Image height, pixels.
        fx: Horizontal focal length, pixels.
        fy: Vertical focal length, pixels.
        cx: Principal point column, pixels (None = image centre).
        cy: Principal point row, pixels (None = image centre).
        baseline: Stereo baseline, metres.
        distance_range: Camera-to-object-centre distance bounds, metres.
        elevation_range_deg: Bounds of the viewing elevation above the table, degrees.
        target_pixels: Bounds of the object's projected area the distance aims for, pixels.
    """

    width: int = 640
    height: int = 480
    fx: float = 575.0
    fy: float = 575.0
    cx: float | None = None
    cy: float | None = None
    baseline: float = 0.0915
    distance_range: tuple[float, float] = (0.6, 1.0)
    elevation_range_deg: tuple[float, float] = (30.0, 50.0)
    target_pixels: tuple[float, float] = (6000.0, 30000.0)

    def __post_init__(self) -> None:
        check_fields(self)
        if self.width <= 0 or self.height <= 0 or self.fx <= 0 or self.fy <= 0:
            raise ConfigError("stereo head image size and focal lengths must be positive")
        if self.baseline <= 0:
            raise ConfigError(f"stereo baseline must be > 0 m, got {self.baseline}")
        lo, hi = self.distance_range
        if not 0 < lo <= hi:
            raise ConfigError(f"distance_range must satisfy 0 < lo <= hi, got {(lo, hi)}")
        elo, ehi = self.elevation_range_deg
        if not 0 < elo <= ehi < 90:
            raise ConfigError(
                f"elevation_range_deg must satisfy 0 < lo <= hi < 90, got {(elo, ehi)}"
            )

    @property
    def K(self) -> np.ndarray:
        """Intrinsics (3, 3), pixels."""
        cx = (self.width - 1) / 2 if self.cx is None else self.cx
        cy = (self.height - 1) / 2 if self.cy is None else self.cy
        return np.array([[self.fx, 0.0, cx], [0.0, self.fy, cy], [0.0, 0.0, 1.0]])

    def place(
        self, rng: np.random.Generator, target: ArrayLike, extents: ArrayLike, azimuth: float = 0.0
    ) -> Camera:
        """Draws the camera for one view.

        The camera looks at ``target`` from the horizontal direction ``azimuth`` (radians; 0 = the
        camera stands on the -y side looking towards +y, so the image x axis is world +x).

        Args:
            rng: Random generator (drawn: distance, elevation).
            target: Point the optical axis goes through (3,), metres (the object centre).
            extents: Object extents (3,) (length, width, height), metres, to pick the distance.
            azimuth: Horizontal viewing direction, radians.

        Returns:
            The left camera of the head.
        """
        ext = np.asarray(extents, np.float64)
        elev = math.radians(rng.uniform(*self.elevation_range_deg))
        # Apparent area of a box of these extents seen from this elevation, a rough but monotonic
        # proxy for the projected area; it scales with (f / distance)^2.
        horiz = 0.5 * (ext[0] + ext[1])
        area = horiz * (ext[2] * math.cos(elev) + horiz * math.sin(elev))
        f = math.sqrt(self.fx * self.fy)
        d_far = f * math.sqrt(area / self.target_pixels[0])
        d_near = f * math.sqrt(area / self.target_pixels[1])
        lo, hi = self.distance_range
        d_near, d_far = float(np.clip(d_near, lo, hi)), float(np.clip(d_far, lo, hi))
        dist = rng.uniform(d_near, d_far) if d_far > d_near else d_near
        t = np.asarray(target, np.float64)
        back = np.array([math.sin(azimuth), -math.cos(azimuth), 0.0])
        pos = t + dist * (math.cos(elev) * back + np.array([0.0, 0.0, math.sin(elev)]))
        return Camera.look_at(pos, t, self.K, self.width, self.height)


@dataclass(frozen=True)
class StereoNoise:
    """The stereo noise model (see the module docstring for each step).

    Attributes:
        disparity_sigma: Standard deviation of the disparity error, pixels.
        disparity_clip: Truncation of the disparity error, in sigmas.
        subpixel: Disparity quantisation step, pixels (0 = none).
        grazing_deg: Largest angle between surface normal and viewing ray with depth, degrees.
        border_drop: Probability that an outline-band pixel loses its depth.
        flying_fraction: Flying pixels as a fraction of the object's outline pixels.
        flying_min: Fewest flying pixels per view (when the outline has that many candidates).
        flying_t: Range of the interpolation weight towards the background.
        flying_min_gap: Outline pixels become flying pixels only where the background is at least
            this much deeper than the object, metres (no mixing where the object meets the table).
        enabled: False renders exact depth (no step applies).
    """

    disparity_sigma: float = 0.15
    disparity_clip: float = 4.0
    subpixel: float = 1.0 / 16.0
    grazing_deg: float = 78.0
    border_drop: float = 0.5
    flying_fraction: float = 0.02
    flying_min: int = 3
    flying_t: tuple[float, float] = (0.2, 0.8)
    flying_min_gap: float = 0.01
    enabled: bool = True

    def __post_init__(self) -> None:
        check_fields(self)
        if self.disparity_sigma < 0 or self.disparity_clip < 0 or self.subpixel < 0:
            raise ConfigError("disparity_sigma, disparity_clip and subpixel must be >= 0")
        if not 0 < self.grazing_deg <= 90:
            raise ConfigError(f"grazing_deg must be in (0, 90], got {self.grazing_deg}")
        if not (0 <= self.border_drop <= 1 and 0 <= self.flying_fraction <= 1):
            raise ConfigError("border_drop and flying_fraction must be probabilities in [0, 1]")
        if not 0 <= self.flying_t[0] <= self.flying_t[1] <= 1:
            raise ConfigError(f"flying_t must be a range within [0, 1], got {self.flying_t}")

    @property
    def disparity_bound(self) -> float:
        """Largest disparity error, pixels (truncated noise plus half a quantisation step)."""
        if not self.enabled:
            return 0.0
        return self.disparity_clip * self.disparity_sigma + self.subpixel / 2

    def depth_bound(self, z: ArrayLike, focal: float, baseline: float) -> np.ndarray:
        """Largest depth error of a non-flying pixel at true depth ``z`` (metres).

        Args:
            z: True depth(s), metres.
            focal: Focal length, pixels.
            baseline: Baseline, metres.

        Returns:
            Bound(s), metres (``z^2 delta / (f B - z delta)``).
        """
        z = np.asarray(z, np.float64)
        delta = self.disparity_bound
        fb = focal * baseline
        return z * z * delta / np.maximum(fb - z * delta, 1e-12)


def outline_bands(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The one-pixel bands on both sides of a mask's outline (4-connectivity).

    Returns:
        ``(inner, outer)``: bool (H, W) mask pixels with a 4-neighbour outside, and non-mask
        pixels with a 4-neighbour inside.
    """
    m = np.asarray(mask, bool)
    p = np.pad(m, 1, mode="edge")
    nb_out = ~p[:-2, 1:-1] | ~p[2:, 1:-1] | ~p[1:-1, :-2] | ~p[1:-1, 2:]
    nb_in = p[:-2, 1:-1] | p[2:, 1:-1] | p[1:-1, :-2] | p[1:-1, 2:]
    return m & nb_out, ~m & nb_in


def simulate_stereo(
    depth: ArrayLike,
    object_mask: ArrayLike,
    normals: ArrayLike,
    camera: Camera,
    noise: StereoNoise,
    baseline: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Applies the stereo noise model to an exact depth image.

    Args:
        depth: Exact depth (H, W) along the optical axis, metres, 0 = no surface.
        object_mask: The object's pixels (H, W), bool.
        normals: Unit surface normals (H, W, 3), world frame (any value where depth is 0).
        camera: The camera that rendered ``depth``.
        noise: Noise model.
        baseline: Stereo baseline, metres.
        rng: Random generator.

    Returns:
        ``(noisy_depth, flying)``: float32 (H, W) metres (0 = no depth) and the bool (H, W) mask of
        flying pixels.
    """
    z = np.asarray(depth, np.float64)
    obj = np.asarray(object_mask, bool)
    flying = np.zeros(z.shape, bool)
    if not noise.enabled:
        return z.astype(np.float32), flying
    h, w = z.shape
    K = np.asarray(camera.K, np.float64)
    R = np.asarray(camera.T_world_cam, np.float64)[:3, :3]
    f = math.sqrt(K[0, 0] * K[1, 1])
    fb = f * baseline
    has = z > 0

    # 3. Grazing angles: angle between the normal and the viewing ray.
    rays = pixel_rays(K, h, w) @ R.T
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    cos = np.abs(np.sum(rays * np.asarray(normals, np.float64), axis=-1))
    keep = has & (cos >= math.cos(math.radians(noise.grazing_deg)))

    # 1-2. Disparity noise and quantisation (all pixels draw, so the stream does not depend on
    # which pixels are kept).
    e = rng.standard_normal(z.shape) * noise.disparity_sigma
    lim = noise.disparity_clip * noise.disparity_sigma
    e = np.clip(e, -lim, lim)
    disp = np.where(has, fb / np.where(has, z, 1.0), 0.0) + e
    if noise.subpixel > 0:
        disp = np.round(disp / noise.subpixel) * noise.subpixel
    keep &= disp > 0
    out = np.where(keep, fb / np.where(keep, disp, 1.0), 0.0)

    # 4. Border bands.
    inner, outer = outline_bands(obj)
    band = inner | outer
    drop = band & (rng.random(z.shape) < noise.border_drop)

    # 5. Flying pixels on the object's outline, between object and the background behind it.
    import cv2

    # Deepest non-object neighbour (8-connectivity): the background a mixed pixel blends into.
    bg = cv2.dilate(
        np.where(obj, 0.0, z).astype(np.float32), np.ones((3, 3), np.uint8), borderValue=0
    ).astype(np.float64)
    cand = np.flatnonzero((inner & has & (bg > z + noise.flying_min_gap)).ravel())
    n_fly = min(len(cand), max(noise.flying_min, int(round(noise.flying_fraction * inner.sum()))))
    if n_fly > 0:
        pick = rng.choice(cand, size=n_fly, replace=False)
        t = rng.uniform(*noise.flying_t, size=n_fly)
        flat = out.reshape(-1)
        zf, bf = z.reshape(-1)[pick], bg.reshape(-1)[pick]
        flat[pick] = zf + t * (bf - zf)
        fl = flying.reshape(-1)
        fl[pick] = True
        drop.reshape(-1)[pick] = False
    out[drop] = 0.0
    flying &= out > 0
    return out.astype(np.float32), flying
