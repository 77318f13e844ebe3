"""An obstacle-avoiding guidance law beyond the report: receding-horizon optimal control
with a clearance constraint per obstacle and the vehicle limits as constraints (SPEC §13).

Why
---
The report's law (eqs 20-69) sees the obstacles only through their number and centroid
(``Σ|r - r_i|² = n|r - s|² + const``, SPEC §9), so it cannot go round an individual
vehicle. This law keeps the report's problem — the performance index of eq 20, the
same boundary conditions, the same point-mass model and inverse (eqs 1-19) — and adds
what the closed form cannot carry: state constraints.

Problem solved at each re-plan (from the current state ``r0, v0`` at ``t = 0``)
-----------------------------------------------------------------------------------
Minimise over the time-to-go ``T`` and the path ``r(t)``::

    J = ∫_0^T { ζ + (1-ζ)/2 [ α|r''|² + μ (z - z_r)² - β Σ_i |r - r_i|² ] } dt      (eq 20)

subject to ``r(0) = r0, r'(0) = v0, r(T) = r_f, r'(T) = v_f`` and, at ``n_samples``
points along the path,

* **clearance**: ``dist(r, B_k) >= clearance + margin`` for every obstacle extent
  ``B_k`` (:class:`~rangefx.guidance.extraction.ObstacleBox`, signed distance);
* **load factor**: ``T/W = |b + (D/m) e_V| / g <= n_max`` with ``b = r'' + g e_z``
  (eq 14 with eq 7's drag; the inverse of eqs 12-19 in the four-quadrant form of
  :func:`~rangefx.guidance.model.inverse_controls`);
* **thrust angle**: ``|b·e_V + D/m| <= sin(θ_max) |b + (D/m) e_V|`` (eq 13);
* **bank**: ``|b·e_χ| <= tan(φ_max) b·e_γ`` (eq 12; this also keeps the thrust up);
* **ground**: ``z >= 0`` at interior samples.

``r_i`` are the same obstacle points the report's law uses (so without active
constraints this is the report's own problem, whose extremal is eqs 37-52 at the
``T`` where ``∂J/∂T = H = 0``), ``T`` is confined below the conjugate point
``0.98 · 4.730/σ`` (beyond it the −β term makes ``J`` unbounded below, see
:mod:`.law`).

Parametrisation (transcription)
-------------------------------
With ``s = t/T``, ``r(s) = h00(s) r0 + h10(s) T v0 + h01(s) r_f + h11(s) T v_f +
Σ_j c_j s²(1-s)² P_j(2s - 1)``: the cubic Hermite polynomial meets the four boundary
conditions exactly for every ``T`` and ``c`` (the correction and its slope vanish at
both ends), ``P_j`` are Legendre polynomials (``n_basis`` per axis). ``J`` is
integrated by Gauss-Legendre quadrature. The nonlinear programme in ``(T, c)`` is
solved by SLSQP (``scipy.optimize.minimize``). **Seed**: the report's extremal
(:func:`~rangefx.guidance.law.open_loop_solution` at its time-to-go from eq 55),
projected on the basis by least squares; further seeds bend that path to either side
when the first does not converge to a feasible plan.

Closed loop
-----------
At every guidance update the command is the plan's ``r''`` plus a tracking term
``ω² (r_plan - r) + 2ζ_t ω (v_plan - v)``, turned into ``(T, θ, φ)`` by the inverse
(eqs 12-19) and held while eqs 1-6 are integrated (as in :func:`.simulate.simulate`).
Every ``replan_interval`` the programme is solved again from the measured state (warm
started from the current plan); in the last ``terminal_time`` the plan is followed
without re-solving (as the report's law counts its time-to-go down there). Each
command passes :func:`limited_command` before it is held, so the held controls — and
with them the whole integrated trajectory — meet the load-factor, θ and φ limits.

Infeasible layouts
------------------
When no plan to the touch-down meets the clearance within the limits, the law says so
(:class:`InfeasibleClearanceWarning`, ``feasible = False``) and takes a safe manoeuvre
(:func:`plan_safe_manoeuvre`: hover ahead, climb over, turn away) to a hold point that
keeps the clearance; it never lands on a plan that passes closer than the clearance
to an extent. A start within an extent's clearance blocks the landing too: the
manoeuvre then keeps what the start leaves and moves away sideways (the extents whose
clearance holds the start are walls, :func:`escape_walls`; the floor rises to the full
clearance over ``ESCAPE_TIME_S``, points away from the extent are tried first), and
at its hold point the law decides again: it lands only on a plan that keeps the
clearance, else it holds. When no manoeuvre keeps its floor the law brakes straight
ahead to a stop (:func:`plan_braking_stop`) and holds there, unless the stop's own path
and hold point come shorter of the clearance than the candidate least short of its
floor (:func:`plan_safe_manoeuvre`): then that candidate is flown.
``when_blocked="best-effort"`` keeps the old behaviour (land on the plan that keeps the
full clearance from every extent except those an end point is within the clearance of,
and from those as much as that end point leaves).
"""

from __future__ import annotations

import functools
import math
import time
import warnings
from dataclasses import dataclass, replace

import numpy as np
from numpy.polynomial import legendre as npleg
from numpy.polynomial import polynomial as nppoly
from scipy.optimize import minimize

from .checks import check_choice, check_numbers
from .extraction import BoxSet, ObstacleBox
from .law import (
    FIRST_SINGULAR_SIGMA_T,
    BoundaryConditions,
    NoTransversalityRootWarning,
    ObstacleField,
    open_loop_solution,
    solve_time_to_go,
)
from .model import (
    G_FT_S2,
    Controls,
    VehicleParams,
    inverse_controls,
    state_from_position_velocity,
    velocity_from_state,
)
from .simulate import (
    SimulationConfig,
    SimulationResult,
    held_sample_times,
    integrate_held_controls,
    record_command,
    result_from_record,
)

__all__ = [
    "MANOEUVRES",
    "OUTCOMES",
    "WHEN_BLOCKED",
    "AvoidConfig",
    "AvoidPlan",
    "InfeasibleClearanceWarning",
    "SafeManoeuvre",
    "escape_direction",
    "escape_walls",
    "limit_margins",
    "limited_command",
    "manoeuvre_candidates",
    "plan_braking_stop",
    "plan_safe_manoeuvre",
    "plan_trajectory",
    "simulate_avoid",
    "stopping_distance",
    "within_limits",
]


class InfeasibleClearanceWarning(UserWarning):
    """No trajectory meets the required clearance within the vehicle limits."""


#: What the law may do when no path to the touch-down keeps the clearance.
WHEN_BLOCKED: tuple[str, ...] = ("manoeuvre", "best-effort")

#: The safe manoeuvres, in the order they are tried (the least departure first); the
#: last, ``stop`` (brake straight ahead to a hover), is flown when none keeps its floor.
MANOEUVRES: tuple[str, ...] = ("hover", "climb", "turn-away", "stop")

#: Hold points of the braking stop, in units of the stopping distance
#: (:func:`stopping_distance`): the first whose plan is within the limits is flown.
STOP_DISTANCE_FACTORS: tuple[float, ...] = (1.25, 1.5, 2.0, 3.0)

#: SLSQP iterations allowed to one safe-manoeuvre candidate (one seed).
MANOEUVRE_MAXITER: int = 80

#: SLSQP iterations allowed to a re-plan warm-started from a plan that keeps the clearance.
REPLAN_MAXITER: int = 60

#: Time (s) over which the clearance floor rises from what a start within an extent's
#: clearance leaves to the full clearance (and falls to what a touch-down within it
#: leaves): the path must move away, not run along the extent (a long P1 extent holds
#: a true vehicle somewhere inside). The rise is quadratic in time (a start whose
#: velocity runs along the extent can only accelerate away): 25 ft in 4 s asks
#: ~3 ft/s² across, a third of what the load-factor limit allows.
ESCAPE_TIME_S: float = 4.0

#: Longest plan to a hold point (s): the candidates lie 100-250 ft away.
MANOEUVRE_MAX_TIME: float = 30.0

#: How a closed-loop flight ends: at the touch-down, holding at a hover point short of
#: the obstacles, after a go-around (climb over or turn away, then hold), or not at all
#: (the model left its domain: reported, never raised).
OUTCOMES: tuple[str, ...] = ("landing", "hover", "go-around", "crash")


