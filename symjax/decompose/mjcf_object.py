"""A graspable object as MJCF: convex hull meshes on a free body, built with ``mujoco.MjSpec``."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from symjax.array_types import ArrayLike
from symjax.decompose.hulls import Decomposition
from symjax.errors import DegenerateGeometryError, EmptyInputError, InvalidInputError, ShapeError

__all__ = ["mass_properties", "object_spec", "object_xml"]


def mass_properties(
    vertices: ArrayLike, faces: ArrayLike, density: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia of a closed triangle mesh of uniform density.

    Args:
        vertices: Shape (V, 3), metres.
        faces: Shape (F, 3), outward-wound triangles.
        density: kg/m^3.

    Returns:
        ``(mass kg, com (3,) m, inertia (3, 3) kg m^2 about the com, in the mesh frame)``.
    """
    import trimesh

    mesh = trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces), process=False)
    if mesh.volume < 0:  # inward-wound mesh: the same solid, flip it
        mesh.invert()
    if not mesh.volume > 1e-12:
        raise DegenerateGeometryError(f"mesh encloses no volume ({mesh.volume:.3g} m^3)")
    mesh.density = float(density)
    return float(mesh.mass), np.asarray(mesh.center_mass), np.asarray(mesh.moment_inertia)


def _hull_list(hulls) -> list[tuple[np.ndarray, np.ndarray]]:
    if isinstance(hulls, Decomposition):
        hulls = hulls.hulls
    out = [(np.asarray(v, float), np.asarray(f, int)) for v, f in hulls]
    if not out:
        raise EmptyInputError("an object needs at least one hull")
    for v, f in out:
        if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
            raise ShapeError(f"hull arrays must be (V, 3) and (F, 3), got {v.shape}, {f.shape}")
    return out


def object_spec(
    hulls: Decomposition | list[tuple[Any, Any]],
    *,
    name: str = "object",
    mesh: tuple[Any, Any] | None = None,
    mass: float | None = None,
    density: float = 400.0,
    pos: ArrayLike = (0.0, 0.0, 0.0),
    quat: ArrayLike = (1.0, 0.0, 0.0, 0.0),
    friction: tuple[float, float, float] = (1.0, 0.005, 0.0001),
    spec: mujoco.MjSpec | None = None,
) -> mujoco.MjSpec:
    """Adds an object made of convex hulls on a free joint to a spec (or a new one).

    Mass properties come from ``mesh`` (the full, closed mesh: completed Poisson or ground
    truth) when given, else from the hulls summed (overlaps count twice). The body's inertial
    is explicit, so MuJoCo does not re-derive it from the hull geoms.

    Args:
        hulls: A :class:`Decomposition` or a list of ``(vertices, faces)`` hulls, metres.
        name: Body name; hull meshes and geoms are ``{name}_hull{i}``, the joint ``{name}``.
        mesh: Optional ``(vertices, faces)`` of the whole object for the mass properties.
        mass: Total mass in kg; if given, the density is scaled to match it.
        density: kg/m^3 (default 400, a light household object) when ``mass`` is None.
        pos: Initial body position (3,), metres; quat: (w, x, y, z).
        friction: Geom friction (sliding, torsional, rolling).
        spec: Spec to add to; a new empty one by default.

    Returns:
        The spec (compile with ``spec.compile()``).
    """
    hl = _hull_list(hulls)
    if mass is not None and not mass > 0:
        raise InvalidInputError(f"mass must be positive, got {mass}")
    if not density > 0:
        raise InvalidInputError(f"density must be positive, got {density}")
    if mesh is not None:
        m, com, inertia = mass_properties(mesh[0], mesh[1], density)
    else:
        parts = [mass_properties(v, f, density) for v, f in hl]
        m = sum(p[0] for p in parts)
        com = sum(p[0] * p[1] for p in parts) / m
        inertia = np.zeros((3, 3))
        for mi, ci, Ii in parts:  # parallel-axis theorem to the common centre of mass
            r = ci - com
            inertia += Ii + mi * (np.dot(r, r) * np.eye(3) - np.outer(r, r))
    if mass is not None:
        inertia = inertia * (mass / m)
        m = float(mass)
    spec = spec if spec is not None else mujoco.MjSpec()
    body = spec.worldbody.add_body(
        name=name, pos=list(map(float, pos)), quat=list(map(float, quat))
    )
    body.add_freejoint(name=name)
    body.explicitinertial = True
    body.mass = m
    body.ipos = com
    body.fullinertia = [inertia[0, 0], inertia[1, 1], inertia[2, 2],
                        inertia[0, 1], inertia[0, 2], inertia[1, 2]]  # fmt: skip
    for i, (v, f) in enumerate(hl):
        spec.add_mesh(name=f"{name}_hull{i}", uservert=v.ravel(), userface=f.ravel())
        body.add_geom(
            name=f"{name}_hull{i}",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=f"{name}_hull{i}",
            condim=3,
            friction=list(friction),
            density=0.0,
            rgba=[0.3, 0.6, 0.9, 1.0],
        )
    return spec


def object_xml(hulls: Decomposition | list[tuple[Any, Any]], **kwargs: Any) -> str:
    """MJCF text of :func:`object_spec` in an otherwise empty model."""
    spec = object_spec(hulls, **kwargs)
    spec.compile()
    return spec.to_xml()
