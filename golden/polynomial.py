"""Optical ranging polynomial of degree 1..4 (SPIE paper of ch. 4, eqs 4-12; float64).

Derivation (the print gives eqs 10-11 without their coefficients). With the disparity
``r = δ v``, ``v = [xp Δz0 - f Δx0, yp Δz0 - f Δy0]`` (eq 9, ``δ`` = inverse depth in
view 2) and ``D = v · ∇`` the derivative along the disparity direction (scaled by
``|v|``), the Taylor series of eqs 4-5 along the straight line ``p + t r`` are exact
one-dimensional series::

    E1 - E2 = Σ_k  D^k E2 δ^k / k!                (eq 4:  E1(p) = E2(p + r))
    E2 - E1 = Σ_k (-1)^k D^k E1 δ^k / k!          (eq 5:  E2(p) = E1(p - r))

Their half difference (eq 6) and their sum (eq 7) give the ranging polynomial (eq 10)
and the ranging error polynomial (eq 11)::

    E1 - E2 = Σ_k a_k δ^k,   a_k = [D^k E2 - (-1)^k D^k E1] / (2 k!)
          0 = Σ_k b_k δ^k,   b_k = [D^k E2 + (-1)^k D^k E1] / k!

so ``a1 = ½ (g1 + g2) · v`` (the degree-1 form of :func:`~rangefx.golden.ranging.range_g3`),
``a2 = ¼ vᵀ (H2 - H1) v``, ``a3 = (D³E1 + D³E2) / 12``, ``a4 = (D⁴E2 - D⁴E1) / 48``, and
``b1 = (g2 - g1) · v``, ``b2 = ½ vᵀ (H1 + H2) v`` — the first two terms match eqs 6-7 as
printed. ``D^k E = Σ_j C(k, j) vx^j vy^(k-j) ∂^k E / ∂x^j ∂y^(k-j)``; for a horizontal
stereo pair only the x derivatives enter.

Derivatives of order ``k`` come from the causal estimator run with ``order >= k``
(:class:`~rangefx.golden.estimator.EstimatorConfig`): its documented taps hold every
partial that is needed — ``consistent``: ``∂^(a+b)E/∂x^a ∂y^b`` = tap ``u{a}{b}``;
``paper``: the product-factorised ``r_(a+1) s_(b+1) / r1`` (eq 19 generalised, as the
estimator forms ``Exx`` and ``Exy``).

Roots. The polynomial is solved in the scaled unknown ``p = S δ`` (``S`` = the largest
``|v|`` of the image, so ``p`` is about the disparity in pixels and the coefficients are
of one magnitude) by closed forms — quadratic (cancellation-free form), cubic
(Cardano with complex cube roots), quartic (Ferrari with a resolvent-cubic root) — or,
on request, by numpy's companion-matrix ``np.roots``; a pixel whose leading coefficients
vanish (``|A_k| <= 1e-12 max|A|``) is solved at its lower effective degree. Root rule:
among the *real* roots (``|Im p| <= 1e-6 max(1, |p|)``) whose depth ``1/δ + Δz0`` lies in
``(0, range_max]``, take the one closest to the degree-1 root ``p1 = S c1 / a1``. Reason:
the higher terms are corrections of the first-order Taylor model; as the disparity
shrinks the physical root tends continuously to ``p1`` while the extra roots move out to
``|p| ~ |A_(k-1) / A_k|``. The chosen root is polished by Newton steps on the full
polynomial (the closed forms lose digits when the leading coefficient is small), a step
being kept only where it lowers ``|P(p)|``. A pixel with no admissible root is invalid.

Validity is that of :func:`~rangefx.golden.ranging.range_g3` (``|E1 - E2| >= T_E``, gradient
term ``|a1| / |v| >= T_g``, ``0 < range <= range_max``) plus an admissible root and,
optionally, ``|Σ b_k δ^k| <= max_error`` (the eq-11 residual at the chosen root: how far
the two one-sided Taylor series disagree, in grey levels). Invalid pixels carry
``range_max``. Degree 1 is computed by the very expression of ``range_g3`` and equals it
bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .estimator import Derivatives
from .geometry import MotionIncrement, PinholeCamera
from .ranging import RangeResult, RangingConfig, range_g3

__all__ = [
    "SOLVERS",
    "PolynomialConfig",
    "backward_error",
    "choose_root",
    "directional_derivatives",
    "polynomial_coefficients",
    "polynomial_roots",
    "range_g3_poly",
    "solve_cubic",
    "solve_quadratic",
    "solve_quartic",
]

SOLVERS: tuple[str, ...] = ("closed", "companion")
_DEGENERATE = 1e-12  # relative size below which a leading coefficient counts as zero
_REAL_TOL = 1e-6  # |Im p| <= tol max(1, |p|) counts as a real root
# closed-form root accepted when |P(x)| <= tol * sum_k |c_k| |x|^k (backward error); the
# formulas with their polish reach ~1e-16 except where the roots' magnitudes differ by
# ~1e6 or more, where a root may come out wholly wrong (relative residual 1.0, measured)
_BACKWARD_TOL = 1e-10


@dataclass(frozen=True)
class PolynomialConfig:
    """Settings of the ranging-polynomial solver.

    Attributes
    ----------
    degree
        Degree ``n`` of the ranging polynomial (eq 10), 1..4.
    solver
        ``"closed"`` (quadratic / Cardano / Ferrari formulas) or ``"companion"``
        (``np.roots`` per pixel; slow, for checks).
    newton_steps
        Newton steps polishing the chosen root on the full polynomial (0 = none).
    max_error
        Pixels whose eq-11 residual ``|Σ b_k δ^k|`` exceeds this (grey levels) are
        invalid; ``inf`` disables the test.
    """

    degree: int = 2
    solver: str = "closed"
    newton_steps: int = 2
    max_error: float = math.inf

    def __post_init__(self) -> None:
        if isinstance(self.degree, bool) or int(self.degree) != self.degree:
            raise ValueError(f"polynomial degree must be an integer in 1..4, not {self.degree!r}")
        if not 1 <= self.degree <= 4:
            raise ValueError(f"polynomial degree must be an integer in 1..4, not {self.degree!r}")
        if self.solver not in SOLVERS:
            raise ValueError(f"unknown root solver {self.solver!r}; choose from {SOLVERS}")
        if isinstance(self.newton_steps, bool) or int(self.newton_steps) != self.newton_steps:
            raise ValueError(f"newton_steps must be an integer >= 0, not {self.newton_steps!r}")
        if self.newton_steps < 0:
            raise ValueError(f"newton_steps must be an integer >= 0, not {self.newton_steps!r}")
        m = self.max_error
        if isinstance(m, bool) or not isinstance(m, (int, float)) or math.isnan(m) or m <= 0:
            raise ValueError(f"max_error must be a positive number (inf = off), not {m!r}")


# --------------------------------------------------------------------------- derivatives


def _partial(d: Derivatives, a: int, b: int) -> np.ndarray:
    """``∂^(a+b) E_hat / ∂x^a ∂y^b`` from the estimator's outputs (``a + b >= 1``)."""
    if (a, b) == (1, 0):
        return d.Ex
    if (a, b) == (0, 1):
        return d.Ey
    taps = d.taps
    need = a + b
    if "u00" in taps:  # consistent: column output b of row output a
        key = f"u{a}{b}"
        if key not in taps:
            raise ValueError(
                f"derivative d^{need}E/dx^{a}dy^{b} needs the estimator with order >= {need}"
            )
        return taps[key]
    if "s1" in taps:  # paper: product factorisation, eq 19 generalised
        rk, sk = f"r{a + 1}", f"s{b + 1}"
        if rk not in taps or sk not in taps:
            raise ValueError(
                f"derivative d^{need}E/dx^{a}dy^{b} needs the estimator with order >= {need}"
            )
        if b == 0:
            return (taps["s1"] / taps["r1"]) * taps[rk]
        if a == 0:
            return taps[sk]
        return taps[rk] * taps[sk] / taps["r1"]
    raise ValueError("derivatives carry no estimator taps: estimate them with estimate_derivatives")


