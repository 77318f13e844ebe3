"""Three-degree-of-freedom point-mass rotorcraft model, chapter 6 (eqs 1-19).

State ``[x, y, z, V, γ, χ]``: down range, cross range, altitude (ft, ``z`` up), airspeed
(ft/s, no wind), flight-path angle and heading (rad). Controls ``(T, θ, φ)``: main-rotor
thrust (lbf), thrust orientation angle measured from the plane normal to the velocity
(positive forward, along ``V``) and bank angle from the local vertical (rad).

Geometry used throughout (derived from eqs 1-6 and 9-11): with the unit vectors

* ``e_V = [cγ cχ, cγ sχ, sγ]`` (along the velocity),
* ``e_γ = [-sγ cχ, -sγ sχ, cγ]`` (normal to it, in the vertical plane, "up"),
* ``e_χ = [-sχ, cχ, 0]`` (horizontal, to the side of increasing heading),

the model is ``m r'' = (T sθ - D) e_V + T cθ cφ e_γ + T cθ sφ e_χ - m g e_z``. Eqs 9-11
are the components of ``r''`` and eqs 12-19 invert it: with ``b = a + g e_z``,
``Γ = b·e_γ`` (eq 19), ``N1 + N2 = b·e_V`` (eqs 17-18), ``b·e_χ = a_y cχ - a_x sχ``.

Print notes: eq 16's ``χ = tan⁻¹(y'/x')`` must be the four-quadrant ``atan2(y', x')``
(the example starts flying along -y, where ``tan⁻¹`` gives the wrong half-plane). Eqs
12-14 use ``tan⁻¹`` and divide by ``Γ`` and ``cos φ``; here ``φ = atan2(b·e_χ, Γ)`` and
``θ = atan2(b·e_V + D/m, sqrt(Γ² + (b·e_χ)²))``, ``T = m |b + (D/m) e_V|``, which equal
eqs 12-14 whenever ``Γ > 0`` (thrust pointing up, the only case the printed form covers)
and stay defined otherwise.

Drag (eq 7), ``D = ½ ρ V² s C_D``: the report takes ``C_D`` of the UH-60 from its
Reference 13, which is not reproduced. The defaults here are *assumptions* of a
UH-60A-class helicopter: weight 16,260 lbf (the UH-60A "loaded" weight quoted in public
specifications, e.g. the table of https://lamorocco.com/the-uh-60-black-hawk/, which
also gives a 2,260 ft² disc area), reference area ``s`` = 2,260 ft² (the rotor disc) and
``C_D`` = 0.0115, i.e. an equivalent flat-plate area ``s C_D`` ≈ 26 ft², typical of
helicopters of that size. At the example's ≤ ~45 ft/s the drag is < 0.3 % of the weight,
so the choice barely matters; ``docs/guidance.md`` measures it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .checks import check_numbers

__all__ = [
    "G_FT_S2",
    "RHO_SL_SLUG_FT3",
    "Controls",
    "VehicleParams",
    "accelerations",
    "flight_path_from_velocity",
    "inverse_controls",
    "point_mass_rhs",
    "state_from_position_velocity",
    "velocity_from_state",
]

G_FT_S2 = 32.174
"""Standard gravity, ft/s²."""

RHO_SL_SLUG_FT3 = 0.0023769
"""Sea-level standard air density, slug/ft³."""


@dataclass(frozen=True)
class VehicleParams:
    """Point-mass vehicle constants (ft, slug, lbf, s).

    Parameters
    ----------
    weight_lbf
        Weight ``m g`` (lbf); ``mass = weight / g``.
    ref_area_ft2, drag_coefficient
        ``s`` and ``C_D`` of eq 7 (see the module docstring for the source/assumption).
    rho
        Air density (slug/ft³).
    g
        Gravity (ft/s²).
    """

    weight_lbf: float = 16260.0
    ref_area_ft2: float = 2260.0
    drag_coefficient: float = 0.0115
    rho: float = RHO_SL_SLUG_FT3
    g: float = G_FT_S2

    def __post_init__(self) -> None:
        check_numbers("vehicle parameter", self, ("weight_lbf", "ref_area_ft2", "rho", "g"))
        cd = self.drag_coefficient
        if not isinstance(cd, (int, float)) or not math.isfinite(cd) or cd < 0:
            raise ValueError(f"drag_coefficient must be a finite number >= 0, not {cd!r}")

    @property
    def mass(self) -> float:
        """Mass (slug)."""
        return self.weight_lbf / self.g

    def drag(self, speed: float | np.ndarray) -> float | np.ndarray:
        """Drag ``D = ½ ρ V² s C_D`` (lbf), eq 7."""
        return 0.5 * self.rho * np.square(speed) * self.ref_area_ft2 * self.drag_coefficient


@dataclass(frozen=True)
class Controls:
    """Actual controls: thrust ``T`` (lbf), thrust angle ``θ`` and bank ``φ`` (rad)."""

    thrust: float
    theta: float
    phi: float

    def load_factor(self, params: VehicleParams) -> float:
        """``T / (m g)``, the rotor load factor."""
        return self.thrust / params.weight_lbf


def flight_path_from_velocity(v: np.ndarray) -> tuple[float, float, float]:
    """``(V, γ, χ)`` from the velocity ``[x', y', z']``, eqs 15-16 (``χ`` by ``atan2``).

    Raises
    ------
    ValueError
        At zero speed, where γ and χ are undefined.
    """
    vx, vy, vz = (float(c) for c in v)
    speed = math.sqrt(vx * vx + vy * vy + vz * vz)  # eq 15
    if speed == 0.0:
        raise ValueError("flight-path angles undefined at zero speed (eq 16)")
    gamma = math.asin(max(-1.0, min(1.0, vz / speed)))  # eq 16
    chi = math.atan2(vy, vx)  # eq 16 with the quadrant resolved
    return speed, gamma, chi


def state_from_position_velocity(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """State ``[x, y, z, V, γ, χ]`` from position and velocity."""
    speed, gamma, chi = flight_path_from_velocity(v)
    return np.array([r[0], r[1], r[2], speed, gamma, chi], dtype=np.float64)


def velocity_from_state(state: np.ndarray) -> np.ndarray:
    """``[x', y', z']`` of eqs 4-6."""
    _, _, _, speed, gamma, chi = state
    cg = math.cos(gamma)
    return np.array(
        [speed * cg * math.cos(chi), speed * cg * math.sin(chi), speed * math.sin(gamma)]
    )


def point_mass_rhs(state: np.ndarray, controls: Controls, params: VehicleParams) -> np.ndarray:
    """Time derivative of ``[x, y, z, V, γ, χ]``, eqs 1-6 with the drag of eq 7.

    Singular at ``V = 0`` (eqs 2-3) and at ``γ = ±90°`` (eq 2), as printed.
    """
    _, _, _, speed, gamma, chi = state
    m, g = params.mass, params.g
    T, th, ph = controls.thrust, controls.theta, controls.phi
    cg, sg = math.cos(gamma), math.sin(gamma)
    drag = params.drag(speed)
    v_dot = (T * math.sin(th) - drag) / m - g * sg  # eq 1
    chi_dot = T * math.cos(th) * math.sin(ph) / (m * speed * cg)  # eq 2
    gamma_dot = T * math.cos(th) * math.cos(ph) / (m * speed) - g * cg / speed  # eq 3
    return np.array(
        [
            speed * cg * math.cos(chi),  # eq 4
            speed * cg * math.sin(chi),  # eq 5
            speed * sg,  # eq 6
            v_dot,
            gamma_dot,
            chi_dot,
        ]
    )


def accelerations(state: np.ndarray, controls: Controls, params: VehicleParams) -> np.ndarray:
    """Pseudo-controls ``[a_x, a_y, a_z]`` produced by the controls, eqs 9-11 with 1-3."""
    _, _, _, speed, gamma, chi = state
    d = point_mass_rhs(state, controls, params)
    v_dot, gamma_dot, chi_dot = d[3], d[4], d[5]
    cg, sg, cc, sc = math.cos(gamma), math.sin(gamma), math.cos(chi), math.sin(chi)
    ax = v_dot * cg * cc - chi_dot * speed * cg * sc - gamma_dot * speed * sg * cc  # eq 9
    ay = v_dot * cg * sc + chi_dot * speed * cg * cc - gamma_dot * speed * sg * sc  # eq 10
    az = v_dot * sg + gamma_dot * speed * cg  # eq 11
    return np.array([ax, ay, az])


def inverse_controls(v: np.ndarray, a: np.ndarray, params: VehicleParams) -> Controls:
    """Controls ``(T, θ, φ)`` that produce the pseudo-controls ``a`` at velocity ``v``.

    Eqs 12-19 in four-quadrant form (module docstring): ``φ`` (eq 12), ``θ`` (eq 13),
    ``T`` (eq 14), with ``V, γ, χ`` from eqs 15-16, ``N1..N3`` (17-18), ``Γ`` (19).

    Parameters
    ----------
    v
        Velocity ``[x', y', z']`` (ft/s), non-zero.
    a
        Commanded acceleration ``[a_x, a_y, a_z]`` (ft/s²).
    params
        Vehicle constants.
    """
    speed, gamma, chi = flight_path_from_velocity(v)
    ax, ay, az = (float(c) for c in a)
    g, m = params.g, params.mass
    cg, sg, cc, sc = math.cos(gamma), math.sin(gamma), math.cos(chi), math.sin(chi)
    n1 = ax * cg * cc + ay * cg * sc  # eq 17
    n2 = (az + g) * sg  # eq 18
    gam = (g + az) * cg - ax * sg * cc - ay * sg * sc  # eq 19 (Γ)
    side = ay * cc - ax * sc  # numerator of eq 12
    phi = math.atan2(side, gam)  # eq 12
    normal = math.hypot(gam, side)  # = Γ / cos φ: thrust component normal to V per unit mass
    along = n1 + n2 + params.drag(speed) / m  # (N1 + N2 + N3 / cos φ), numerator of eq 13
    theta = math.atan2(along, normal)  # eq 13
    thrust = m * math.hypot(along, normal)  # eq 14: m Γ / (cos θ cos φ)
    return Controls(thrust, theta, phi)
