"""Rigid DEM bodies of a scene and the contact law between them (SI units, per unit thickness).

A rigid body is a spheropolygon (``mpmdem.model.spheropolygons``) with a density, a motion kind and a
friction coefficient. Masses are per unit thickness [kg/m]; the contact stiffness is a force per
unit thickness per metre of overlap [N/m per m = Pa].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ..checks import at_least, finite, positive, within
from ..errors import InputError
from .spheropolygons import Spheropolygon

__all__ = ["MOTIONS", "ContactLaw", "RigidBody"]

MOTIONS = ("free", "fixed", "kinematic")


@dataclass(frozen=True)
class ContactLaw:
    """Linear spring–dashpot contact with a Coulomb-capped tangential spring (MPM-SDEM eq. 43).

    Attributes:
        normal_stiffness: k_n [N/m per m of thickness], > 0.
        tangential_stiffness: k_t, >= 0; None means k_t = k_n.
        restitution: coefficient of restitution e in [0, 1] of a head-on two-body impact; it
            sets the normal damping c_n = 2ζ sqrt(m_eff k_n), ζ = −ln e / sqrt(π² + ln² e)
            (1 is elastic, 0 critically damped).
    """

    normal_stiffness: float
    tangential_stiffness: float | None = None
    restitution: float = 0.5

    def __post_init__(self):
        positive("normal_stiffness", self.normal_stiffness, "a stiffness k_n > 0 [N/m per m]")
        if self.tangential_stiffness is not None:
            at_least("tangential_stiffness", self.tangential_stiffness, 0.0, "a stiffness k_t >= 0, or None (= k_n)")
        within("restitution", self.restitution, 0.0, 1.0, "a coefficient of restitution in [0, 1]")

    @property
    def kt(self) -> float:
        """Tangential stiffness k_t [N/m per m]."""
        return float(self.normal_stiffness if self.tangential_stiffness is None else self.tangential_stiffness)

    @property
    def damping_ratio(self) -> float:
        """ζ of the normal dashpot that gives the restitution coefficient e."""
        e = float(self.restitution)
        if e <= 0.0:
            return 1.0
        log_e = math.log(e)
        return -log_e / math.sqrt(math.pi**2 + log_e**2)

    def to_dict(self) -> dict:
        return {"normal_stiffness": float(self.normal_stiffness), "tangential_stiffness": self.kt,
                "restitution": float(self.restitution)}


@dataclass(frozen=True, eq=False)
class RigidBody:
    """A spheropolygon body of the DEM stage.

    Attributes:
        name: label in outputs.
        shape: the spheropolygon (vertices in its body frame, about its centroid).
        density: ρ [kg/m³]; mass per unit thickness = ρ × area.
        position: centroid [m].
        angle: orientation of the body frame [rad].
        velocity: initial (free) or prescribed (kinematic) velocity [m/s].
        angular_velocity: initial or prescribed angular velocity [rad/s].
        motion: "free" (integrated), "fixed" (never moves, never integrated) or "kinematic"
            (moves with the prescribed velocity during ``active``, whatever the forces).
        friction: Coulomb coefficient μ >= 0; a pair of bodies uses the smaller of the two.
        active: (t_start, t_end) [s] during which a kinematic body moves; still otherwise.
    """

    name: str
    shape: Spheropolygon
    density: float
    position: tuple[float, float]
    angle: float = 0.0
    velocity: tuple[float, float] = (0.0, 0.0)
    angular_velocity: float = 0.0
    motion: Literal["free", "fixed", "kinematic"] = "free"
    friction: float = 0.5
    active: tuple[float, float] = (0.0, math.inf)

    @property
    def mass(self) -> float:
        """Mass per unit thickness [kg/m]."""
        return self.shape.mass_properties(self.density)[0]

    @property
    def inertia(self) -> float:
        """Moment of inertia about the centroid per unit thickness [kg m²/m]."""
        return self.shape.mass_properties(self.density)[1]

    def world_vertices(self) -> np.ndarray:
        """Core vertices at the initial position and angle [m]."""
        return self.shape.world_vertices(self.position, self.angle)

    def to_dict(self) -> dict:
        return {
            "name": self.name, "shape": self.shape.to_dict(), "density": self.density,
            "position": list(self.position), "angle": self.angle, "velocity": list(self.velocity),
            "angular_velocity": self.angular_velocity, "motion": self.motion, "friction": self.friction,
            "active": [self.active[0], self.active[1] if math.isfinite(self.active[1]) else None],
        }


def _vector(name: str, value, allowed: str) -> tuple[float, float]:
    """``value`` as finite (x, y) floats: a pair of numbers, or anything numpy reads as two numbers;
    InputError(name, value, allowed) otherwise. A tuple or list of two ints or floats skips numpy
    (the same floats, a few microseconds less per body for scenes of 10⁶ bodies)."""
    if isinstance(value, (tuple, list)) and len(value) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        xy = (float(value[0]), float(value[1]))
    else:
        xy = tuple(float(v) for v in np.asarray(value, dtype=float).ravel())
    if len(xy) != 2 or not all(math.isfinite(v) for v in xy):
        raise InputError(name, value, allowed)
    return xy


def make_rigid_body(
    shape: Spheropolygon,
    *,
    density: float,
    position=None,
    angle: float = 0.0,
    velocity=(0.0, 0.0),
    angular_velocity: float = 0.0,
    motion: str = "free",
    friction: float = 0.5,
    active=(0.0, math.inf),
    name: str,
) -> RigidBody:
    """Validate the arguments of ``Scene.add_rigid_body`` and build the body."""
    if not isinstance(shape, Spheropolygon):
        raise InputError("shape", shape, "a Spheropolygon (mpmdem.sphero_disk, rounded_rectangle, regular_polygon...)")
    rho = positive("density", density, "a density > 0 [kg/m^3]")
    if position is None:
        position = shape.origin
    pos = _vector("position", position, "a finite centroid (x, y) [m]")
    vel = _vector("velocity", velocity, "a finite (vx, vy) [m/s]")
    ang = finite("angle", angle, "a finite angle [rad]")
    w = finite("angular_velocity", angular_velocity, "a finite angular velocity [rad/s]")
    if motion not in MOTIONS:
        raise InputError("motion", motion, f"one of {', '.join(MOTIONS)}")
    mu = at_least("friction", friction, 0.0, "a Coulomb coefficient >= 0")
    try:
        t0, t1 = (float(v) for v in active)
    except (TypeError, ValueError):
        raise InputError("active", active, "(t_start, t_end) [s] with t_start < t_end") from None
    if not (math.isfinite(t0) and t0 < t1):
        raise InputError("active", active, "(t_start, t_end) [s] with t_start < t_end")
    if motion == "free" and shape.radius <= 0.0:
        raise InputError("shape.radius", shape.radius,
                         "a sphero radius a > 0 for a free body (contacts are measured in its rounding disk)")
    return RigidBody(name, shape, rho, pos, ang, vel, w, motion, mu, (t0, t1))
