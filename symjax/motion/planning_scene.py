"""The planning scene: a robot, its table and the objects on it as convex hulls.

Objects are mocap bodies, so moving one only changes ``MjData.mocap_pos``/``mocap_quat``. An
attached object becomes part of the hand: its hulls are copied onto a body under the hand base,
whose pose relative to the hand is a model field set at attach time. The compiled model is cached
per (object set, attached object); adding or removing an object, or attaching a different one,
compiles a new model from the robot's :class:`mujoco.MjSpec` (tens of milliseconds).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import mujoco
import numpy as np

from symjax.array_types import ArrayLike
from symjax.errors import InvalidInputError, ShapeError, unknown_name
from symjax.geometry import as_pose
from symjax.motion.scene_model import (
    CARRIED,
    SceneModel,
    add_hulls,
    classify,
    has_geom,
    hull_list,
    mat_to_quat,
)

__all__ = ["PlanningScene"]

_ENV_FIXED = ("table", "floor", "pedestal")


@dataclasses.dataclass
class _Object:
    hulls: list[tuple[np.ndarray, np.ndarray]]
    pos: np.ndarray
    quat: np.ndarray


class _Margin:
    """A contact distance of the scene, metres: setting another value recompiles its models
    (the geoms' margins are model fields)."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.attr = "_" + name

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        return self if obj is None else getattr(obj, self.attr)

    def __set__(self, obj: Any, value: float) -> None:
        if float(value) != getattr(obj, self.attr):
            setattr(obj, self.attr, float(value))
            obj._version += 1


class PlanningScene:
    """A robot, the table and the objects on it, for IK, collision checks and motion planning.

    Args:
        robot: ``"kth"``, ``"uji"`` or a :class:`symjax.robots.Robot`.
        objects: Optional ``{name: hulls}`` to add (see :meth:`add_object`), world frame.
        target: Name of the object to grasp, or None.
        margin: A robot geom closer than this to anything counts as a collision, metres.
        carried_margin: The same for the attached object: larger, because where it sits in the
            hand is only known to the slip of the grasp, metres.
        obstacle_margin: The same for the robot against an object other than the target (at
            least ``margin``): larger when the objects are planned on estimated shapes (a
            completion, observed points), which can be off by millimetres, metres.

    Raises:
        UnknownNameError: An unknown robot.
    """

    #: Contact distance that counts as a collision, metres.
    margin = _Margin()
    #: The same for the attached object (and the hand carrying it, against the other objects).
    carried_margin = _Margin()
    #: The same against an object other than the target.
    obstacle_margin = _Margin()

    def __init__(
        self,
        robot: Any,
        objects: dict[str, Any] | None = None,
        target: str | None = None,
        margin: float = 0.005,
        carried_margin: float = 0.02,
        obstacle_margin: float = 0.01,
    ):
        from symjax import robots
        from symjax.hands import load as load_hand

        self.robot = robot if isinstance(robot, robots.Robot) else robots.load(robot)
        self.hand = load_hand(self.robot.hand)
        self._margin = float(margin)
        self._carried_margin = float(carried_margin)
        self._obstacle_margin = float(obstacle_margin)
        self._others: tuple[Any, str | None, np.ndarray] = (None, None, np.zeros(0, bool))
        #: When set, the margin of robot-table contacts instead of :attr:`margin`, metres (the
        #: final approach to a grasp keeps the fingertips just above the table).
        self.table_margin: float | None = None
        self._objects: dict[str, _Object] = {}
        self._version = 0
        self._attached: str | None = None
        self._attach_pose = (np.zeros(3), np.array([1.0, 0, 0, 0]))
        self._cache: dict[tuple[int, str | None], SceneModel] = {}
        for name, hulls in (objects or {}).items():
            self.add_object(name, hulls)
        self._target: str | None = None
        self.target = target

    # --- objects ------------------------------------------------------------------------------
    @property
    def object_names(self) -> tuple[str, ...]:
        return tuple(self._objects)

    @property
    def target(self) -> str | None:
        """The object to grasp: collisions of the hand with it are allowed on the approach."""
        return self._target

    @target.setter
    def target(self, name: str | None) -> None:
        if name is not None and name not in self._objects:
            raise unknown_name("target object", name, self.object_names or ("<none>",))
        self._target = name

    @property
    def attached(self) -> str | None:
        """The object held by the hand, or None."""
        return self._attached

    def add_object(self, name: str, hulls: Any, pose: ArrayLike | None = None) -> None:
        """Adds an object made of convex hulls.

        Args:
            name: A new object name.
            hulls: A :class:`symjax.decompose.Decomposition` or a list of ``(vertices (V, 3),
                faces (F, 3))``, metres, in the object's frame.
            pose: The object frame in the world, a (4, 4) matrix or ``(x, y, z, qw, qx, qy,
                qz)``; default identity (hulls given in the world frame).
        """
        if not isinstance(name, str) or not name or "/" in name:
            raise InvalidInputError(f"object name must be a non-empty string without '/': {name!r}")
        if name in self._objects:
            raise InvalidInputError(f"object {name!r} is already in the scene")
        pos, R = as_pose(np.eye(4) if pose is None else pose)
        self._objects[name] = _Object(hull_list(hulls), pos, mat_to_quat(R))
        self._version += 1

    def remove_object(self, name: str) -> None:
        """Removes an object (and detaches it if held)."""
        self._check(name)
        if self._attached == name:
            self._attached = None
        if self._target == name:
            self._target = None
        del self._objects[name]
        self._version += 1

    def move_object(self, name: str, pose: ArrayLike) -> None:
        """Moves an object rigidly (no recompilation); ``pose`` as in :meth:`add_object`."""
        self._check(name)
        pos, R = as_pose(pose)
        self._objects[name].pos, self._objects[name].quat = pos, mat_to_quat(R)

    def object_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """``(position (3,), rotation (3, 3))`` of an object's frame in the world."""
        self._check(name)
        o = self._objects[name]
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, o.quat)
        return o.pos.copy(), R.reshape(3, 3)

    def attach(self, name: str, q: ArrayLike) -> None:
        """Attaches an object to the hand at its current pose relative to the hand.

        Args:
            name: The object.
            q: Full configuration (``model.nq``) whose hand pose holds the object.
        """
        self._check(name)
        sm = self.scene_model(attached=None)
        d = sm.data
        self._forward(sm, q)
        hb = sm.model.body(self.robot.hand_prefix + self.hand.base_body).id
        Rh, ph = d.xmat[hb].reshape(3, 3), d.xpos[hb]
        po, Ro = self.object_pose(name)
        self._attach_pose = (Rh.T @ (po - ph), mat_to_quat(Rh.T @ Ro))
        self._attached = name

    def detach(self, q: ArrayLike | None = None) -> None:
        """Releases the held object; with ``q`` it stays where the hand put it, else it returns
        to its pose before the attach."""
        if self._attached is None:
            return
        name = self._attached
        if q is not None:
            sm = self.scene_model()
            self._forward(sm, q)
            b = sm.carried_body
            self._objects[name].pos = sm.data.xpos[b].copy()
            self._objects[name].quat = mat_to_quat(sm.data.xmat[b].reshape(3, 3))
        self._attached = None

    def _check(self, name: str) -> None:
        if name not in self._objects:
            raise unknown_name("object", name, self.object_names or ("<none>",))

    # --- models -------------------------------------------------------------------------------
    def scene_model(self, attached: str | None | type[Ellipsis] = ...) -> SceneModel:
        """The compiled variant for the current objects (and the attached one)."""
        att = self._attached if attached is ... else attached
        key = (self._version, att)
        if key not in self._cache:
            self._cache = {k: v for k, v in self._cache.items() if k[0] == self._version}
            self._cache[key] = self._compile(att)
        sm = self._cache[key]
        if att is not None:
            sm.model.body_pos[sm.carried_body] = self._attach_pose[0]
            sm.model.body_quat[sm.carried_body] = self._attach_pose[1]
        return sm

    def _compile(self, attached: str | None) -> SceneModel:
        spec = self.robot.spec()
        prefix = self.robot.hand_prefix
        for g in spec.geoms:
            g.margin = self.margin
        for name, obj in self._objects.items():
            if name == attached:
                continue
            body = spec.worldbody.add_body(name=f"obj/{name}", mocap=True)
            add_hulls(spec, body, f"obj/{name}", obj.hulls, rgba=[0.3, 0.6, 0.9, 1])
            for g in body.geoms:
                g.margin = max(self.margin, self.obstacle_margin)
        if attached is not None:
            hb = spec.body(prefix + self.hand.base_body)
            body = hb.add_body(name=CARRIED)
            add_hulls(spec, body, CARRIED, self._objects[attached].hulls, rgba=[0.9, 0.5, 0.2, 1])
            for g in body.geoms:
                g.margin = max(self.margin, self.carried_margin)
        m = spec.compile()
        d = mujoco.MjData(m)
        body_names = [m.body(i).name for i in range(m.nbody)]
        gb = m.geom_bodyid
        arm_bodies = {m.body(self.robot.arm_base).id} | {
            i for i in range(m.nbody) if body_names[i].startswith("link")
        }
        hand_bodies = {i for i in range(m.nbody) if body_names[i].startswith(prefix)}
        carried = m.body(CARRIED).id if attached is not None else -1
        ids = np.arange(m.ngeom)
        arm = ids[np.isin(gb, list(arm_bodies))]
        hand = ids[np.isin(gb, list(hand_bodies))]
        carried_g = ids[gb == carried] if carried >= 0 else np.zeros(0, int)
        fixed = np.array([m.geom(n).id for n in _ENV_FIXED if has_geom(m, n)])
        objs, mocap = {}, {}
        for name in self._objects:
            if name == attached:
                continue
            b = m.body(f"obj/{name}").id
            objs[name] = ids[gb == b]
            mocap[name] = int(m.body_mocapid[b])
        mask = np.zeros(m.ngeom, bool)
        mask[np.concatenate([arm, hand, carried_g])] = True
        return SceneModel(m, d, arm, hand, carried_g, fixed, objs, mask, mocap, carried,
                          m.site(self.robot.tcp_site).id)  # fmt: skip

    # --- state --------------------------------------------------------------------------------
    def full_q(self, q_arm: ArrayLike, preshape: int | str = "open") -> np.ndarray:
        """The model's qpos: arm angles (n_arm,) and the hand in a pre-shape (or its name)."""
        q_arm = np.asarray(q_arm, np.float64)
        n = self.robot.n_arm
        if q_arm.shape != (n,):
            raise ShapeError(f"arm configuration must have shape ({n},), got {q_arm.shape}")
        if not np.all(np.isfinite(q_arm)):
            raise InvalidInputError("arm configuration contains NaN or inf")
        k = self.hand.preshape_index(preshape) if isinstance(preshape, str) else int(preshape)
        return np.concatenate([q_arm, np.asarray(self.hand.preshape_qpos, np.float64)[k]])

    def sync(self, sm: SceneModel, d: mujoco.MjData) -> None:
        """Copies the objects' poses into ``d``'s mocap arrays."""
        for name, i in sm.mocap.items():
            d.mocap_pos[i] = self._objects[name].pos
            d.mocap_quat[i] = self._objects[name].quat

    def _forward(self, sm: SceneModel, q: ArrayLike, d: mujoco.MjData | None = None) -> None:
        d = sm.data if d is None else d
        q = np.asarray(q, np.float64)
        if q.shape != (sm.model.nq,):
            raise ShapeError(f"configuration must have shape ({sm.model.nq},), got {q.shape}")
        d.qpos[:] = q
        self.sync(sm, d)
        mujoco.mj_kinematics(sm.model, d)

    def tcp_pose(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """TCP ``(position (3,), rotation (3, 3))`` in the world at configuration ``q`` (nq,)."""
        sm = self.scene_model()
        self._forward(sm, q)
        return sm.data.site_xpos[sm.tcp_site].copy(), sm.data.site_xmat[sm.tcp_site].reshape(3, 3)

    def collisions(
        self, q: ArrayLike, allow: tuple[tuple[str, str], ...] = (), *, obstacles: bool = True
    ) -> list[tuple[str, str, float]]:
        """Robot contacts at configuration ``q``: ``(geom, geom, distance)``, closer than
        :attr:`margin`.

        Counted: the arm, the hand or the attached object against the table, floor, pedestal,
        an object or another robot link; the attached object against the hand holding it is
        not.

        Args:
            q: Full configuration, shape (nq,).
            allow: Contacts that are allowed, as ``(part, other)`` pairs: ``part`` is
                ``"hand"``, ``"carried"`` or ``"robot"`` (arm, hand and carried object);
                ``other`` an object name or ``"table"``. The approach allows
                ``("hand", target)``; the lift allows ``("carried", "table")``.
            obstacles: Keep :attr:`obstacle_margin` from the objects other than the target;
                False: :attr:`margin` from every object (a start the robot is already at).
        """
        sm = self.scene_model()
        m, d = sm.model, sm.data
        self._forward(sm, q)
        mujoco.mj_collision(m, d)
        if d.ncon == 0:
            return []
        g1 = d.contact.geom1[: d.ncon]
        g2 = d.contact.geom2[: d.ncon]
        dist = d.contact.dist[: d.ncon]
        # Some colliders (box-capsule) also return contacts a little beyond the margin.
        carried = np.isin(g1, sm.carried_geoms) | np.isin(g2, sm.carried_geoms)
        wide = max(self._margin, self._carried_margin)
        limit = np.where(carried, wide, self._margin)
        t = int(sm.fixed_geoms[0])
        on_table = (g1 == t) | (g2 == t)
        if self._attached is not None:
            # The hand that carries swings with its load too: it keeps the carried margin from
            # the other objects (not from the table it has just lifted off).
            hand = np.isin(g1, sm.hand_geoms) | np.isin(g2, sm.hand_geoms)
            limit = np.where(hand & ~on_table, wide, limit)
        if self.table_margin is not None:
            limit = np.where(on_table & ~carried, self.table_margin, limit)
        if obstacles and self._obstacle_margin > self._margin:
            other = self._other_objects(sm)
            limit = np.where(other[g1] | other[g2], np.maximum(limit, self._obstacle_margin), limit)
        bad = classify(sm, g1, g2, allow) & (dist < limit)
        return [(m.geom(a).name, m.geom(b).name, float(x))
                for a, b, x, k in zip(g1, g2, dist, bad, strict=True) if k]  # fmt: skip

    def _other_objects(self, sm: SceneModel) -> np.ndarray:
        """Per geom of ``sm``: an object other than the target, (ngeom,) bool (cached: the
        collision checks of a plan ask for it thousands of times)."""
        held, target, mask = self._others
        if held is not sm or target != self._target:
            mask = np.zeros(sm.model.ngeom, bool)
            for name, gs in sm.object_geoms.items():
                mask[gs] = name != self._target
            self._others = (sm, self._target, mask)  # holding sm: its id is not reused
        return mask

    def is_valid(self, q: ArrayLike, allow: tuple[tuple[str, str], ...] = ()) -> bool:
        """No collision at ``q`` (see :meth:`collisions`); a Python bool."""
        return not self.collisions(q, allow)