@dataclass(frozen=True)
class AvoidConfig:
    """Settings of the avoiding law.

    Parameters
    ----------
    clearance_ft
        Required distance from every obstacle extent (ft).
    margin_ft
        Planning margin added to the clearance: the plan is checked at samples and the
        closed loop holds each command for a guidance interval. Per extent it is capped
        at half of what the end points have beyond the clearance (else an end point
        just outside the clearance makes the programme infeasible).
    max_load_factor, max_theta_deg, max_phi_deg
        Limits on ``T/W``, ``|θ|`` and ``|φ|`` (constraints of the programme).
    limit_backoff
        The plan keeps this fraction inside each limit (of ``n_max - 1``, ``θ_max``,
        ``φ_max``) so that the tracking term and the held commands of the closed loop
        stay within them.
    n_basis
        Correction polynomials per axis.
    n_samples
        Constraint samples along the plan (also the quadrature order).
    replan_interval
        Time between re-solves in the closed loop (s).
    terminal_time
        No re-solve once the plan has less than this left (s).
    track_omega, track_damping
        Tracking-term natural frequency (rad/s) and damping ratio.
    maxiter, ftol
        SLSQP iteration limit and cost tolerance per solve.
    when_blocked
        What the law does when no trajectory to the touch-down keeps the clearance:
        ``"manoeuvre"`` (default) takes a safe manoeuvre (:func:`plan_safe_manoeuvre`:
        decelerate to a hover and hold, climb over, or turn away to a safe point);
        ``"best-effort"`` lands anyway on the best-effort plan (flagged), as before
        issue 39.
    """

    clearance_ft: float = 20.0
    margin_ft: float = 1.0
    max_load_factor: float = 1.1
    max_theta_deg: float = 20.0
    max_phi_deg: float = 30.0
    limit_backoff: float = 0.1
    n_basis: int = 8
    n_samples: int = 64
    replan_interval: float = 0.5
    terminal_time: float = 2.0
    track_omega: float = 1.0
    track_damping: float = 0.9
    maxiter: int = 200
    ftol: float = 1e-6
    when_blocked: str = "manoeuvre"

    def __post_init__(self) -> None:
        check_choice("avoid", "when_blocked", self.when_blocked, WHEN_BLOCKED)
        check_numbers("avoid", self, (
            "clearance_ft", "max_load_factor", "max_theta_deg", "max_phi_deg",
            "replan_interval", "terminal_time", "track_omega", "track_damping",
        ))  # fmt: skip
        if not (isinstance(self.margin_ft, (int, float)) and self.margin_ft >= 0):
            raise ValueError(f"avoid margin_ft must be >= 0, not {self.margin_ft!r}")
        if self.max_load_factor <= 1.0:
            raise ValueError(
                f"max_load_factor must exceed 1 (hover needs T = W), not {self.max_load_factor!r}"
            )
        if not 0 <= self.limit_backoff < 1:
            raise ValueError(f"limit_backoff must lie in [0, 1), not {self.limit_backoff!r}")
        if not 0 < self.max_theta_deg < 90 or not 0 < self.max_phi_deg < 90:
            raise ValueError("max_theta_deg and max_phi_deg must lie in (0, 90)")
        for name, lo in (("n_basis", 1), ("n_samples", 8), ("maxiter", 1)):
            v = getattr(self, name)
            if not isinstance(v, int) or v < lo:
                raise ValueError(f"avoid {name} must be an integer >= {lo}, not {v!r}")


# --------------------------------------------------------------------------- basis


@dataclass(frozen=True)
class _Basis:
    """Hermite + correction basis evaluated at fixed ``s`` nodes (values, d/ds, d²/ds²)."""

    s: np.ndarray
    weights: np.ndarray  # quadrature weights on [0, 1]
    herm: np.ndarray  # (3, 4, n): order, [h00, h10, h01, h11], node
    corr: np.ndarray  # (3, m, n)


def _hermite(s: np.ndarray) -> np.ndarray:
    h = np.empty((3, 4, len(s)))
    s2, s3 = s * s, s**3
    h[0] = [2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2]
    h[1] = [6 * s2 - 6 * s, 3 * s2 - 4 * s + 1, -6 * s2 + 6 * s, 3 * s2 - 2 * s]
    h[2] = [12 * s - 6, 6 * s - 4, -12 * s + 6, 6 * s - 2]
    return h