def directional_derivatives(
    d: Derivatives, wx: np.ndarray | float, wy: np.ndarray | float, degree: int
) -> list[np.ndarray]:
    """``[D E, D² E, ..., D^degree E]`` with ``D = wx ∂/∂x + wy ∂/∂y`` (SPIE eqs 4-5).

    ``D^k E = Σ_j C(k, j) wx^j wy^(k-j) ∂^k E / ∂x^j ∂y^(k-j)``; terms whose weight is
    zero everywhere are skipped (a horizontal stereo pair needs x derivatives only).
    """
    wx = np.asarray(wx, dtype=np.float64)
    wy = np.asarray(wy, dtype=np.float64)
    out = []
    for k in range(1, degree + 1):
        total = np.zeros(d.E.shape)
        for j in range(k + 1):
            weight = math.comb(k, j) * wx**j * wy ** (k - j)
            if not np.any(weight):
                continue
            total = total + weight * _partial(d, j, k - j)
        out.append(total)
    return out


def _disparity_basis(
    camera: PinholeCamera, motion: MotionIncrement
) -> tuple[np.ndarray, np.ndarray, float]:
    """Disparity per unit inverse depth ``v`` (eq 9) and the forward displacement Δz0."""
    fwd, right, down = motion.camera_displacement
    if math.hypot(fwd, right, down) == 0:
        raise ValueError("camera displacement between the two views is zero: no parallax")
    xp, yp = camera.pixel_grid()
    f = camera.f_px
    return xp * fwd - f * right, yp * fwd - f * down, float(fwd)


