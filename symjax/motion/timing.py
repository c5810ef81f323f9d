"""Time parameterisation of joint paths within the arm's speed and acceleration limits.

Paths from RRT-Connect have corners: each edge gets its own trapezoidal velocity profile and the
arm stops at every waypoint, so no joint ever exceeds its limits. Straight-line TCP motions are
dense and smooth: one trapezoidal profile runs along the whole polyline.
"""

from __future__ import annotations

import numpy as np

__all__ = ["duration", "time_path", "trapezoid"]


def trapezoid(length: float, vmax: float, amax: float, t: np.ndarray) -> np.ndarray:
    """Position along a rest-to-rest trapezoidal profile over ``length`` at times ``t``.

    Args:
        length: Distance to travel (>= 0).
        vmax, amax: Speed and acceleration limits (> 0).
        t: Times, seconds, from the start.

    Returns:
        Positions (same shape as ``t``), clipped to ``[0, length]`` after the end.
    """
    if length <= 0:
        return np.zeros_like(t)
    ta = vmax / amax
    if length < vmax * ta:  # triangular: never reaches vmax
        ta = np.sqrt(length / amax)
        vmax = amax * ta
    total = 2 * ta + (length - vmax * ta) / vmax
    t = np.clip(t, 0.0, total)
    acc = 0.5 * amax * t**2
    cruise = 0.5 * vmax * ta + vmax * (t - ta)
    dec = length - 0.5 * amax * (total - t) ** 2
    return np.where(t < ta, acc, np.where(t <= total - ta, cruise, dec))


def duration(length: float, vmax: float, amax: float) -> float:
    """Duration of :func:`trapezoid`, seconds."""
    if length <= 0:
        return 0.0
    ta = vmax / amax
    if length < vmax * ta:
        return 2 * float(np.sqrt(length / amax))
    return float(2 * ta + (length - vmax * ta) / vmax)


def _grid(T: float, dt: float) -> np.ndarray:
    """0, dt, 2 dt, ... and T, with no step shorter than dt / 2 (finite differences stay sane)."""
    k = max(1, int(round(T / dt)))
    return np.linspace(0.0, T, k + 1)


def time_path(
    path: np.ndarray, vmax: np.ndarray, amax: np.ndarray, dt: float, stop_at_waypoints: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Samples a joint path in time.

    Args:
        path: Waypoints, shape (K, n), radians.
        vmax, amax: Joint speed and acceleration limits, shape (n,).
        dt: Sample spacing, seconds.
        stop_at_waypoints: True: rest at every waypoint (paths with corners); False: one
            profile along the polyline (dense, smooth paths).

    Returns:
        ``(t (T,), q (T, n))``; the first sample is ``path[0]`` at t = 0, the last
        ``path[-1]``.
    """
    path = np.asarray(path, np.float64)
    if len(path) < 2:
        return np.zeros(1), path[:1].copy()
    delta = np.diff(path, axis=0)
    if stop_at_waypoints:
        # Per edge, the scalar s in [0, 1] moves at most vmax_j / |delta_j| (and accelerates
        # at most amax_j / |delta_j|), so every joint keeps its own limits.
        ts, qs, t0 = [np.zeros(1)], [path[:1]], 0.0
        for a, d in zip(path[:-1], delta, strict=True):
            mag = np.abs(d)
            if mag.max() < 1e-12:
                continue
            with np.errstate(divide="ignore"):
                vs = float(np.min(np.where(mag > 0, vmax / mag, np.inf)))
                acs = float(np.min(np.where(mag > 0, amax / mag, np.inf)))
            T = duration(1.0, vs, acs)
            tt = _grid(T, dt)[1:]
            s = trapezoid(1.0, vs, acs, tt)
            ts.append(t0 + tt)
            qs.append(a + s[:, None] * d)
            t0 += T
        return np.concatenate(ts), np.concatenate(qs)
    # Arc length in "seconds at full speed": an edge takes max_j |delta_j| / vmax_j.
    edge = np.max(np.abs(delta) / vmax, axis=1)
    keep = np.concatenate([[True], edge > 1e-12])
    path, delta, edge = path[keep], delta[keep[1:]], edge[keep[1:]]
    L = float(edge.sum())
    if L < 1e-12:
        return np.zeros(1), path[:1].copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.where(edge[:, None] > 0, np.abs(delta) / edge[:, None], 0.0)
        au = float(np.min(np.where(rate > 0, amax / rate, np.inf)))
    T = duration(L, 1.0, au)
    tt = _grid(T, dt)
    u = trapezoid(L, 1.0, au, tt)
    cum = np.concatenate([[0.0], np.cumsum(edge)])
    q = np.stack([np.interp(u, cum, path[:, j]) for j in range(path.shape[1])], axis=1)
    q[-1] = path[-1]
    return tt, q