@functools.lru_cache(maxsize=8)
def _correction_polys(m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Power-series coefficients (m, deg + 1) of ``s²(1-s)² P_j(2s-1)``, ``j < m``, and of
    its first two s-derivatives (built once per ``m``: :func:`AvoidPlan.evaluate` needs
    them at every guidance update)."""
    w = np.polynomial.Polynomial([0, 0, 1, -2, 1])  # s²(1-s)²
    deg = m + 3
    out = np.zeros((3, m, deg + 1))
    for j in range(m):
        pj = np.polynomial.Polynomial(npleg.leg2poly([0] * j + [1])).convert()
        pj = pj(np.polynomial.Polynomial([-1, 2]))  # P_j(2s - 1)
        poly = w * pj
        for k in range(3):
            c = poly.deriv(k).coef if k else poly.coef
            out[k, j, : len(c)] = c
    return out[0], out[1], out[2]


def _correction(s: np.ndarray, m: int) -> np.ndarray:
    """``s²(1-s)² P_j(2s-1)`` and its first two s-derivatives, shape (3, m, n)."""
    s = np.asarray(s, dtype=np.float64)
    return np.stack([nppoly.polyval(s, c.T) for c in _correction_polys(m)])


@functools.lru_cache(maxsize=8)
def _basis(n_nodes: int, m: int) -> _Basis:
    x, wq = npleg.leggauss(n_nodes)
    s = 0.5 * (x + 1.0)
    return _Basis(s, 0.5 * wq, _hermite(s), _correction(s, m))


@functools.lru_cache(maxsize=64)
def _box_set(boxes: tuple[ObstacleBox, ...]) -> BoxSet:
    """The extents of a layout as one :class:`~rangefx.guidance.extraction.BoxSet`, built
    once per layout (every solve of a flight asks for the same extents)."""
    return BoxSet(boxes)


@dataclass(frozen=True)
class AvoidPlan:
    """A planned path from ``(r0, v0)`` at time ``t0`` to ``(r_f, v_f)`` at ``t0 + T``.

    ``coeffs`` (m, 3): correction coefficients. Evaluate with :meth:`evaluate`.
    """

    t0: float
    t_go: float
    r0: np.ndarray
    v0: np.ndarray
    rf: np.ndarray
    vf: np.ndarray
    coeffs: np.ndarray
    feasible: bool
    min_clearance_ft: float
    limits_ok: bool = True
    solve_time_s: float = 0.0
    iterations: int = 0
    status: str = ""
    meets_floor: bool = True  # met what was asked: the clearance, or what the end points leave
    floor_margin_ft: float = 0.0  # smallest distance beyond what was asked (< 0: short of it)

    def evaluate(self, tau: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration at plan times ``tau`` (s from ``t0``)."""
        tau = np.atleast_1d(np.asarray(tau, dtype=np.float64))
        s = np.clip(tau / self.t_go, 0.0, 1.0)
        return _path(s, self.t_go, self.r0, self.v0, self.rf, self.vf, self.coeffs)


def _path(s, t_go, r0, v0, rf, vf, coeffs):
    herm = _hermite(s)
    corr = _correction(s, len(coeffs))
    return _path_from(herm, corr, t_go, r0, v0, rf, vf, coeffs)


def _path_from(herm, corr, t_go, r0, v0, rf, vf, coeffs):
    ends = np.stack([r0, t_go * v0, rf, t_go * vf])  # (4, 3)
    out = []
    for k in range(3):
        val = herm[k].T @ ends + corr[k].T @ coeffs  # (n, 3), d^k/ds^k
        out.append(val / t_go**k)
    return out[0], out[1], out[2]


# --------------------------------------------------------------------------- constraints


def limit_margins(
    v: np.ndarray,
    a: np.ndarray,
    params: VehicleParams,
    cfg: AvoidConfig,
    min_speed: float = 0.0,
) -> np.ndarray:
    """Margins (>= 0 when met) of the load-factor, θ and φ limits at velocities ``v`` and
    accelerations ``a`` (shape (n, 3)); columns ``[n, +θ, -θ, +φ, -φ, V]``.

    The last column keeps the airspeed above ``min_speed``: the point-mass model is
    singular at ``V = 0`` (eqs 2-3), and a plan that turns the velocity round through
    zero near the touch-down cannot be flown.

    The quantities are those of the inverse (eqs 12-19, four-quadrant form).
    """
    g = params.g
    speed = np.linalg.norm(v, axis=1)
    speed = np.maximum(speed, 1e-9)
    ev = v / speed[:, None]
    gam = np.arcsin(np.clip(v[:, 2] / speed, -1.0, 1.0))
    chi = np.arctan2(v[:, 1], v[:, 0])
    cg, sg, cc, sc = np.cos(gam), np.sin(gam), np.cos(chi), np.sin(chi)
    b = a + np.array([0.0, 0.0, g])
    e_gam = np.stack([-sg * cc, -sg * sc, cg], axis=1)
    e_chi = np.stack([-sc, cc, np.zeros_like(cc)], axis=1)
    drag = params.drag(speed) / params.mass
    along = (b * ev).sum(axis=1) + drag  # numerator of eq 13
    normal = (b * e_gam).sum(axis=1)  # Γ, eq 19
    side = (b * e_chi).sum(axis=1)  # numerator of eq 12
    thrust = np.sqrt(along**2 + normal**2 + side**2)  # T/m, eq 14
    keep = 1.0 - cfg.limit_backoff
    st = math.sin(math.radians(keep * cfg.max_theta_deg))
    tp = math.tan(math.radians(keep * cfg.max_phi_deg))
    return np.stack(
        [
            1.0 + keep * (cfg.max_load_factor - 1.0) - thrust / g,
            st * thrust - along,
            st * thrust + along,
            tp * normal - side,
            tp * normal + side,
            speed - min_speed,
        ],
        axis=1,
    )


def within_limits(ctrl: Controls, params: VehicleParams, cfg: AvoidConfig) -> bool:
    """Whether held controls meet the load-factor, θ and φ limits (the limits
    themselves, not the plan's backed-off ones)."""
    return (
        ctrl.load_factor(params) <= cfg.max_load_factor
        and abs(ctrl.theta) <= math.radians(cfg.max_theta_deg)
        and abs(ctrl.phi) <= math.radians(cfg.max_phi_deg)
    )


def limited_command(
    v: np.ndarray,
    a_plan: np.ndarray,
    a_track: np.ndarray,
    params: VehicleParams,
    cfg: AvoidConfig,
    steps: int = 30,
) -> tuple[np.ndarray, Controls, bool]:
    """The command of one guidance update, limited so that its controls (held until the
    next update) meet the vehicle limits: ``(a, controls, limited)``.

    The plan keeps ``limit_backoff`` inside the limits, so ``a_plan + a_track`` is
    normally within them and returned as is. Otherwise the tracking term is scaled by
    the largest ``λ ∈ [0, 1]`` found by bisection whose controls are within; if even the
    plan's own ``a_plan`` is not (a coarse plan between its constraint samples), the
    command ``μ a_plan`` with the largest such ``μ ∈ [0, 1]`` (``a = 0``, unaccelerated
    flight, needs ``θ ≈ γ`` and ``T ≈ W``: within the limits unless the path climbs
    steeper than ``θ_max``); if that is not within either, the controls are clipped to
    the limits (the commanded ``a`` returned is then not achieved exactly).
    Because the controls are held constant between updates (eqs 1-6 integrated with
    them), this makes the limits hold along the whole integrated trajectory.
    """

    def ctrl_of(a):
        return inverse_controls(v, a, params)

    full = a_plan + a_track
    ctrl = ctrl_of(full)
    if within_limits(ctrl, params, cfg):
        return full, ctrl, False
    if within_limits(ctrl_of(a_plan), params, cfg):
        base, step = a_plan, a_track
    else:
        base, step = np.zeros(3), a_plan
    lo, hi = 0.0, 1.0  # base + lo * step is within the limits, base + hi * step is not
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if within_limits(ctrl_of(base + mid * step), params, cfg):
            lo = mid
        else:
            hi = mid
    a = base + lo * step
    ctrl = ctrl_of(a)
    if not within_limits(ctrl, params, cfg):  # base itself outside (a steep climb): clip
        th, ph = math.radians(cfg.max_theta_deg), math.radians(cfg.max_phi_deg)
        ctrl = Controls(
            min(ctrl.thrust, cfg.max_load_factor * params.weight_lbf),
            min(max(ctrl.theta, -th), th),
            min(max(ctrl.phi, -ph), ph),
        )
    return a, ctrl, True


def _clearances(pos: np.ndarray, boxes: tuple[ObstacleBox, ...]) -> np.ndarray:
    if not boxes:
        return np.full((len(pos), 0), np.inf)
    return _box_set(tuple(boxes)).signed_distance(pos)


# --------------------------------------------------------------------------- one solve


@dataclass
class _Problem:
    r0: np.ndarray
    v0: np.ndarray
    bc: BoundaryConditions
    field: ObstacleField
    boxes: tuple[ObstacleBox, ...]
    params: VehicleParams
    cfg: AvoidConfig
    basis: _Basis
    t_bounds: tuple[float, float]
    need_ft: np.ndarray  # (node, box): clearance + the planning margin the ends allow

    def __post_init__(self) -> None:
        # SLSQP evaluates the cost, the constraints and their Jacobians at the same x:
        # the path at the last x is kept.
        self._last: tuple[np.ndarray, tuple] | None = None
        self._boxset = _box_set(self.boxes) if self.boxes else None

    @property
    def min_speed(self) -> float:
        """Half the smaller of the current and the final speed (see :func:`limit_margins`)."""
        return 0.5 * min(float(np.linalg.norm(self.v0)), float(np.linalg.norm(self.bc.vf)))

    def unpack(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        return float(x[0]), x[1:].reshape(-1, 3)

    def path(self, x):
        if self._last is not None and np.array_equal(self._last[0], x):
            return self._last[1]
        t_go, c = self.unpack(x)
        b = self.basis
        out = _path_from(b.herm, b.corr, t_go, self.r0, self.v0, self.bc.rf, self.bc.vf, c)
        self._last = (np.array(x, dtype=np.float64), out)
        return out

    def path_dt(self, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """d/dT of position, velocity and acceleration at the nodes (fixed ``s``): ``T``
        enters through the end slopes ``T v0``, ``T v_f`` and the ``1/T^k`` of d^k/dt^k."""
        t_go, _ = self.unpack(x)
        _, v, a = self.path(x)
        h = self.basis.herm
        slope = [h[k][1][:, None] * self.v0 + h[k][3][:, None] * self.bc.vf for k in range(3)]
        return slope[0], (slope[1] - v) / t_go, slope[2] / t_go**2 - 2.0 * a / t_go

    def cost(self, x) -> float:
        """Eq 20 by Gauss-Legendre quadrature on [0, T]."""
        t_go, _ = self.unpack(x)
        r, _, a = self.path(x)
        return float(t_go * (self.basis.weights * self._integrand(r, a)).sum())

    def _integrand(self, r, a):
        w = self.field.weights
        return w.zeta + 0.5 * (1.0 - w.zeta) * (
            w.alpha * (a**2).sum(axis=1)
            + w.mu * (r[:, 2] - w.z_ref) ** 2
            - w.beta * self.field.sum_sq_distance(r)
        )

    def _chain(self, t_go, idx, g_r, g_v=None, g_a=None) -> np.ndarray:
        """d(row)/dc for rows that each depend on one sample ``idx[row]`` through
        per-row gradients (rows, 3) in r, v and a; returns (rows, 3m)."""
        b = self.basis
        jac = b.corr[0][:, idx].T[:, :, None] * g_r[:, None, :]
        if g_v is not None:
            jac += (b.corr[1][:, idx].T / t_go)[:, :, None] * g_v[:, None, :]
        if g_a is not None:
            jac += (b.corr[2][:, idx].T / t_go**2)[:, :, None] * g_a[:, None, :]
        return jac.reshape(len(idx), -1)

    def cost_grad(self, x) -> np.ndarray:
        t_go, _ = self.unpack(x)
        r, _, a = self.path(x)
        w = self.field.weights
        wq = self.basis.weights[:, None]
        g_a = t_go * wq * (1.0 - w.zeta) * w.alpha * a
        g_r = -t_go * wq * (1.0 - w.zeta) * w.beta * self.field.n * (r - self.field.mean)
        g_r[:, 2] += t_go * self.basis.weights * (1.0 - w.zeta) * w.mu * (r[:, 2] - w.z_ref)
        idx = np.arange(len(r))
        grad_c = self._chain(t_go, idx, g_r, None, g_a).sum(axis=0)
        # J = T Σ w L(r, a): dJ/dT = J/T + Σ T w (∂L/∂r dr/dT + ∂L/∂a da/dT)
        dr, _, da = self.path_dt(x)
        grad_t = self.cost(x) / t_go + float((g_r * dr).sum() + (g_a * da).sum())
        return np.concatenate([[grad_t], grad_c])

    def clearances(self, x) -> np.ndarray:
        """Signed distance of every sample to every extent, (samples, boxes)."""
        r, _, _ = self.path(x)
        if self._boxset is None:  # no extents (the braking stop): nothing to keep from
            return np.empty((len(r), 0))
        return self._boxset.signed_distance(r)

    def clearance_margin(self, x) -> np.ndarray:
        return (self.clearances(x) - self.need_ft).ravel()

    def clearance_jac(self, x) -> np.ndarray:
        t_go, _ = self.unpack(x)
        r, _, _ = self.path(x)
        n, k = len(r), len(self.boxes)
        g = self._boxset.signed_distance_gradient(r)  # n,k,3
        # rows ordered (sample, box) like clearance_margin's ravel
        jac_c = self._chain(t_go, np.repeat(np.arange(n), k), g.reshape(n * k, 3))
        dr, _, _ = self.path_dt(x)
        jac_t = (g * dr[:, None, :]).sum(axis=-1).ravel()
        return np.column_stack([jac_t, jac_c])

    def other_margins(self, x) -> np.ndarray:
        r, v, a = self.path(x)
        lim = limit_margins(v, a, self.params, self.cfg, self.min_speed)
        return np.concatenate([lim.T.ravel(), r[:, 2]])

    def other_jac(self, x) -> np.ndarray:
        t_go, _ = self.unpack(x)
        r, v, a = self.path(x)
        n = len(r)
        eye = np.eye(3)
        nl = 6
        # central differences per sample and axis, all in one vectorised call:
        # blocks (axis, [v+, v-, a+, a-]) of n rows each
        hv = 1e-6 * np.maximum(np.abs(v), 1.0)  # (n, 3)
        ha = 1e-6 * np.maximum(np.abs(a), 1.0)
        vs, acc = [], []
        for ax in range(3):
            dv, da = hv[:, ax : ax + 1] * eye[ax], ha[:, ax : ax + 1] * eye[ax]
            vs += [v + dv, v - dv, v, v]
            acc += [a, a, a + da, a - da]
        lm = limit_margins(
            np.concatenate(vs), np.concatenate(acc), self.params, self.cfg, self.min_speed
        ).reshape(3, 4, n, nl)
        g_v = np.empty((nl, n, 3))
        g_a = np.empty((nl, n, 3))
        for ax in range(3):
            g_v[:, :, ax] = ((lm[ax, 0] - lm[ax, 1]) / (2 * hv[:, ax : ax + 1])).T
            g_a[:, :, ax] = ((lm[ax, 2] - lm[ax, 3]) / (2 * ha[:, ax : ax + 1])).T
        idx = np.tile(np.arange(n), nl)  # rows ordered (limit, sample) like lim.T.ravel
        zero = np.zeros((nl * n, 3))
        jac_lim = self._chain(t_go, idx, zero, g_v.reshape(nl * n, 3), g_a.reshape(nl * n, 3))
        jac_z = self._chain(t_go, np.arange(n), np.tile([0.0, 0.0, 1.0], (n, 1)))
        dr, dv, da = self.path_dt(x)
        jac_t = np.concatenate(
            [((g_v * dv).sum(axis=-1) + (g_a * da).sum(axis=-1)).ravel(), dr[:, 2]]
        )
        return np.column_stack([jac_t, np.vstack([jac_lim, jac_z])])


def _solve(prob: _Problem, x0: np.ndarray, relaxed: bool) -> tuple[np.ndarray, object]:
    """SLSQP on the programme; ``relaxed`` maximises the smallest clearance instead."""
    lo, hi = prob.t_bounds
    n = len(x0)
    opts = {"maxiter": prob.cfg.maxiter, "ftol": prob.cfg.ftol}
    if relaxed:
        # variables [T, c..., slack]: maximise slack s with clearance - need >= s.
        x_init = np.concatenate([x0, [float(prob.clearance_margin(x0).min(initial=0.0))]])
        bounds = [(lo, hi)] + [(None, None)] * (n - 1) + [(None, 0.0)]

        def slack_jac(y, jac):
            j = jac(y[:-1])
            return np.column_stack([j, np.full(len(j), -1.0)])

        cons = [
            {
                "type": "ineq",
                "fun": lambda y: prob.clearance_margin(y[:-1]) - y[-1],
                "jac": lambda y: slack_jac(y, prob.clearance_jac),
            },
            {
                "type": "ineq",
                "fun": lambda y: prob.other_margins(y[:-1]),
                "jac": lambda y: np.column_stack(
                    [prob.other_jac(y[:-1]), np.zeros(len(prob.other_margins(y[:-1])))]
                ),
            },
        ]
        scale = max(abs(prob.cost(x0)), 1.0)
        res = minimize(
            lambda y: -y[-1] + 1e-3 * prob.cost(y[:-1]) / scale,
            x_init,
            jac=lambda y: np.concatenate([1e-3 * prob.cost_grad(y[:-1]) / scale, [-1.0]]),
            method="SLSQP",
            bounds=bounds,
            constraints=cons,
            options=opts,
        )
        return res.x[:-1], res
    bounds = [(lo, hi)] + [(None, None)] * (n - 1)
    cons = [{"type": "ineq", "fun": prob.other_margins, "jac": prob.other_jac}]
    if prob.boxes:
        cons.append({"type": "ineq", "fun": prob.clearance_margin, "jac": prob.clearance_jac})
    res = minimize(
        prob.cost, x0, jac=prob.cost_grad, method="SLSQP", bounds=bounds, constraints=cons,
        options=opts,
    )  # fmt: skip
    return res.x, res


def _meets(prob: _Problem, x: np.ndarray, floor: np.ndarray, tol: float = 1e-3) -> bool:
    """Within the limits and at least ``floor`` (per extent) from every extent: the
    required clearance (the planning margin is slack for the closed loop, not part of
    the requirement) or, for a best-effort plan, what the end points leave."""
    cm = prob.clearances(x) - floor
    return bool(
        np.all(np.isfinite(x))
        and (cm.size == 0 or cm.min() >= -tol)
        and prob.other_margins(x).min() >= -tol
    )


def _fit_coeffs(prob: _Problem, t_go: float, target: np.ndarray) -> np.ndarray:
    """Least-squares correction coefficients that bring the path closest to ``target``
    (positions at the basis nodes for this ``t_go``)."""
    b = prob.basis
    ends = np.stack([prob.r0, t_go * prob.v0, prob.bc.rf, t_go * prob.bc.vf])
    resid = target - b.herm[0].T @ ends
    coeffs, *_ = np.linalg.lstsq(b.corr[0].T, resid, rcond=None)
    return coeffs


def _report_seed(prob: _Problem) -> tuple[float, np.ndarray]:
    """The report's extremal from the current state (eqs 37-52 at eq 55's time-to-go)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoTransversalityRootWarning)
        ttg = solve_time_to_go(prob.r0, prob.v0, prob.bc, prob.field)
    t_go = float(np.clip(ttg.t_go, *prob.t_bounds))
    sol = open_loop_solution(prob.r0, prob.v0, t_go, prob.bc, prob.field)
    target = sol.derivative(prob.basis.s * t_go, 0)
    return t_go, _fit_coeffs(prob, t_go, target)


def _side_seeds(prob: _Problem, t_go: float, coeffs: np.ndarray, amplitude: float):
    """The seed bent sideways (horizontal normal to the start-goal line) both ways."""
    d = prob.bc.rf[:2] - prob.r0[:2]
    nrm = np.array([-d[1], d[0], 0.0]) / max(np.hypot(*d), 1e-9)
    s = prob.basis.s
    bump = (16.0 * s**2 * (1 - s) ** 2)[:, None] * nrm  # 1 at mid-path
    r_seed, _, _ = prob.path(np.concatenate([[t_go], coeffs.ravel()]))
    for sign in (1.0, -1.0):
        yield _fit_coeffs(prob, t_go, r_seed + sign * amplitude * bump)


def plan_trajectory(
    r0: np.ndarray,
    v0: np.ndarray,
    bc: BoundaryConditions,
    field: ObstacleField,
    boxes: tuple[ObstacleBox, ...],
    *,
    params: VehicleParams | None = None,
    config: AvoidConfig | None = None,
    warm: AvoidPlan | None = None,
    t0: float = 0.0,
    t_go_max: float | None = None,
    relax: bool = True,
    side_seeds: bool = True,
    report_seed: bool = True,
) -> AvoidPlan:
    """Solve the programme of the module docstring once, from ``(r0, v0)`` at ``t0``.

    Seeds, in order: ``warm`` (the previous plan, resampled from ``t0``) if given, else
    the report's extremal; if the result is not feasible, that seed bent sideways by
    ``±(clearance + half the largest obstacle)`` and the report's extremal. If the start
    or the touch-down point is within the clearance of an extent, the plan is a best
    effort (``feasible=False``): the full clearance from the other extents, from those
    the end point's own distance less 10 % (at least 0.5 ft). If no seed meets what is
    asked, the relaxed programme (largest smallest-clearance within the limits) gives
    the plan, with ``feasible=False`` unless it still meets the clearance; with
    ``relax=False`` (the caller has a safe manoeuvre to fall back on) the relaxed
    programme is not solved and the lowest-cost result of the seeds is returned,
    ``feasible=False``. ``meets_floor`` says whether the plan met what was asked.
    ``side_seeds=False`` skips the bent seeds, ``report_seed=False`` (with ``warm``) the
    report's extremal too.
    """
    params = params or VehicleParams()
    cfg = config or AvoidConfig()
    r0 = np.asarray(r0, dtype=np.float64)
    v0 = np.asarray(v0, dtype=np.float64)
    t_sing = 0.98 * FIRST_SINGULAR_SIGMA_T / float(field.sigma.max())
    hi = min(t_sing, t_go_max) if t_go_max else t_sing
    boxes = tuple(boxes)
    ends = np.stack([r0, bc.rf])
    end_clear = _clearances(ends, boxes).min(axis=0)  # per box
    # The planning margin, per box, only as far as the end points leave room for it:
    # a touch-down point 21 ft from an extent admits a 20 ft clearance but not 20 + 1
    # everywhere (the programme would be infeasible and SLSQP would wander).
    need = cfg.clearance_ft + np.clip(0.5 * (end_clear - cfg.clearance_ft), 0.0, cfg.margin_ft)
    # An end point within the clearance of an extent makes the layout infeasible. Best
    # effort then still keeps the full clearance from every other extent and, from
    # those, as much as the end point leaves (10 % and at least 0.5 ft less than its
    # own distance, so that a path can reach it) near that end only: the floor rises
    # to the full clearance over the first (last) ESCAPE_TIME_S of the path (at the
    # report seed's time-to-go; at most half the path), so the path moves away from
    # (approaches) the extent instead of running along it.
    ends_inside = bool(boxes) and float(end_clear.min()) < cfg.clearance_ft
    basis = _basis(cfg.n_samples, cfg.n_basis)
    floor = np.full((len(basis.s), len(boxes)), cfg.clearance_ft)
    need = np.broadcast_to(need, floor.shape).copy()
    prob = _Problem(r0, v0, bc, field, boxes, params, cfg, basis, (0.05, hi), need)
    t_rep, c_rep = _report_seed(prob)
    if ends_inside:
        dist = _clearances(ends, boxes)  # (2, boxes): start, touch-down
        lo = _escape_floor(dist)
        s_ramp = min(max(ESCAPE_TIME_S / t_rep, 0.02), 0.5)
        ramps = np.clip(np.stack([basis.s, 1.0 - basis.s]) / s_ramp, 0.0, 1.0) ** 2
        for end in range(2):
            close = dist[end] < cfg.clearance_ft
            ramp = ramps[end][:, None]
            need = np.where(close, np.minimum(need, lo[end] + (need - lo[end]) * ramp), need)
            floor = np.where(close, np.minimum(floor, lo[end] + (floor - lo[end]) * ramp), floor)
        prob.need_ft = need
    start = time.perf_counter()
    seeds: list[np.ndarray] = []
    if warm is not None:
        remaining = max(warm.t_go - (t0 - warm.t0), 0.1)
        t_go = float(np.clip(remaining, 0.05, hi))
        tau = (t0 - warm.t0) + prob.basis.s * t_go
        target, _, _ = warm.evaluate(tau)
        seeds.append(np.concatenate([[t_go], _fit_coeffs(prob, t_go, target).ravel()]))
    x_rep = np.concatenate([[t_rep], c_rep.ravel()])
    if report_seed or not seeds:
        seeds.append(x_rep)
    amp = cfg.clearance_ft + max((max(b.half_u, b.half_v) for b in boxes), default=0.0)
    if side_seeds:
        seeds += [
            np.concatenate([[t_rep], c.ravel()]) for c in _side_seeds(prob, t_rep, c_rep, amp)
        ]
    best, best_res, iters = None, None, 0
    unmet: tuple[np.ndarray, object] | None = None  # the first seed's result, not acceptable
    for k, x0 in enumerate(seeds):
        x, res = _solve(prob, x0, relaxed=False)
        iters += int(getattr(res, "nit", 0))
        if _meets(prob, x, floor):
            if best is None or prob.cost(x) < prob.cost(best):
                best, best_res = x, res
            if k == 0 or warm is None:
                break  # the first acceptable solution from the preferred seed
        elif unmet is None and np.all(np.isfinite(x)):
            unmet = (x, res)
    if best is None and not relax:  # the caller falls back on a safe manoeuvre
        best, best_res = unmet if unmet is not None else (x_rep, None)
    if best is None:  # the relaxed programme: the largest smallest clearance
        best, best_res = _solve(prob, x_rep, relaxed=True)
        iters += int(getattr(best_res, "nit", 0))
    # Feasible: the required clearance from every extent within the limits (the
    # largest smallest clearance may still meet it).
    meets_floor = _meets(prob, best, floor)
    feasible = not ends_inside and meets_floor
    t_go, c = prob.unpack(best)
    cm = prob.clearances(best)
    min_clear = float(cm.min()) if cm.size else math.inf
    limits_ok = bool(prob.other_margins(best).min() >= -1e-3)
    floor_margin = float((cm - floor).min()) if cm.size else math.inf
    return AvoidPlan(
        t0, t_go, r0, v0, bc.rf.copy(), bc.vf.copy(), c, feasible, min_clear, limits_ok,
        time.perf_counter() - start, iters, str(getattr(best_res, "message", "")), meets_floor,
        floor_margin,
    )  # fmt: skip


#: Top (ft) given to an extent whose clearance holds the start of an escape, and depth
#: below the ground of its base (:func:`escape_walls`): far above any flight and far
#: below the ground, so that only its sides count.
WALL_TOP_FT: float = 1.0e4


def escape_walls(
    boxes: tuple[ObstacleBox, ...], r: np.ndarray, clearance_ft: float
) -> tuple[ObstacleBox, ...]:
    """``boxes`` with the extents whose clearance holds ``r`` made walls (top
    :data:`WALL_TOP_FT`): an escape from within an extent's clearance must leave it
    sideways. With the extent's top counted, the nearest way out of a long P1 extent
    whose footprint holds the start is up through its top (a few feet away), and the
    escape plans climbed there -- at most 0.09 g up (the load-factor limit) -- while
    passing a true vehicle inside the extent at 18.7 ft, 3 ft above its roof (runway/P1
    stress0-10, issue 39; 26.8 ft leaving sideways). The wall reaches below the ground
    too: with its base on the ground, a start inside its footprint 7 ft up is 7 ft from
    the bottom face, the floor of every escape began there (-7.7 ft, rising to the
    clearance in :data:`ESCAPE_TIME_S`), no escape could reach its sides in time and
    the law braked straight ahead along the extent, to a hover 16.5 ft from the
    vehicle inside it (runway-p1 shifted by (-79.935, 376.446) ft, issue 39). The other
    boxes are returned as they are."""
    if not boxes:
        return boxes
    d = _clearances(np.asarray(r, dtype=np.float64)[None], boxes)[0]
    return tuple(
        replace(b, top=WALL_TOP_FT, base=-WALL_TOP_FT) if dk < clearance_ft else b
        for b, dk in zip(boxes, d, strict=True)
    )


def _escape_floor(dist: np.ndarray) -> np.ndarray:
    """The floor a plan from an end point ``dist`` ft from each extent keeps near that
    end (its own distance less 10 %, at least 0.5 ft less: a path can leave it)."""
    dist = np.asarray(dist, dtype=np.float64)
    return dist - np.maximum(0.1 * np.abs(dist), 0.5)


# --------------------------------------------------------------------------- safe manoeuvres


@dataclass(frozen=True)
class SafeManoeuvre:
    """A safe manoeuvre the law took because no path to the touch-down keeps the
    clearance: ``kind`` (one of :data:`MANOEUVRES`), the hold point and velocity it flies
    to (``goal``, whose ``r0``/``v0`` are the state it was decided from), its plan, the
    time it was decided and how many candidates were tried."""

    kind: str
    goal: BoundaryConditions
    plan: AvoidPlan
    decided_at_s: float
    candidates_tried: int
    keeps_floor: bool = True  # False: no candidate kept it; the one that came closest

    @property
    def outcome(self) -> str:
        """``hover`` (held short of the obstacles, or braked to a stop) or ``go-around``
        (climbed over or turned away, then held)."""
        return "hover" if self.kind in ("hover", "stop") else "go-around"

    def to_dict(self) -> dict:
        return {
            "kind": self.kind,
            "outcome": self.outcome,
            "hold_point_ft": [float(c) for c in self.goal.rf],
            "hold_velocity_ft_s": [float(c) for c in self.goal.vf],
            "decided_at_s": self.decided_at_s,
            "candidates_tried": self.candidates_tried,
            "planned_min_clearance_ft": self.plan.min_clearance_ft,
            "keeps_clearance_floor": self.keeps_floor,
        }


def manoeuvre_candidates(
    r: np.ndarray,
    v: np.ndarray,
    boxes: tuple[ObstacleBox, ...],
    cfg: AvoidConfig,
) -> list[tuple[str, np.ndarray]]:
    """Hold points of the safe manoeuvres from position ``r`` flying at ``v``, in the order
    they are tried: decelerate to a hover ahead on the present track (150, 100, 220 ft);
    climb over (to ``clearance + margin + 2`` ft above the highest extent, 150 or 250 ft
    ahead); turn away (150 ft at ±90° and ±135° from the track, at the present altitude,
    then at the climb height). When ``r`` lies within the clearance of an extent, points
    *away* from it come first (:func:`escape_direction`: 100, 150, 220 ft along it and
    along its bisector with the track; ``hover`` within 45° of the track, else
    ``turn-away``; then ``climb`` along it). Only points at least ``clearance + margin +
    2`` ft from every extent are returned (the hold point must itself keep the
    clearance)."""
    speed_h = float(np.hypot(v[0], v[1]))
    ahead = np.array([v[0], v[1], 0.0]) / speed_h if speed_h > 1e-6 else np.array([1.0, 0, 0])
    side = np.array([-ahead[1], ahead[0], 0.0])
    top = max((b.top for b in boxes), default=0.0)
    z_hold = max(float(r[2]), 5.0)
    z_over = max(z_hold, top + cfg.clearance_ft + cfg.margin_ft + 2.0)
    cands: list[tuple[str, np.ndarray]] = []
    away = escape_direction(r, boxes, cfg.clearance_ft)
    if away is not None:
        bisector = away + ahead
        dirs = [away] if np.linalg.norm(bisector) < 1e-6 else [bisector, away]
        for u in dirs:
            u = u / np.linalg.norm(u)
            kind = "hover" if float(u @ ahead) >= math.cos(math.radians(45.0)) else "turn-away"
            for d in (150.0, 100.0, 220.0):
                cands.append((kind, np.array([*(r[:2] + d * u[:2]), z_hold])))
        for d in (150.0, 220.0):
            cands.append(("climb", np.array([*(r[:2] + d * away[:2]), z_over])))
    for d in (150.0, 100.0, 220.0):
        cands.append(("hover", np.array([*(r[:2] + d * ahead[:2]), z_hold])))
    for d in (150.0, 250.0):
        cands.append(("climb", np.array([*(r[:2] + d * ahead[:2]), z_over])))
    for z in (z_hold, z_over):
        for deg in (90.0, -90.0, 135.0, -135.0):
            a = math.radians(deg)
            p = r[:2] + 150.0 * (math.cos(a) * ahead[:2] + math.sin(a) * side[:2])
            cands.append(("turn-away", np.array([*p, z])))
    need = cfg.clearance_ft + cfg.margin_ft + 2.0
    return [(k, p) for k, p in cands if not boxes or _clearances(p[None], boxes).min() >= need]


def escape_direction(
    r: np.ndarray, boxes: tuple[ObstacleBox, ...], clearance_ft: float
) -> np.ndarray | None:
    """The horizontal unit direction away from the footprints of the extents whose
    clearance ``r`` lies within (each footprint's outward normal at its nearest side,
    weighted by how far inside the clearance ``r`` is), or ``None`` when ``r`` keeps the
    clearance from all. Inside a long along-ray extent this points out of its nearest
    long side, across the ray (never up: a climb is a candidate of its own)."""
    if not boxes:
        return None
    r = np.asarray(r, dtype=np.float64)
    d = _clearances(r[None], boxes)[0]
    u = np.zeros(2)
    for box, dk in zip(boxes, d, strict=True):
        if dk >= clearance_ft:
            continue
        pu, pv, _ = box.local(r)
        out = np.array([abs(pu) - box.half_u, abs(pv) - box.half_v])
        if out.max() <= 0:  # inside the footprint: out of the nearest side
            # (on the centre line either side will do: copysign takes +0 as +1)
            u_side, v_side = math.copysign(1.0, pu), math.copysign(1.0, pv)
            g = np.array([u_side, 0.0]) if out[0] > out[1] else np.array([0.0, v_side])
        else:  # outside: along the footprint's distance gradient
            g = np.maximum(out, 0.0) * np.sign([pu, pv])
        g = g / max(float(np.linalg.norm(g)), 1e-12)
        u += (clearance_ft - dk) * (g @ box.axes)
    n = float(np.linalg.norm(u))
    return np.array([u[0] / n, u[1] / n, 0.0]) if n > 1e-9 else None


def _chord_clearance(
    r: np.ndarray, point: np.ndarray, boxes, clearance_ft: float, speed: float
) -> float:
    """The smallest margin of the straight chord from ``r`` to ``point`` over the floor a
    plan from ``r`` must keep (:func:`plan_trajectory`: the clearance, rising to it over
    the first ``ESCAPE_TIME_S`` from what a start within it leaves, at the chord's
    straight-line time): a geometric test,
    before any solve, of whether a hold point is reachable without bending the path
    round an extent."""
    s = np.linspace(0.0, 1.0, 33)[:, None]
    chord = r[None] + s * (point - r)[None]
    start = _clearances(r[None], boxes)[0]
    lo = np.minimum(_escape_floor(start), clearance_ft)
    t_chord = float(np.linalg.norm(point - r)) / max(speed, 1.0)
    s_ramp = min(max(ESCAPE_TIME_S / max(t_chord, 1e-9), 0.02), 0.5)
    floor = lo + (clearance_ft - lo) * np.clip(s / s_ramp, 0.0, 1.0) ** 2
    return float((_clearances(chord, boxes) - floor).min())


#: β of a manoeuvre's cost (eq 20 without its obstacle term, in effect): the report's
#: −β Σ|r − r_i|² rewards distance from the obstacle points without bound, and with a
#: free hold point instead of a fixed touch-down the plan wandered hundreds of feet
#: away (measured on a synthetic layout); the clearance constraints keep it safe.
MANOEUVRE_BETA: float = 1e-12


def _hold_field(field: ObstacleField) -> ObstacleField:
    """The obstacle field of a manoeuvre's cost: the same points and weights, β tiny."""
    return ObstacleField(field.points, replace(field.weights, beta=MANOEUVRE_BETA))


def plan_safe_manoeuvre(
    r: np.ndarray,
    v: np.ndarray,
    field: ObstacleField,
    boxes: tuple[ObstacleBox, ...],
    *,
    hold_speed: float = 1.0,
    params: VehicleParams | None = None,
    config: AvoidConfig | None = None,
    t0: float = 0.0,
    closest_if_none: bool = False,
) -> SafeManoeuvre | None:
    """The first safe manoeuvre (:func:`manoeuvre_candidates`) whose plan keeps the
    clearance from every extent within the limits, ending at its hold point at
    ``hold_speed`` ft/s (the point-mass model, eqs 2-3, needs ``V > 0``: the hold begins
    there). The plan is the programme of the module docstring with the hold point as
    its final state. If ``r`` itself is within the clearance of an extent, a plan is
    accepted when it keeps what the start leaves (never closer than it already is, less
    10 %, at least 0.5 ft).

    From such a start, candidates whose straight chord keeps that floor
    (:func:`_chord_clearance`, a geometric test) are solved first, in their order; the
    others after them (elsewhere the order is the least departure first). ``None``
    when no candidate has such a plan, unless ``closest_if_none``: then of the braking
    stop (:func:`plan_braking_stop`) and the candidate least short of that floor
    (within the limits first), the one whose path and hold point come less short of
    the clearance (:func:`_stop_margin`; the stop on a tie, the candidate if no stop is
    within the limits); flagged (the caller reports it; never a landing)."""
    params = params or VehicleParams()
    cfg = config or AvoidConfig()
    # A hold point is a short, open target: a plan that keeps the clearance converges
    # from the report's seed in tens of iterations; a candidate that does not is
    # dropped after one seed and MANOEUVRE_MAXITER iterations, not three seeds of
    # ``maxiter`` each (the candidates are tried in turn).
    solve_cfg = replace(cfg, maxiter=min(cfg.maxiter, MANOEUVRE_MAXITER))
    r = np.asarray(r, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    hold = _hold_field(field)
    cands = manoeuvre_candidates(r, v, boxes, cfg)
    walls = escape_walls(boxes, r, cfg.clearance_ft)
    if walls != boxes:  # a hold point must keep the clearance from the walls too
        need = cfg.clearance_ft + cfg.margin_ft + 2.0
        cands = [(k, p) for k, p in cands if _clearances(p[None], walls).min() >= need]
    if cands and escape_direction(r, boxes, cfg.clearance_ft) is not None:
        speed = float(np.linalg.norm(v))
        ok = [_chord_clearance(r, p, walls, cfg.clearance_ft, speed) >= 0.0 for _, p in cands]
        cands = [c for c, k in zip(cands, ok, strict=True) if k] + [
            c for c, k in zip(cands, ok, strict=True) if not k
        ]
    tried = 0
    closest: SafeManoeuvre | None = None
    for kind, point in cands:
        chord = point - r
        chord[2] = 0.0
        n = float(np.linalg.norm(chord))
        vf = hold_speed * (chord / n if n > 1e-6 else v / np.linalg.norm(v))
        goal = BoundaryConditions(r0=r, v0=v, rf=point, vf=vf)
        tried += 1
        plan = plan_trajectory(
            r, v, goal, hold, walls, params=params, config=solve_cfg, t0=t0, relax=False,
            side_seeds=False, t_go_max=MANOEUVRE_MAX_TIME,
        )  # fmt: skip
        if plan.meets_floor:
            return SafeManoeuvre(kind, goal, plan, t0, tried)
        if closest_if_none and np.isfinite(plan.floor_margin_ft):
            # within the limits first (the limiter bounds the flown commands either way),
            # then the least short of the floor (the start's own distance ties them all)
            key = (plan.limits_ok, plan.floor_margin_ft)
            if closest is None or key > (closest.plan.limits_ok, closest.plan.floor_margin_ft):
                closest = SafeManoeuvre(kind, goal, plan, t0, tried, keeps_floor=False)
    if closest is not None:
        # Of the braking stop and the candidate least short of its floor, the one whose
        # path and hold point come less short of the clearance (as far as the start
        # leaves it: :func:`_stop_margin`), the stop on a tie. Braking straight ahead
        # along a long P1 extent that holds the start ends inside it, where a vehicle
        # may stand: runway-p1 shifted by (-79.935, 376.446) ft held 16.5 ft from one
        # (margin -24.3 ft; a turn-away to a hold point clear of every extent, -20.2 ft).
        stop = plan_braking_stop(
            r, v, field, boxes, hold_speed=hold_speed, params=params, config=cfg, t0=t0
        )
        pick = closest
        if stop is not None:
            near = _stop_margin(closest.plan, r, boxes, cfg.clearance_ft)[0]
            if stop.keeps_floor or stop.plan.floor_margin_ft >= near:
                pick = stop
        return replace(pick, candidates_tried=tried)
    return None


def stopping_distance(speed: float, config: AvoidConfig | None = None) -> float:
    """Distance (ft) to stop from ``speed`` ft/s at constant altitude at the largest
    deceleration within the pitch limit less its back-off, ``g tan((1 - backoff)
    θ_max)`` (10.45 ft/s² by default: 69 ft from the report's 38 ft/s; its load factor,
    1.05, is within the 1.1 limit)."""
    cfg = config or AvoidConfig()
    decel = G_FT_S2 * math.tan(math.radians((1.0 - cfg.limit_backoff) * cfg.max_theta_deg))
    return float(speed) ** 2 / (2.0 * decel)


def plan_braking_stop(
    r: np.ndarray,
    v: np.ndarray,
    field: ObstacleField,
    boxes: tuple[ObstacleBox, ...],
    *,
    hold_speed: float = 1.0,
    params: VehicleParams | None = None,
    config: AvoidConfig | None = None,
    t0: float = 0.0,
) -> SafeManoeuvre | None:
    """The braking stop: decelerate straight ahead, at the present altitude, to a hover
    :data:`STOP_DISTANCE_FACTORS` × the :func:`stopping_distance` ahead (the first whose
    plan is within the limits; ``None`` if none is). Considered when no safe manoeuvre keeps
    its clearance floor: no plan then certifies the clearance, the distance to an extent
    no longer bounds the distance to the object inside it (a P1 extent runs 86-480 ft
    along its ray), and the least of the map a rotorcraft can cross is the stretch it
    needs to stop. The candidate least short of its floor went further: runway/P1
    stress0-13 passed Vehicle 3 at 18.58 ft climbing over its extent; the stop holds
    30 ft short of it (issue 39). Planned on the limits alone; its path and hold point
    are then checked against ``boxes`` (:func:`_stop_margin`: ``floor_margin_ft``, and
    ``keeps_floor`` when that is ``>= 0``)."""
    params = params or VehicleParams()
    cfg = config or AvoidConfig()
    r = np.asarray(r, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    speed = float(np.hypot(v[0], v[1]))
    ahead = np.array([v[0], v[1], 0.0]) / speed if speed > 1e-6 else np.array([1.0, 0, 0])
    d_stop = max(stopping_distance(speed, cfg), 5.0)
    hold = _hold_field(field)
    for k, factor in enumerate(STOP_DISTANCE_FACTORS, 1):
        point = r + factor * d_stop * ahead
        goal = BoundaryConditions(r0=r, v0=v, rf=point, vf=hold_speed * ahead)
        plan = plan_trajectory(
            r, v, goal, hold, (), params=params, config=cfg, t0=t0, relax=False,
            side_seeds=False, t_go_max=MANOEUVRE_MAX_TIME,
        )  # fmt: skip
        if not plan.limits_ok:
            continue
        margin, clear = _stop_margin(plan, r, boxes, cfg.clearance_ft)
        plan = replace(
            plan, feasible=False, meets_floor=margin >= 0.0, min_clearance_ft=clear,
            floor_margin_ft=margin,
        )  # fmt: skip
        return SafeManoeuvre("stop", goal, plan, t0, k, keeps_floor=margin >= 0.0)
    return None


def _stop_margin(
    plan: AvoidPlan, r: np.ndarray, boxes: tuple[ObstacleBox, ...], clearance_ft: float
) -> tuple[float, float]:
    """``(margin, smallest clearance)`` of a braking stop's plan from ``r``: the margin is
    the least, over the extents, of its path's distance beyond the floor of an escape
    from ``r`` (the clearance, or what ``r`` leaves of it less 10 %: the stop may not go
    deeper than it starts) and of its hold point's beyond the full clearance (it hovers
    there). ``>= 0``: the stop keeps the clearance as far as the start allows."""
    if not boxes:
        return math.inf, math.inf
    path = plan.evaluate(np.linspace(0.0, plan.t_go, 65))[0]
    d = _clearances(path, boxes)  # (samples, boxes)
    floor = np.minimum(_escape_floor(_clearances(r[None], boxes)[0]), clearance_ft)
    margin = min(float((d - floor).min()), float(d[-1].min()) - clearance_ft)
    return margin, float(d.min())


def _decide(
    r, v, bc, field, boxes, params, av, t0: float = 0.0, *, closest_if_none: bool = True
) -> tuple[AvoidPlan, SafeManoeuvre | None, str]:
    """The first plan: to the touch-down if one keeps the clearance, else a safe
    manoeuvre (``when_blocked="manoeuvre"``), else (``"best-effort"``) the best-effort
    landing (flagged); and why the landing was blocked (``""`` when it was not).

    A start within the clearance of an extent blocks the landing: no plan from it keeps
    the clearance, and a landing on one that keeps only what the start leaves passed
    true vehicles at 2.9-7.4 ft (issue 39, stress0-10/-18/-19). The law then moves
    away first (a manoeuvre that keeps what the start leaves) and re-decides from its
    hold point (:func:`simulate_avoid`)."""
    blocked_ok = av.when_blocked == "best-effort"
    td_clear = float(_clearances(bc.rf[None], boxes).min()) if boxes else math.inf
    start_clear = float(_clearances(r[None], boxes).min()) if boxes else math.inf
    landing = None
    if blocked_ok or (td_clear >= av.clearance_ft and start_clear >= av.clearance_ft):
        landing = plan_trajectory(
            r, v, bc, field, boxes, params=params, config=av, relax=blocked_ok, t0=t0
        )
        if landing.feasible:
            return landing, None, ""
        why = "no plan to the touch-down keeps the clearance within the limits"
        if blocked_ok:
            return landing, None, why
    elif td_clear < av.clearance_ft:
        why = f"the touch-down point is {td_clear:.1f} ft from an extent"
    else:
        why = f"the start is {start_clear:.1f} ft from an extent"
    man = plan_safe_manoeuvre(
        r, v, field, boxes, hold_speed=float(np.linalg.norm(bc.vf)), params=params, config=av,
        t0=t0, closest_if_none=closest_if_none,
    )  # fmt: skip
    if man is not None:
        if man.kind == "stop":
            why += "; no safe manoeuvre keeps it either: braking to a stop"
        elif not man.keeps_floor:
            why += "; no safe manoeuvre keeps it either: the one that comes closest"
        return man.plan, man, why
    # No hold point keeps clearance + margin + 2 ft (no candidate at all): the braking
    # stop (flagged); never the landing.
    stop = plan_braking_stop(
        r, v, field, boxes, hold_speed=float(np.linalg.norm(bc.vf)), params=params, config=av,
        t0=t0,
    )  # fmt: skip
    if stop is not None:
        return stop.plan, stop, why + "; no hold point keeps the clearance: braking to a stop"
    kind, point = "hover", np.array([*(r[:2] + 150.0 * v[:2] / max(np.hypot(*v[:2]), 1e-9)), r[2]])
    chord = point - r
    vf = float(np.linalg.norm(bc.vf)) * chord / float(np.linalg.norm(chord))
    goal = BoundaryConditions(r0=r, v0=v, rf=point, vf=vf)
    plan = plan_trajectory(
        r, v, goal, _hold_field(field), boxes, params=params, config=av, t0=t0,
        t_go_max=MANOEUVRE_MAX_TIME,
    )  # fmt: skip
    man = SafeManoeuvre(kind, goal, plan, t0, 0, keeps_floor=False)
    return plan, man, why + "; no hold point keeps the clearance: straight ahead to a hover"


# --------------------------------------------------------------------------- closed loop


def simulate_avoid(
    bc: BoundaryConditions,
    field: ObstacleField,
    boxes: tuple[ObstacleBox, ...],
    params: VehicleParams | None = None,
    config: SimulationConfig | None = None,
    avoid: AvoidConfig | None = None,
) -> SimulationResult:
    """Fly the avoiding law in closed loop on the nonlinear model (module docstring).

    ``field`` carries the report's weights and obstacle points (the eq-20 cost);
    ``boxes`` the obstacle extents the clearance is kept from. The first plan goes to
    the touch-down if one keeps the clearance; otherwise (``avoid.when_blocked ==
    "manoeuvre"``) the law takes a safe manoeuvre (:func:`plan_safe_manoeuvre`) and
    flies to its hold point instead, with :class:`InfeasibleClearanceWarning` naming it.

    The simulation does not raise when the model leaves its domain (zero airspeed, an
    integrator failure, no end within ``config.max_time``): the flight ends there with
    ``outcome == "crash"`` and the reason in ``crash_reason``.

    A manoeuvre's deceleration that brings the airspeed to zero before its hold point
    ends the flight there, as a hover (``stopped_short_of_hold_s`` says how much of the
    plan was left): the hold begins where the vehicle stopped.

    ``extras`` of the result hold ``outcome`` (one of :data:`OUTCOMES`), ``manoeuvre``
    (:meth:`SafeManoeuvre.to_dict` or ``None``), ``touchdown`` (the original final
    point; ``result.bc`` is the goal flown), ``feasible`` (the touch-down was reached on
    plans that keep the clearance), ``plans`` (count), ``replan_failures``, per-solve
    times (``solve_times_s``), SLSQP iterations, the planned minimum clearance, the
    boxes and ``terminal_segment_skipped_s``: when the last held command (≤ 1.5 guidance
    intervals before the end) would bring the airspeed to zero, where eqs 2-3 are
    singular, the flight ends at the start of that segment and this says how long it
    was (0 otherwise).
    """
    params = params or VehicleParams()
    cfg = config or SimulationConfig()
    av = avoid or AvoidConfig()
    boxes = tuple(boxes)
    state = state_from_position_velocity(bc.r0, bc.v0)
    t = 0.0
    ts, states = [0.0], [state.copy()]
    rec: dict[str, list] = {k: [] for k in ("t_cmd", "a_cmd", "a_ach", "T", "th", "ph", "tgo")}
    plan, manoeuvre, blocked = _decide(bc.r0, bc.v0, bc, field, boxes, params, av)
    goal = bc if manoeuvre is None else manoeuvre.goal
    # A manoeuvre taken while the touch-down itself keeps the clearance (the start, or
    # the path, was blocked) is followed by a second decision at its hold point.
    td_clear = float(_clearances(bc.rf[None], boxes).min()) if boxes else math.inf
    redecide = manoeuvre is not None and td_clear >= av.clearance_ft
    # A manoeuvre's re-plans keep its walls (an escape from within an extent's
    # clearance leaves it sideways, :func:`escape_walls`).
    walls = boxes if manoeuvre is None else escape_walls(boxes, bc.r0, av.clearance_ft)
    if manoeuvre is not None and manoeuvre.kind == "stop":
        walls = ()  # the braking stop is re-planned on the limits alone, as it was planned
    landing_after: dict | None = None
    phase_start = plan  # the first plan of the flight's current phase (its arrival cap)
    # A manoeuvre's re-plans get its candidates' iteration budget (a short, open target).
    # Re-plans of a plan that keeps the clearance start from it and converge in a few
    # iterations (~5 on runway/P1); one that does not within REPLAN_MAXITER is dropped
    # (the plan is kept), not re-solved from other seeds, which only costs time. A
    # manoeuvre's re-plans get the same budget.
    replan_cfg = replace(av, maxiter=min(av.maxiter, REPLAN_MAXITER))
    plan_field = field if manoeuvre is None else _hold_field(field)
    plans = [plan]
    feasible = plan.feasible and manoeuvre is None
    failures = 0
    terminal_skip = 0.0
    limited = 0
    crash = ""
    stopped_short = 0.0
    last_plan_t = 0.0
    w, zt = av.track_omega, av.track_damping
    while True:
        r, v = state[:3], velocity_from_state(state)
        remaining = plan.t_go - (t - plan.t0)
        if t - last_plan_t >= av.replan_interval - 1e-9 and remaining > av.terminal_time:
            replan_boxes = boxes if goal is bc else walls
            new = plan_trajectory(
                r, v, goal, plan_field, replan_boxes, params=params,
                config=replan_cfg if plan.meets_floor else av, warm=plan, t0=t,
                # A re-plan may delay the arrival by at most one re-plan interval (and
                # never past 1.25 x the first plan's), a relaxed plan (whose cost is the
                # clearance, not time) not at all: else the time-to-go drifts up.
                t_go_max=max(
                    min(
                        remaining + (av.replan_interval if plan.feasible else 1e-6),
                        # never beyond 1.25 x the phase's first arrival
                        phase_start.t0 + 1.25 * phase_start.t_go - t,
                    ),
                    remaining + 1e-6,
                ),
                # Following a plan that keeps the clearance, a re-plan that does not is
                # dropped anyway: do not pay for the relaxed programme, nor for the bent
                # seeds (the warm start is the plan's own path, already clear of them).
                relax=not plan.meets_floor and bool(replan_boxes),
                side_seeds=not plan.meets_floor,
                report_seed=not plan.meets_floor,
            )  # fmt: skip
            plans.append(new)
            last_plan_t = t
            if new.feasible or (not plan.feasible and new.limits_ok and new.meets_floor):
                plan = new
                feasible = feasible and new.feasible
            else:
                failures += 1  # keep following the last plan that kept the clearance
            remaining = plan.t_go - (t - plan.t0)
        rp, vp, ap = plan.evaluate(t - plan.t0)
        track = w * w * (rp[0] - r) + 2.0 * zt * w * (vp[0] - v)
        a_cmd, ctrl, was_limited = limited_command(v, ap[0], track, params, av)
        limited += was_limited
        record_command(rec, t, a_cmd, state, ctrl, params, remaining)
        last = remaining <= 1.5 * cfg.guidance_interval
        dt = max(remaining, 1e-6) if last else cfg.guidance_interval
        t_end, t_eval = held_sample_times(t, dt, cfg.sample_interval)
        try:
            sol = integrate_held_controls(state, ctrl, params, t, t_end, t_eval, cfg)
        except RuntimeError as exc:
            # Near V = 0 eqs 2-3 are singular (γ', χ' ∝ 1/V): the integrator fails or
            # the airspeed reaches zero. Decelerating to its hold, the vehicle has then
            # come (nearly) to a stop before the hold point: a rotorcraft hovers there,
            # the model cannot. The hold begins here; says how early.
            crawling = float(state[3]) <= max(3.0 * float(np.linalg.norm(goal.vf)), 3.0)
            slowing = remaining <= av.terminal_time  # the plan's final deceleration
            stopped = "airspeed reached zero" in str(exc) or crawling or slowing
            if not last and goal is not bc and stopped:
                stopped_short = remaining
                break
            if not last and landing_after is not None and crawling and not slowing:
                # The landing from a hold point starts at the hold speed (~1 ft/s); a
                # plan that turns the velocity round there passes V = 0, which the
                # model cannot fly (runway/P1 stress0-14: "integration failed" at
                # t = 7.5 s, just after the hold). A rotorcraft holds: the flight ends
                # here, holding, and the landing is reported as not flown.
                landing_after.update(landed=False, aborted_at_s=t, aborted=str(exc))
                feasible = False
                break
            if not last:
                crash = str(exc)  # the model left its domain: the flight ends, said so
                break
            # The last held command would stop the vehicle (V -> 0, eqs 2-3 singular)
            # within the final sliver of the flight: it ends here, and says so.
            terminal_skip = dt
            break
        ts.extend(sol.t.tolist())
        states.extend(sol.y.T)
        state = sol.y[:, -1].copy()
        t = float(sol.t[-1])
        if last and redecide:
            # At the hold point: the second decision (never again). A landing is flown
            # only on a plan that keeps the clearance; else the hold stands.
            redecide = False
            r, v = state[:3], velocity_from_state(state)
            landing = plan_trajectory(
                r, v, bc, field, boxes, params=params, config=av, t0=t, relax=False
            )
            plans.append(landing)
            landing_after = {
                "decided_at_s": t,
                "landed": bool(landing.feasible),
                "planned_min_clearance_ft": landing.min_clearance_ft,
            }
            if landing.feasible:
                plan, goal, plan_field, phase_start = landing, bc, field, landing
                feasible, last_plan_t = True, t
                continue
        if last:
            break
        if t > cfg.max_time:
            crash = f"flight did not end within max_time = {cfg.max_time:g} s"
            break
    landed_after = landing_after is not None and landing_after["landed"]
    if crash:
        outcome = "crash"
    elif manoeuvre is not None and not landed_after:
        outcome = manoeuvre.outcome
    else:
        outcome = "landing"
    if manoeuvre is not None:
        hold = ", ".join(f"{c:.0f}" for c in manoeuvre.goal.rf)
        warnings.warn(
            f"no trajectory to the touch-down keeps {av.clearance_ft:g} ft from every "
            f"obstacle within the limits ({blocked}); safe manoeuvre: {manoeuvre.kind} to the "
            f"hold point "
            f"({hold}) ft ({manoeuvre.outcome}, {manoeuvre.plan.min_clearance_ft:.2f} ft "
            f"planned)"
            + ("" if manoeuvre.keeps_floor else ", closer than the clearance floor")
            + (
                ""
                if landing_after is None
                else "; then landed from the hold point on a plan that keeps the clearance"
                if landed_after
                else f"; the landing from the hold point reached zero airspeed (the model's "
                f"limit) at t = {landing_after['aborted_at_s']:.1f} s: holding there"
                if "aborted_at_s" in landing_after
                else "; no landing from the hold point keeps the clearance: holding"
            ),
            InfeasibleClearanceWarning,
            stacklevel=2,
        )
    elif not feasible:
        worst = min(p.min_clearance_ft for p in plans if not p.feasible)
        warnings.warn(
            f"no trajectory keeps {av.clearance_ft:g} ft from every obstacle within the "
            f"limits (load factor {av.max_load_factor:g}, |theta| {av.max_theta_deg:g} deg, "
            f"|phi| {av.max_phi_deg:g} deg); flying the plan that maximises the smallest "
            f"clearance ({worst:.2f} ft planned)",
            InfeasibleClearanceWarning,
            stacklevel=2,
        )
    n_upd = len(rec["tgo"])
    return result_from_record(
        ts,
        states,
        rec,
        h_residual=np.full(n_upd, np.nan),
        root_found=np.ones(n_upd, dtype=bool),
        obstacles=field.points,
        bc=goal,
        params=params,
        extras={
            "law": "avoid",
            "outcome": outcome,
            "crash_reason": crash,
            "manoeuvre": None
            if manoeuvre is None
            else {**manoeuvre.to_dict(), "landing_after": landing_after},
            "landing_blocked": blocked,
            "stopped_short_of_hold_s": stopped_short,
            "touchdown": [float(c) for c in bc.rf],
            "feasible": bool(feasible),
            "plans": len(plans),
            "replan_failures": failures,
            "solve_times_s": [p.solve_time_s for p in plans],
            "solve_iterations": [p.iterations for p in plans],
            "planned_min_clearance_ft": float(min(p.min_clearance_ft for p in plans)),
            "terminal_segment_skipped_s": terminal_skip,
            "limited_updates": limited,
            "boxes": boxes,
            "config": replace(av),
        },
    )