def polynomial_coefficients(
    d1: Derivatives,
    d2: Derivatives,
    camera: PinholeCamera,
    motion: MotionIncrement,
    degree: int,
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Coefficients ``[a_1..a_n]`` of eq 10 and ``[b_1..b_n]`` of eq 11, per pixel.

    In the report's unknown ``δ`` (inverse depth in view 2, scene length unit):
    ``a_k = [D^k E2 - (-1)^k D^k E1] / (2 k!)``, ``b_k = [D^k E2 + (-1)^k D^k E1] / k!``
    with ``D = v · ∇`` and ``v`` of eq 9 (module docstring).
    """
    vx, vy, _ = _disparity_basis(camera, motion)
    a, b = _scaled_coefficients(d1, d2, vx, vy, 1.0, degree)
    return a, b


def _scaled_coefficients(
    d1: Derivatives, d2: Derivatives, vx: np.ndarray, vy: np.ndarray, scale: float, degree: int
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Coefficients in the unknown ``p = scale δ``: ``A_k = a_k / scale^k``."""
    g1 = directional_derivatives(d1, vx / scale, vy / scale, degree)
    g2 = directional_derivatives(d2, vx / scale, vy / scale, degree)
    a, b = [], []
    for k in range(1, degree + 1):
        sgn = (-1.0) ** k
        fact = math.factorial(k)
        a.append((g2[k - 1] - sgn * g1[k - 1]) / (2.0 * fact))
        b.append((g2[k - 1] + sgn * g1[k - 1]) / fact)
    return a, b


# --------------------------------------------------------------------------- roots


def _cbrt(z: np.ndarray) -> np.ndarray:
    """Principal complex cube root."""
    return np.power(z.astype(np.complex128), 1.0 / 3.0)


def solve_quadratic(c: np.ndarray) -> np.ndarray:
    """Roots of ``c0 + c1 x + c2 x²`` (``c`` shape (N, 3), ascending); complex (N, 2).

    Cancellation-free form: ``q = -(c1 + sign(c1) sqrt(c1² - 4 c0 c2)) / 2``, roots
    ``q / c2`` and ``c0 / q`` (``c2 != 0`` required).
    """
    c = np.asarray(c, dtype=np.float64)
    c0, c1, c2 = c[:, 0], c[:, 1], c[:, 2]
    disc = np.sqrt((c1 * c1 - 4.0 * c0 * c2).astype(np.complex128))
    # choose the sign that adds magnitudes (Re part decides for a complex root)
    s = np.where(c1 * disc.real >= 0, 1.0, -1.0)
    q = -0.5 * (c1 + s * disc)
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = q / c2
        r2 = np.where(q != 0, c0 / np.where(q != 0, q, 1.0), 0.0)
    return np.stack([r1, r2], axis=1)


def solve_cubic(c: np.ndarray) -> np.ndarray:
    """Roots of ``c0 + c1 x + c2 x² + c3 x³`` (shape (N, 4), ascending); complex (N, 3).

    Cardano in the general form: with the monic ``x³ + A x² + B x + C``,
    ``Δ0 = A² - 3B``, ``Δ1 = 2A³ - 9AB + 27C``,
    ``Q = cbrt((Δ1 ± sqrt(Δ1² - 4Δ0³)) / 2)`` (sign chosen for the larger ``|Q|``), and
    ``x_k = -(A + ξ^k Q + Δ0 / (ξ^k Q)) / 3``, ``ξ = e^(2πi/3)``; ``Q = 0`` is the triple
    root ``-A/3``.
    """
    c = np.asarray(c, dtype=np.float64)
    A, B, C = c[:, 2] / c[:, 3], c[:, 1] / c[:, 3], c[:, 0] / c[:, 3]
    d0 = A * A - 3.0 * B
    d1 = 2.0 * A**3 - 9.0 * A * B + 27.0 * C
    root = np.sqrt((d1 * d1 - 4.0 * d0**3).astype(np.complex128))
    plus, minus = d1 + root, d1 - root
    big = np.where(np.abs(plus) >= np.abs(minus), plus, minus)
    Q = _cbrt(0.5 * big)
    xi = np.exp(2j * np.pi / 3.0)
    roots = []
    for k in range(3):
        qk = Q * xi**k
        with np.errstate(divide="ignore", invalid="ignore"):
            x = -(A + qk + np.where(qk != 0, d0 / np.where(qk != 0, qk, 1.0), 0.0)) / 3.0
        roots.append(x)
    return np.stack(roots, axis=1)


def solve_quartic(c: np.ndarray) -> np.ndarray:
    """Roots of ``c0 + ... + c4 x⁴`` (shape (N, 5), ascending); complex (N, 4).

    Ferrari: depress ``x = y - A/4`` to ``y⁴ + p y² + q y + r``; with a root ``m`` of the
    resolvent ``8m³ + 8p m² + (2p² - 8r) m - q² = 0`` (the one of largest ``|m|``, so that
    ``s = sqrt(2m) != 0`` unless ``p = q = r = 0``) the quartic factors as
    ``(y² - s y + p/2 + m + q/(2s)) (y² + s y + p/2 + m - q/(2s))``.
    """
    c = np.asarray(c, dtype=np.float64)
    A, B, C, D = (c[:, k] / c[:, 4] for k in (3, 2, 1, 0))
    p = B - 3.0 * A * A / 8.0
    q = C - A * B / 2.0 + A**3 / 8.0
    r = D - A * C / 4.0 + A * A * B / 16.0 - 3.0 * A**4 / 256.0
    res = solve_cubic(np.stack([-q * q, 2.0 * p * p - 8.0 * r, 8.0 * p, np.full_like(p, 8.0)], 1))
    m = res[np.arange(len(p)), np.argmax(np.abs(res), axis=1)]
    s = np.sqrt(2.0 * m)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(s != 0, q / (2.0 * np.where(s != 0, s, 1.0)), 0.0)
    half = p / 2.0 + m
    one = np.ones_like(p)
    roots1 = _complex_quadratic(half + t, -s, one)
    roots2 = _complex_quadratic(half - t, s, one)
    return np.concatenate([roots1, roots2], axis=1) - A[:, None] / 4.0


def _complex_quadratic(c0: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
    """Roots of a quadratic with complex coefficients, (N, 2)."""
    c0, c1 = c0.astype(np.complex128), c1.astype(np.complex128)
    disc = np.sqrt(c1 * c1 - 4.0 * c0 * c2)
    s = np.where((np.conj(c1) * disc).real >= 0, 1.0, -1.0)
    q = -0.5 * (c1 + s * disc)
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = q / c2
        r2 = np.where(q != 0, c0 / np.where(q != 0, q, 1.0), 0.0)
    return np.stack([r1, r2], axis=1)


_CLOSED = {2: solve_quadratic, 3: solve_cubic, 4: solve_quartic}


def polynomial_roots(coeffs: np.ndarray, solver: str = "closed") -> np.ndarray:
    """All roots of ``Σ_k coeffs[:, k] x^k`` per row; complex (N, n), NaN-padded.

    Rows whose leading coefficients vanish (``|c_k| <= 1e-12 max|c|``) are solved at
    their effective degree; the missing roots are NaN. ``solver="closed"`` uses the
    formulas of degree 1..4 (:func:`solve_quadratic`, :func:`solve_cubic`,
    :func:`solve_quartic`) after deflating exact zero roots (vanishing low-order
    coefficients), polished by guarded Newton steps; a row where a root's
    :func:`backward_error` still exceeds 1e-10 (roots whose magnitudes differ by ~1e6 or
    more: 2.5 % of quartic roots with coefficients log-uniform over 1e-4..1e4) is solved
    by ``np.roots`` instead. ``"companion"`` uses ``np.roots`` row by row.
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim != 2 or coeffs.shape[1] < 2:
        raise ValueError(f"coefficients must have shape (N, n+1) with n >= 1, not {coeffs.shape}")
    if solver not in SOLVERS:
        raise ValueError(f"unknown root solver {solver!r}; choose from {SOLVERS}")
    n = coeffs.shape[1] - 1
    if solver == "closed" and n > 4:
        raise ValueError(f"closed-form roots exist up to degree 4, not {n}")
    out = np.full((coeffs.shape[0], n), np.nan + 0j)
    mag = np.max(np.abs(coeffs), axis=1)
    eff = np.zeros(coeffs.shape[0], dtype=np.int64)
    for k in range(n, 0, -1):  # effective degree: highest non-negligible coefficient
        eff = np.where((eff == 0) & (np.abs(coeffs[:, k]) > _DEGENERATE * mag), k, eff)
    for k in range(1, n + 1):
        rows = np.flatnonzero(eff == k)
        if rows.size == 0:
            continue
        sub = coeffs[rows, : k + 1]
        if solver == "companion":
            found = np.array([np.roots(row[::-1]) for row in sub]).reshape(len(rows), k)
            out[rows, :k] = found
            continue
        # exact zero roots (c_0 = ... = c_(z-1) = 0) are deflated, not left to the
        # formulas: Ferrari's puts a double root at 0 some 1e-4 away (P = x^2 (24 +
        # 82.6 x + x^2 / 16) gave ±2.06e-4)
        zeros = np.argmax(sub[:, :k] != 0, axis=1)
        zeros = np.where(np.any(sub[:, :k] != 0, axis=1), zeros, k)
        for z in np.unique(zeros):
            sel = np.flatnonzero(zeros == z)
            d = k - z  # degree of the deflated polynomial
            found = np.zeros((sel.size, k), dtype=np.complex128)
            red = sub[sel, z:]
            if d == 1:
                found[:, 0] = -red[:, 0] / red[:, 1]
            elif d > 1:
                found[:, :d] = _polish(red, _CLOSED[d](red))
                # rows the formulas fail (roots ~1e6 or more apart in magnitude: Newton
                # cannot recover a root that started wholly wrong) are re-solved by the
                # backward-stable companion matrix rather than returned wrong
                # ... and so are rows where two roots met at a simple root: each is a
                # root, but another root is missing (Newton carried a poor formula root
                # at 1.755 onto -0.0019 in -1 - 526 x - x^2 + 172 x^3 - 1.7e-4 x^4)
                err = backward_error(red, found[:, :d]).max(axis=1)
                met = _roots_met(red, found[:, :d])
                bad = np.flatnonzero((err > _BACKWARD_TOL) | met)
                if bad.size:
                    alt = np.array([np.roots(red[i, ::-1]) for i in bad]).reshape(bad.size, d)
                    alt = _polish(red[bad], alt)
                    take = (backward_error(red[bad], alt).max(axis=1) < err[bad]) | (
                        met[bad] & ~_roots_met(red[bad], alt)
                    )
                    found[bad[take], :d] = alt[take]
            out[rows[sel], :k] = found
    return out


def backward_error(c: np.ndarray, roots: np.ndarray) -> np.ndarray:
    """Relative backward error ``|P(x)| / Σ_k |c_k| |x|^k`` of each of ``roots`` (N, d) of
    ``c`` (N, d+1, ascending): the relative change of the coefficients that makes ``x`` an
    exact root (0 for an exact root; NaN or inf for a non-finite one)."""
    coeffs = [c[:, k : k + 1] for k in range(c.shape[1])]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        p, _ = _poly(coeffs, roots)
        size, _ = _poly([np.abs(ck) for ck in coeffs], np.abs(roots))
        err = np.abs(p) / size
    return np.where(np.isfinite(roots), np.where(size > 0, err, 0.0), np.inf)


def _roots_met(c: np.ndarray, roots: np.ndarray) -> np.ndarray:
    """Rows of ``roots`` (N, d) of ``c`` (N, d+1) where two roots coincide (relative 1e-6)
    at a point where ``P'`` does not vanish (backward error of ``x`` as a root of ``P'``
    above 1e-4): a simple root counted twice, so one of the roots was lost. A true multiple
    root, found to ~sqrt(eps), has ``P' ~ 0`` there and is not flagged."""
    met = np.zeros(roots.shape[0], dtype=bool)
    if roots.shape[1] < 2:
        return met
    deriv = c[:, 1:] * np.arange(1, c.shape[1], dtype=np.float64)
    simple = backward_error(deriv, roots) > 1e-4
    for i in range(roots.shape[1]):
        for j in range(i + 1, roots.shape[1]):
            with np.errstate(invalid="ignore"):
                close = np.abs(roots[:, i] - roots[:, j]) <= 1e-6 * np.maximum(
                    1.0, np.abs(roots[:, i])
                )
            met |= close & simple[:, i]
    return met


def _polish(c: np.ndarray, roots: np.ndarray, steps: int = 8) -> np.ndarray:
    """Guarded Newton steps on the closed-form ``roots`` (N, d) of ``c`` (N, d+1): a step is
    kept only where it lowers ``|P|``, and the steps stop early once none is kept.
    Ferrari's formulas lose digits when the roots' magnitudes differ widely (``1 + 55 x^3
    + x^4/64``: roots near 0.26 and -3520 left a relative residual of 1.2e-5; ``1/256 +
    78 x^3 + x^4/256``: a root near -0.0369 came out 17 % off and took 4 steps, two left
    a residual of 6e-6); near a multiple root, where Newton may step away, the guard keeps
    the formula's root."""
    coeffs = [c[:, k : k + 1] for k in range(c.shape[1])]
    x = roots.copy()
    p, dp = _poly(coeffs, x)
    for _ in range(steps):
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dp != 0, p / np.where(dp != 0, dp, 1.0), 0.0)
        cand = x - step
        with np.errstate(over="ignore", invalid="ignore"):  # a wild step: rejected below
            pc, dpc = _poly(coeffs, cand)
        better = np.isfinite(cand) & (np.abs(pc) < np.abs(p))
        if not better.any():
            break
        # P and P' at the kept points carry over to the next step (no second evaluation)
        x, p, dp = np.where(better, cand, x), np.where(better, pc, p), np.where(better, dpc, dp)
    return x


