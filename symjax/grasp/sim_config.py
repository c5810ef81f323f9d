"""Settings of the grasp rollouts (paper Section IV-A, ``PlanGrasp``) and their quality labels."""

from __future__ import annotations

import dataclasses
import math

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["SimulationConfig"]


@dataclasses.dataclass(frozen=True)
class SimulationConfig:
    """Parameters of :func:`symjax.grasp.simulate`.

    A rollout has five open-loop phases, identical for both backends: *approach* (the hand
    moves along its approach vector under a force-limited velocity servo, so it stops where it
    first touches the object or the table; the object is welded in place), *close* (the object
    is released and the hand's closing targets ramp from the pre-shape), *settle* (targets
    held; the contacts at its end are the grasp and give the closure test), *lift* and *shake*
    (gravity now acts on the object; the hand lifts and shakes it).

    Attributes:
        timestep: Physics step, seconds.
        cone: Friction cone of the simulation, ``"pyramidal"`` or ``"elliptic"`` (Coulomb's
            cone; in MJX on the CPU it stepped 22x slower: 76 against 1,672 env-steps/s for
            the SDH, batch 16; the grasp labels were about the same in C MuJoCo).
        impratio: Ratio of frictional to normal constraint impedance. MuJoCo's soft contacts
            creep under a sustained tangential load; 10 (MuJoCo's advice for grasping) cut the
            SDH's slip in the hand during lift and shake on a 5 x 8 x 12 cm box from 2-4 cm to
            under 1.5 cm.
        gravity_after_closure: The object is weightless until the closure test (the end of
            the settle phase) and feels gravity from then on, as in the paper's sequence (close,
            test closure, then lift); False: gravity acts throughout (the object rests on the
            table while the hand closes).
        iterations: Most constraint solver iterations per step. 4 (MJX's usual setting)
            diverged in about 4% of SDH rollouts on a mug of 8 hulls (fingers wedged between
            hulls); 10 diverged in none of 1,024. The solver stops early once converged.
        ls_iterations: Most line-search iterations of the solver.
        approach_speed: Approach velocity, m/s.
        max_travel: Longest approach, metres; sets the approach phase's length.
        overshoot: The hand may travel this far past the grasp point, metres.
        base_force: Force limit of each base translation servo, newtons: how hard the hand
            presses on what it touches, and what it can lift.
        base_kv: Velocity gain of the base translation servos, N s/m.
        base_kp_rot: Stiffness of the base orientation servos, N m/rad.
        close_time: Ramp of the finger targets, seconds.
        settle_time: Hold before the contacts are read, seconds.
        lift_height: Lift, metres, over ``lift_time`` seconds.
        lift_time: Seconds.
        shake_amplitude: Shake amplitude, metres (along world x and z).
        shake_frequency: Hz.
        shake_cycles: Number of shake periods.
        success_distance: Success when the object moved less than this relative to the palm
            from grasp to the end of the shake, metres...
        success_rotation: ...and turned less than this, radians.
        min_lift: ...and rose at least this much, metres (it left the table).
        friction: Friction coefficient of the linearised cones of the force-closure test.
        n_edges: Edges per friction cone.
        torsion: Soft-finger torsional friction length, metres (0: point contacts).
        contact_distance: A contact counts when its signed distance is below this, metres.
        max_contacts: Contacts kept per grasp for the quality test (the deepest ones).
        object_mass: Object mass, kg; None: from its hulls at ``object_density``.
        object_density: kg/m^3.
        object_friction: Sliding friction of the object's geoms (and the table).
        finger_torsion: Torsional friction of the hand's geoms (a length, metres: about the
            radius of a finger pad's contact patch); 0 keeps point contacts (condim 3).
        mjx_max_contacts: MJX keeps at most this many contacts per contact dimension (the
            deepest; MJX's ``max_contact_points``), None: all it can generate. MJX allots
            constraint rows for every contact a geom pair could make (4 per hull pair), so
            without a cap the solver works on thousands of mostly empty rows. C MuJoCo ignores it.
        mjx_max_pairs: MJX runs each collision function on at most this many geom pairs per
            geom-type group, the nearest by bounding sphere (``max_geom_pairs``); None: all.
    """

    timestep: float = 0.002
    cone: str = "pyramidal"
    impratio: float = 10.0
    gravity_after_closure: bool = True
    iterations: int = 10
    ls_iterations: int = 20
    approach_speed: float = 0.5
    max_travel: float = 0.25
    overshoot: float = 0.04
    base_force: float = 20.0
    base_kv: float = 400.0
    base_kp_rot: float = 200.0
    close_time: float = 0.4
    settle_time: float = 0.1
    lift_height: float = 0.1
    lift_time: float = 0.4
    shake_amplitude: float = 0.01
    shake_frequency: float = 2.0
    shake_cycles: int = 1
    success_distance: float = 0.03
    success_rotation: float = 1.0
    min_lift: float = 0.05
    friction: float = 0.5
    n_edges: int = 8
    torsion: float = 0.0
    contact_distance: float = 0.0005
    max_contacts: int = 16
    object_mass: float | None = None
    object_density: float = 400.0
    object_friction: float = 1.0
    finger_torsion: float = 0.01
    mjx_max_contacts: int | None = 32
    mjx_max_pairs: int | None = 16

    def __post_init__(self):
        check_fields(self)
        positive = (
            "timestep", "approach_speed", "max_travel", "base_force", "base_kv", "base_kp_rot",
            "close_time", "lift_time", "shake_frequency", "success_distance",
            "success_rotation", "object_density", "impratio",
        )  # fmt: skip
        for name in positive:
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ConfigError(f"{name} must be a positive number, got {v!r}")
        for name in ("settle_time", "lift_height", "shake_amplitude", "overshoot", "friction",
                     "torsion", "min_lift", "finger_torsion"):  # fmt: skip
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ConfigError(f"{name} must be >= 0, got {v!r}")
        if self.cone not in ("elliptic", "pyramidal"):
            raise ConfigError(f"cone must be 'elliptic' or 'pyramidal', got {self.cone!r}")
        if self.iterations < 1 or self.ls_iterations < 1:
            raise ConfigError("iterations and ls_iterations must be >= 1")
        if self.n_edges < 3:
            raise ConfigError(f"n_edges must be >= 3, got {self.n_edges}")
        if self.max_contacts < 1 or self.shake_cycles < 0:
            raise ConfigError(
                f"max_contacts must be >= 1 and shake_cycles >= 0, got {self.max_contacts},"
                f" {self.shake_cycles}"
            )
        if self.object_mass is not None and not self.object_mass > 0:
            raise ConfigError(f"object_mass must be positive, got {self.object_mass}")
        for name in ("mjx_max_contacts", "mjx_max_pairs"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, int) and v >= 1):
                raise ConfigError(f"{name} must be None or an integer >= 1, got {v!r}")

    def _steps(self, seconds: float) -> int:
        return max(1, int(round(seconds / self.timestep)))

    @property
    def phase_steps(self) -> tuple[int, int, int, int, int]:
        """Steps of (approach, close, settle, lift, shake)."""
        shake = self.shake_cycles / self.shake_frequency
        return (
            self._steps(self.max_travel / self.approach_speed),
            self._steps(self.close_time),
            self._steps(self.settle_time) if self.settle_time > 0 else 0,
            self._steps(self.lift_time),
            self._steps(shake) if self.shake_cycles else 0,
        )

    @property
    def geom_friction(self) -> tuple[float, float, float]:
        """MuJoCo friction (sliding, torsional, rolling) of the objects, obstacles and table."""
        return (self.object_friction, 0.005, 0.0001)

    @property
    def n_steps(self) -> int:
        """Total steps of one rollout."""
        return sum(self.phase_steps)
