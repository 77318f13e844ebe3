"""Closed-form optimal obstacle-avoidance guidance law, chapter 6 (eqs 20-69).

The problem (eq 20): with the pseudo-controls ``a = r''`` of the feedback-linearised
model (eq 8), minimise over the free final time ``t_f``::

    J = ∫ { ζ + (1-ζ)/2 [ α|a|² + μ (z - z_r)² - β Σ_i |r - r_i|² ] } dt

from a given initial position/velocity to a given final position/velocity. The
Euler-Lagrange equations (23-31) decouple into three fourth-order linear ODEs (32-34)
whose solution (37-39) is a sum of ``e^{±σt}``, ``sin σt``, ``cos σt`` around the
"obstacle centroid" ``s`` (40-41), with ``σ1 = (nβ/α)^{1/4}`` for x, y and
``σ2 = ((nβ-μ)/α)^{1/4}`` for z (35-36).

Print errors and ambiguities resolved here (SPEC §9, "Ch. 6")
------------------------------------------------------------------
* Eq 60 ends in ``k4 y',`` which is ``k4 y_f'`` (the pattern of eqs 59 and 61).
* "D" is the drag of eq 7 *and* the constant ``D_x`` of eqs 37 and 56; here the
  constants are ``A, B, C, D`` per axis and the drag is ``drag``.
* Eqs 56-58 vs 59-69: derived again here. With ``x - s = A + B + D`` at ``t = 0``,
  ``x''(0) = σ²(A + B - D) = σ²(x - s - 2D)``, so eqs 56-58 are right, and solving
  eqs 48-52 for ``D`` gives exactly the printed gains (62-69); the test suite checks
  the gains against a direct solve of eq 48 (no sign error survives). Small
  ``σ t_go`` limits are the minimum-energy gains ``k1 → -6/t²``, ``k2 → 6/t²``,
  ``k3 → -4/t``, ``k4 → -2/t``.
* The gains (and ``P``, ``Q`` of eqs 51-52) are singular where
  ``cos(σ t_go) cosh(σ t_go) = 1``; the first non-zero root is ``σ t_go ≈ 4.7300``
  (:data:`FIRST_SINGULAR_SIGMA_T`). There no extremal joins the two states uniquely
  (a conjugate point, the Jacobi condition the paper leaves open); beyond it the
  extremal is not a minimum because the ``-β`` term makes the cost indefinite. The
  time-to-go search is therefore confined below ``FIRST_SINGULAR_SIGMA_T / max(σ1, σ2)``
  and :func:`feedback_gains` raises near the singularity.
* Because ``Σ|r - r_i|² = n|r - s|² + Σ|r_i - s|²``, the law sees the obstacles only
  through ``n`` and their centroid; the constant ``Σ|r_i - s|²`` does enter ``H``.
* Transversality (eq 55): ``H`` is autonomous, so ``H(t) = H(t_f) = 0`` along the
  optimum. With the optimal control (27) substituted, ``λ_v = -α(1-ζ) a`` and
  ``λ_r = -λ_v' = α(1-ζ) a'`` (eqs 42-47), so::

      H = ζ + (1-ζ) [ -α|a|²/2 + α a'·v + μ(z - z_r)²/2 - β Σ|r - r_i|²/2 ]

  and ``dJ*/dt_go = H``: roots of ``H`` are the stationary points of the optimal cost
  as a function of the time-to-go. ``H(t_go) → -∞`` as ``t_go → 0`` (unless the state
  already equals the final state), and for larger ``t_go`` it tends to
  ``ζ - (1-ζ) β Σ|r - r_i|²/2`` plus the acceleration terms: a root exists only while
  ``ζ`` outweighs the obstacle term, which is why the report's example (``ζ = 0.96``,
  ``β = 1e-6``, ~300 points several hundred feet away) sits near the boundary.
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, minimize_scalar

__all__ = [
    "FIRST_SINGULAR_SIGMA_T",
    "BoundaryConditions",
    "GuidanceWeights",
    "NoTransversalityRootWarning",
    "ObstacleField",
    "OpenLoopSolution",
    "TimeToGo",
    "command_acceleration",
    "feedback_gains",
    "hamiltonian",
    "open_loop_solution",
    "optimal_cost",
    "solve_time_to_go",
]

#: First positive root of ``cos(τ) cosh(τ) = 1`` (the clamped-beam eigenvalue).
FIRST_SINGULAR_SIGMA_T = 4.730040744862704


def _vec3(name: str, value: object) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector [x, y, z], got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class GuidanceWeights:
    """Weights of the performance index, eq 20, with the constraints of eq 21.

    Parameters
    ----------
    zeta
        Flight-time weight ζ, strictly inside (0, 1) (eq 21: ζ > 0 makes the final
        time free-able by eq 55, ζ < 1 keeps the controls of eq 27 finite).
    alpha
        Acceleration weight α > 0.
    mu
        Altitude-deviation weight μ ≥ 0 (about ``z_ref``).
    beta
        Obstacle-distance weight β > 0; eq 21 also requires ``n β > μ`` for ``n``
        obstacle points (checked by :class:`ObstacleField`).
    z_ref
        Reference altitude ``z_r`` (ft).
    """

    zeta: float = 0.96
    alpha: float = 0.5
    mu: float = 0.0
    beta: float = 1e-6
    z_ref: float = 0.0

    def __post_init__(self) -> None:
        for name in ("zeta", "alpha", "mu", "beta", "z_ref"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"guidance weight {name} must be a finite number, not {v!r}")
        if not 0.0 < self.zeta < 1.0:
            raise ValueError(f"zeta must lie strictly inside (0, 1) (eq 21), not {self.zeta!r}")
        if self.alpha <= 0:
            raise ValueError(f"alpha must be > 0, not {self.alpha!r}")
        if self.mu < 0:
            raise ValueError(f"mu must be >= 0, not {self.mu!r}")
        if self.beta <= 0:
            raise ValueError(f"beta must be > 0 (eq 21 needs n*beta > mu >= 0), not {self.beta!r}")


@dataclass(frozen=True)
class BoundaryConditions:
    """Initial and final position/velocity (ft, ft/s) in the guidance frame.

    The guidance frame is the report's (its Fig 1 and eqs 4-6): ``x`` down range,
    ``y`` cross range, ``z`` altitude above the ground plane (up), right-handed.

    Feasibility (checked): finite 3-vectors; altitudes ``z0, zf >= 0`` (the ground is
    ``z = 0``); non-zero initial and final speed, because the point-mass model divides
    by ``V`` (eqs 2-3) and the heading of eq 16 is undefined at ``V = 0``; distinct
    initial and final positions.
    """

    r0: np.ndarray
    v0: np.ndarray
    rf: np.ndarray
    vf: np.ndarray

    def __post_init__(self) -> None:
        for name in ("r0", "v0", "rf", "vf"):
            object.__setattr__(self, name, _vec3(name, getattr(self, name)))
        if self.r0[2] < 0 or self.rf[2] < 0:
            raise ValueError(
                f"infeasible boundary conditions: altitude below the ground "
                f"(z0={self.r0[2]:g}, zf={self.rf[2]:g} ft; z is altitude, up)"
            )
        if np.linalg.norm(self.v0) == 0 or np.linalg.norm(self.vf) == 0:
            raise ValueError(
                "infeasible boundary conditions: zero initial or final speed (the point-mass "
                "model, eqs 2-3, and the heading, eq 16, need V > 0)"
            )
        if np.array_equal(self.r0, self.rf):
            raise ValueError("infeasible boundary conditions: initial and final positions coincide")


@dataclass(frozen=True)
class ObstacleField:
    """Point obstacles ``r_i`` (shape (n, 3), ft) and the derived law constants.

    Checks ``n >= 1``, finiteness, and eq 21's ``n β > μ``. Exposes ``sigma`` (eqs
    35-36) and the centroid ``s`` (eqs 40-41).
    """

    points: np.ndarray
    weights: GuidanceWeights

    def __post_init__(self) -> None:
        pts = np.array(self.points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"obstacle points must have shape (n, 3), got {pts.shape}")
        if pts.shape[0] == 0:
            raise ValueError("no obstacle points: the guidance law needs n >= 1 (eqs 32-41)")
        if not np.all(np.isfinite(pts)):
            raise ValueError("obstacle points must be finite (NaN or inf found)")
        w = self.weights
        if not pts.shape[0] * w.beta > w.mu:
            raise ValueError(
                f"eq 21 requires n*beta > mu: n={pts.shape[0]}, beta={w.beta:g}, mu={w.mu:g}"
            )
        pts.setflags(write=False)
        object.__setattr__(self, "points", pts)

    @property
    def n(self) -> int:
        return int(self.points.shape[0])

    @functools.cached_property
    def sigma(self) -> np.ndarray:
        """``[σ1, σ1, σ2]``, eqs 35-36."""
        w = self.weights
        s1 = (self.n * w.beta / w.alpha) ** 0.25
        s2 = ((self.n * w.beta - w.mu) / w.alpha) ** 0.25
        return np.array([s1, s1, s2])

    @functools.cached_property
    def centroid(self) -> np.ndarray:
        """``[s_x, s_y, s_z]``, eqs 40-41 (``s_z`` shifted towards ``z_r`` when μ > 0)."""
        w = self.weights
        s = self.points.mean(axis=0)
        sz = (w.beta * self.points[:, 2].sum() - w.mu * w.z_ref) / (self.n * w.beta - w.mu)
        return np.array([s[0], s[1], sz])

    @functools.cached_property
    def mean(self) -> np.ndarray:
        """Plain mean of the points (equals the centroid when μ = 0)."""
        return self.points.mean(axis=0)

    @functools.cached_property
    def spread(self) -> float:
        """``Σ|r_i - c|²`` about the plain mean ``c`` (the constant part of Σ|r - r_i|²)."""
        return float(((self.points - self.mean) ** 2).sum())

    def sum_sq_distance(self, r: np.ndarray) -> np.ndarray:
        """``Σ_i |r - r_i|²`` for positions ``r`` (shape (..., 3)), via the centroid."""
        d = np.asarray(r, dtype=np.float64) - self.mean
        return self.n * (d**2).sum(axis=-1) + self.spread

    @property
    def t_go_singular(self) -> float:
        """Smallest time-to-go at which the gains are singular (σ t_go = 4.730)."""
        return FIRST_SINGULAR_SIGMA_T / float(self.sigma.max())


# --------------------------------------------------------------------------- gains


def _pmatrix(sigma: np.ndarray, t_go: np.ndarray) -> np.ndarray:
    """``P`` / ``Q`` of eqs 51-52 for broadcast ``sigma`` and ``t_go``; shape (..., 4, 4)."""
    s, t = np.broadcast_arrays(np.asarray(sigma, float), np.asarray(t_go, float))
    st = s * t
    e, em, sn, cs = np.exp(st), np.exp(-st), np.sin(st), np.cos(st)
    one, zero = np.ones_like(st), np.zeros_like(st)
    rows = [
        [one, one, zero, one],
        [s, -s, s, zero],
        [e, em, sn, cs],
        [s * e, -s * em, s * cs, -s * sn],
    ]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def feedback_gains(sigma: float, t_go: float) -> tuple[float, float, float, float]:
    """Feedback gains of eqs 62-65 (x and y, ``σ = σ1``) or 66-69 (z, ``σ = σ2``).

    ``a = k1 (x - s) + k2 (x_f - s) + k3 x' + k4 x_f'`` (eqs 59-61).

    Parameters
    ----------
    sigma
        σ1 or σ2 (1/s), > 0.
    t_go
        Time-to-go (s), > 0, with ``σ t_go`` away from the roots of ``cos·cosh = 1``.

    Returns
    -------
    k1, k2, k3, k4 : float

    Raises
    ------
    ValueError
        For ``t_go <= 0`` or ``|cos τ cosh τ - 1| < 1e-9 max(1, cosh τ)`` (singular gains).
    """
    if not (sigma > 0 and t_go > 0):
        raise ValueError(f"feedback gains need sigma > 0 and t_go > 0, got {sigma!r}, {t_go!r}")
    tau = sigma * t_go
    c, ch, sn, sh = math.cos(tau), math.cosh(tau), math.sin(tau), math.sinh(tau)
    den = c * ch - 1.0
    # For small τ, den ≈ -τ⁴/6: evaluate the series to avoid cancellation below τ ~ 1e-2.
    if tau < 2e-2:
        t2 = t_go * t_go
        return (-6.0 / t2, 6.0 / t2, -4.0 / t_go, -2.0 / t_go)
    if abs(den) < 1e-9 * max(1.0, ch):
        raise ValueError(
            f"feedback gains singular: cos(σt)·cosh(σt) = 1 at σ t_go = {tau:.6f} "
            f"(first root {FIRST_SINGULAR_SIGMA_T:.4f})"
        )
    return (
        sigma**2 * sn * sh / den,  # eq 62 / 66
        sigma**2 * (c - ch) / den,  # eq 63 / 67
        sigma * (sn * ch - c * sh) / den,  # eq 64 / 68
        sigma * (sh - sn) / den,  # eq 65 / 69
    )


def command_acceleration(
    r: np.ndarray, v: np.ndarray, t_go: float, bc: BoundaryConditions, field: ObstacleField
) -> np.ndarray:
    """Commanded pseudo-control ``[a_x, a_y, a_z]`` (ft/s²), eqs 59-61 (eq 60 as corrected)."""
    s = field.centroid
    sig = field.sigma
    a = np.empty(3)
    for i in range(3):
        k1, k2, k3, k4 = feedback_gains(float(sig[i]), t_go)
        a[i] = k1 * (r[i] - s[i]) + k2 * (bc.rf[i] - s[i]) + k3 * v[i] + k4 * bc.vf[i]
    return a


# --------------------------------------------------------------------------- open loop


@dataclass(frozen=True)
class OpenLoopSolution:
    """The extremal of eqs 37-39 from ``(r0, v0)`` at ``t = 0`` to ``(rf, vf)`` at ``t_go``.

    ``coeffs[i] = [A, B, C, D]`` of axis ``i`` (eqs 48-50).
    """

    t_go: float
    sigma: np.ndarray
    centroid: np.ndarray
    coeffs: np.ndarray  # (3, 4)

    def derivative(self, t: np.ndarray | float, order: int) -> np.ndarray:
        """``d^order r / dt^order`` at times ``t`` (shape (..., 3)); eqs 37-39 differentiated."""
        t = np.asarray(t, dtype=np.float64)[..., None]
        s = self.sigma
        A, B, C, D = (self.coeffs[:, k] for k in range(4))
        st = s * t
        # d^k/dt^k of e^{σt}, e^{-σt}, sin σt, cos σt
        trig = [np.sin(st), np.cos(st), -np.sin(st), -np.cos(st)]
        sin_k = trig[order % 4]
        cos_k = trig[(order + 1) % 4]
        out = s**order * (A * np.exp(st) + B * (-1) ** order * np.exp(-st) + C * sin_k + D * cos_k)
        if order == 0:
            out = out + self.centroid
        return out


def open_loop_solution(
    r0: np.ndarray, v0: np.ndarray, t_go: float, bc: BoundaryConditions, field: ObstacleField
) -> OpenLoopSolution:
    """Solve eqs 48-50 for the 12 constants at a given time-to-go."""
    s = field.centroid
    sig = field.sigma
    rhs = np.stack([r0 - s, v0, bc.rf - s, bc.vf], axis=-1)  # (3, 4)
    coeffs = np.linalg.solve(_pmatrix(sig, t_go), rhs[..., None])[..., 0]
    return OpenLoopSolution(float(t_go), sig, s, coeffs)


def _h_batch(
    r0: np.ndarray, v0: np.ndarray, t_go: np.ndarray, bc: BoundaryConditions, field: ObstacleField
) -> np.ndarray:
    """``H(t = 0)`` for many ``t_go`` at once (vectorised eq 22 on the extremal)."""
    t_go = np.asarray(t_go, dtype=np.float64)
    s = field.centroid
    sig = field.sigma
    rhs = np.stack([r0 - s, v0, bc.rf - s, bc.vf], axis=-1)  # (3, 4)
    P = _pmatrix(sig[None, :], t_go[:, None])  # (m, 3, 4, 4)
    coef = np.linalg.solve(P, np.broadcast_to(rhs, P.shape[:-1])[..., None])[..., 0]
    A, B, C, D = (coef[..., k] for k in range(4))
    a = sig**2 * (A + B - D)  # x''(0), eq 56
    jerk = sig**3 * (A - B - C)  # x'''(0), cf. eq 45
    return _h_terms(r0, v0, a, jerk, field)


def _h_terms(
    r: np.ndarray, v: np.ndarray, a: np.ndarray, jerk: np.ndarray, field: ObstacleField
) -> np.ndarray:
    w = field.weights
    acc = -0.5 * w.alpha * (a**2).sum(axis=-1) + w.alpha * (jerk * v).sum(axis=-1)
    alt = 0.5 * w.mu * (np.asarray(r)[..., 2] - w.z_ref) ** 2
    obs = 0.5 * w.beta * field.sum_sq_distance(r)
    return w.zeta + (1.0 - w.zeta) * (acc + alt - obs)


def hamiltonian(
    sol: OpenLoopSolution, field: ObstacleField, t: np.ndarray | float = 0.0
) -> np.ndarray:
    """Variational Hamiltonian (eq 22) along an extremal at times ``t``.

    Uses ``λ_v = -α(1-ζ) r''`` (eqs 27, 42-44) and ``λ_r = α(1-ζ) r'''`` (eqs 45-47).
    Constant in ``t`` on an extremal (tested).
    """
    r = sol.derivative(t, 0)
    return _h_terms(r, sol.derivative(t, 1), sol.derivative(t, 2), sol.derivative(t, 3), field)


@functools.cache
def _leggauss(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(nodes)


def optimal_cost(sol: OpenLoopSolution, field: ObstacleField, nodes: int = 96) -> float:
    """The cost of eq 20 along the extremal, by Gauss-Legendre quadrature."""
    w = field.weights
    x, wq = _leggauss(nodes)
    t = 0.5 * sol.t_go * (x + 1.0)
    r = sol.derivative(t, 0)
    a = sol.derivative(t, 2)
    integrand = w.zeta + 0.5 * (1.0 - w.zeta) * (
        w.alpha * (a**2).sum(axis=-1)
        + w.mu * (r[:, 2] - w.z_ref) ** 2
        - w.beta * field.sum_sq_distance(r)
    )
    return float(0.5 * sol.t_go * (wq * integrand).sum())


# --------------------------------------------------------------------------- time-to-go


class NoTransversalityRootWarning(UserWarning):
    """``H(t_go) = 0`` (eq 55) has no root in the admissible time-to-go interval."""


@dataclass(frozen=True)
class TimeToGo:
    """Result of :func:`solve_time_to_go`.

    Attributes
    ----------
    t_go
        The chosen time-to-go (s).
    roots
        Every root of ``H`` found in the search interval, ascending.
    costs
        Cost of eq 20 on the extremal of each root (same order).
    h_residual
        ``H`` at the chosen ``t_go`` (0 up to the solver tolerance when a root exists).
    root_found
        False when no root exists and the fallback was used.
    interval
        The search interval ``(t_min, t_max)``.
    """

    t_go: float
    roots: tuple[float, ...]
    costs: tuple[float, ...]
    h_residual: float
    root_found: bool
    interval: tuple[float, float]


def solve_time_to_go(
    r0: np.ndarray,
    v0: np.ndarray,
    bc: BoundaryConditions,
    field: ObstacleField,
    *,
    t_min: float = 0.05,
    t_max: float = 120.0,
    grid: int = 400,
    singular_margin: float = 0.02,
) -> TimeToGo:
    """Time-to-go from the transversality condition ``H(t0) = 0`` (eq 55), 1-D search.

    The search interval is ``[t_min, min(t_max, (1 - singular_margin) t_sing)]`` with
    ``t_sing = 4.7300 / max(σ1, σ2)`` the first singularity of the gains (beyond it the
    extremal is not a minimum, see the module docstring). ``H`` is tabulated on a
    geometric grid, each sign change is refined by Brent's method (the paper suggests
    bisection), and:

    * **several roots** → the one whose extremal has the lowest cost (eq 20,
      :func:`optimal_cost`); since ``dJ*/dt_go = H``, minima of the cost are the roots
      where ``H`` goes from negative to positive;
    * **no root** → a :class:`NoTransversalityRootWarning` is issued and the time-to-go
      that brings ``H`` closest to zero (``argmin |H|`` over the grid, refined by a
      bounded scalar minimisation) is used, i.e. the closest the transversality
      condition can be met. The result says ``root_found=False``.

    Parameters
    ----------
    r0, v0
        Current position and velocity (the "initial" state of the closed loop).
    bc
        Final state (``bc.rf``, ``bc.vf``); ``bc.r0``/``bc.v0`` are not used here.
    field
        Obstacles and weights.
    t_min, t_max
        Search bounds (s), ``0 < t_min < t_max``.
    grid
        Number of grid points for bracketing roots (>= 8).
    singular_margin
        Relative distance kept from the gain singularity.

    Returns
    -------
    TimeToGo
    """
    if not 0 < t_min < t_max:
        raise ValueError(f"need 0 < t_min < t_max, got t_min={t_min!r}, t_max={t_max!r}")
    if grid < 8:
        raise ValueError(f"grid must be >= 8, not {grid!r}")
    r0 = np.asarray(r0, dtype=np.float64)
    v0 = np.asarray(v0, dtype=np.float64)
    hi = min(t_max, (1.0 - singular_margin) * field.t_go_singular)
    if hi <= t_min:
        raise ValueError(
            f"time-to-go search interval is empty: t_min={t_min:g} s but the gains are "
            f"singular from {field.t_go_singular:g} s (σ t_go = 4.730)"
        )
    ts = np.geomspace(t_min, hi, grid)
    hs = _h_batch(r0, v0, ts, bc, field)

    def h(t: float) -> float:
        return float(_h_batch(r0, v0, np.array([t]), bc, field)[0])

    roots: list[float] = []
    for k in np.nonzero(np.signbit(hs[:-1]) != np.signbit(hs[1:]))[0]:
        roots.append(brentq(h, ts[k], ts[k + 1], xtol=1e-10, rtol=1e-12))
    if roots:
        costs = [optimal_cost(open_loop_solution(r0, v0, t, bc, field), field) for t in roots]
        best = int(np.argmin(costs))
        return TimeToGo(roots[best], tuple(roots), tuple(costs), h(roots[best]), True, (t_min, hi))
    k = int(np.argmin(np.abs(hs)))
    lo_b, hi_b = ts[max(k - 1, 0)], ts[min(k + 1, grid - 1)]
    res = minimize_scalar(
        lambda t: abs(h(t)), bounds=(lo_b, hi_b), method="bounded", options={"xatol": 1e-8}
    )
    t_best = float(res.x) if abs(h(float(res.x))) <= abs(hs[k]) else float(ts[k])
    warnings.warn(
        f"H(t_go) = 0 (eq 55) has no root for t_go in [{t_min:g}, {hi:g}] s; "
        f"using t_go = {t_best:.4g} s where |H| is smallest (H = {h(t_best):.4g})",
        NoTransversalityRootWarning,
        stacklevel=2,
    )
    return TimeToGo(t_best, (), (), h(t_best), False, (t_min, hi))