def choose_root(
    roots: np.ndarray, guess: np.ndarray, p_min: np.ndarray | float, p_max: float = math.inf
) -> np.ndarray:
    """The real root in ``[p_min, p_max]`` closest to ``guess``, per row; NaN if none.

    A root is real when ``|Im| <= 1e-6 max(1, |root|)``.
    """
    re, im = roots.real, roots.imag
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(re) & (np.abs(im) <= _REAL_TOL * np.maximum(1.0, np.abs(re)))
        ok &= (re >= np.asarray(p_min)[..., None]) & (re <= p_max) & (re > 0)
        g = np.where(np.isfinite(guess), guess, 0.0)[:, None]
        dist = np.where(ok, np.abs(re - g), np.inf)
    idx = np.argmin(dist, axis=1)
    rows = np.arange(roots.shape[0])
    return np.where(np.isfinite(dist[rows, idx]), re[rows, idx], np.nan)


def _poly(coeffs: list[np.ndarray], x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``Σ coeffs[k] x^k`` and its derivative (Horner)."""
    val = np.zeros_like(x)
    der = np.zeros_like(x)
    for c in reversed(coeffs):
        der = der * x + val
        val = val * x + c
    return val, der


# --------------------------------------------------------------------------- ranging


def range_g3_poly(
    d1: Derivatives,
    d2: Derivatives,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: RangingConfig | None = None,
    poly: PolynomialConfig | None = None,
) -> RangeResult:
    """Range from the optical ranging polynomial of degree 1..4 (SPIE eqs 9-12).

    Solves ``E1 - E2 = Σ_(k<=n) a_k δ^k`` (eq 10) per pixel for the inverse depth ``δ``
    with the root rule of the module docstring; the depth of view 1 is
    ``1/δ + Δz0`` (eq 12). ``terms`` adds to ``range_g3``'s (``c1``, ``a1``, ``grad``,
    ``raw_range``): ``a{k}``/``b{k}`` (eqs 10-11 in ``δ`` units), ``delta``, ``delta1``
    (the degree-1 root), ``error_residual`` (eq 11 at the chosen root, grey levels).

    Derivatives must come from an estimator of order >= the degree.
    """
    config = config or RangingConfig()
    poly = poly or PolynomialConfig()
    base = range_g3(d1, d2, camera, motion, config)  # checks shapes; degree 1 exactly
    if poly.degree == 1:
        return base
    n = poly.degree
    vx, vy, fwd = _disparity_basis(camera, motion)
    norm = np.hypot(vx, vy)
    scale = float(np.max(norm))
    A, Bc = _scaled_coefficients(d1, d2, vx, vy, scale, n)
    c1 = base.terms["c1"]
    shape = c1.shape
    with np.errstate(divide="ignore", invalid="ignore"):
        p1 = scale * c1 / base.terms["a1"]  # degree-1 root, scaled
        # depth = scale / p + fwd <= range_max  <=>  p >= scale / (range_max - fwd)
        p_min = scale / (config.range_max - fwd) if config.range_max > fwd else math.inf
        p_max = scale / -fwd if fwd < 0 else math.inf  # depth > 0 when camera 2 is behind
    coeffs = np.stack([-c1.ravel(), *(a.ravel() for a in A)], axis=1)
    roots = polynomial_roots(coeffs, poly.solver)
    p = choose_root(roots, p1.ravel(), p_min, p_max).reshape(shape)
    for _ in range(poly.newton_steps):
        val, der = _poly([-c1, *A], p)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(der != 0, val / der, 0.0)
            new = p - step
            better = np.abs(_poly([-c1, *A], new)[0]) < np.abs(val)
        p = np.where(better & np.isfinite(new), new, p)
    resid, _ = _poly([np.zeros(shape), *Bc], np.where(np.isfinite(p), p, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = p / scale
        raw = 1.0 / delta + fwd
    ok = (np.abs(c1) >= config.threshold_e) & (base.terms["grad"] >= config.threshold_g)
    ok &= np.isfinite(p) & (np.abs(resid) <= poly.max_error)
    with np.errstate(invalid="ignore"):
        valid = ok & np.isfinite(raw) & (raw > 0) & (raw <= config.range_max)
    terms = dict(base.terms)
    terms.update({f"a{k + 1}": A[k] * scale ** (k + 1) for k in range(n)})
    terms.update({f"b{k + 1}": Bc[k] * scale ** (k + 1) for k in range(n)})
    terms.update(delta=delta, delta1=p1 / scale, error_residual=resid, raw_range=raw)
    return RangeResult(range=np.where(valid, raw, config.range_max), valid=valid, terms=terms)
