"""Tests of the SPIE ranging polynomial of degree 1..4 (`rangefx.golden.polynomial`)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rangefx.golden.estimator import Derivatives, EstimatorConfig, estimate_derivatives
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import G3_POLY_METHODS, METHODS, run_method
from rangefx.golden.polynomial import (
    PolynomialConfig,
    backward_error,
    choose_root,
    polynomial_coefficients,
    polynomial_roots,
    range_g3_poly,
)
from rangefx.golden.ranging import RangingConfig, range_g3
from rangefx.golden.scenes import render_plane, render_scene

LOOSE = RangingConfig(threshold_e=0.5, threshold_g=0.5, range_max=1e3)
VARIANTS = ("paper", "consistent")


# ---------------------------------------------------------------- closed-form roots


def _match(got: np.ndarray, ref: np.ndarray, tol: float) -> None:
    """Every reference root has a distinct computed root within tol (relative)."""
    left = list(got)
    for x in ref:
        i = int(np.argmin([abs(g - x) for g in left]))
        assert abs(left[i] - x) <= tol * max(1.0, abs(x)), (got, ref)
        left.pop(i)


@pytest.mark.parametrize("degree", [1, 2, 3, 4])
@pytest.mark.parametrize("seed", range(5))
def test_closed_form_roots_match_np_roots(degree: int, seed: int) -> None:
    """Random polynomials with distinct real and complex-pair roots, 200 per case."""
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(200):
        roots = list(rng.uniform(-5, 5, degree))
        if degree >= 2 and rng.random() < 0.5:  # a complex pair
            re, im = rng.uniform(-3, 3), rng.uniform(0.1, 3)
            roots[:2] = [re + 1j * im, re - 1j * im]
        rows.append(np.real(np.poly(roots))[::-1] * rng.uniform(0.5, 3))
    coeffs = np.array(rows)
    closed = polynomial_roots(coeffs, "closed")
    companion = polynomial_roots(coeffs, "companion")
    for i in range(len(rows)):
        ref = np.roots(coeffs[i, ::-1])
        _match(closed[i], ref, 1e-7)
        _match(companion[i], ref, 1e-12)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.floats(-100, 100, allow_nan=False, allow_subnormal=False), min_size=3, max_size=5
    ).filter(lambda c: abs(c[-1]) >= 1e-3)
)
# a double root at 0 beside roots 1e4 apart: Ferrari's formulas alone gave +-2.06e-4
@example(coeffs=[0.0, 0.0, 24.0, 82.5625, 0.0625])
# roots near 0.26 and -3520: Ferrari's formulas alone left a relative residual of 1.2e-5
@example(coeffs=[1.0, 0.0, 0.0, 55.0, 0.015625])
# a root near -0.0369 beside -19968: Ferrari's formulas 17 % off, two Newton steps not enough
@example(coeffs=[0.00390625, 0.0, 0.0, 78.0, 0.00390625])
def test_closed_form_roots_are_roots(coeffs: list[float]) -> None:
    """Backward error: every closed-form root makes |P| small relative to its terms."""
    c = np.array([coeffs])
    roots = polynomial_roots(c, "closed")[0]
    assert np.all(np.isfinite(roots))
    for x in roots:
        terms = np.array([ck * x**k for k, ck in enumerate(coeffs)])
        # multiple roots are found only to ~eps^(1/m): allow for a quadruple root
        assert abs(terms.sum()) <= 1e-6 * max(1.0, np.abs(terms).sum())


_SIGNED_MAGNITUDE = st.builds(
    lambda sign, e: sign * 10.0**e, st.sampled_from([-1.0, 1.0]), st.floats(-4, 4)
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_SIGNED_MAGNITUDE, min_size=4, max_size=5))
# a cubic with roots near 7.2e-4 beside 8.5e6 and a quartic with roots near 2 beside
# -3.5e7: the formulas and their polish returned roots with a relative backward error
# of 1.0 (0.4 % of such cubics' roots, 2.5 % of quartics'); such rows now go to np.roots
@example(
    coeffs=[-3.7572825886734833, -4.1561457343661663e-4, -6566.841054675485, 7.690068907966382e-4]
)
@example(coeffs=[-1.0986505078219486e-3, -5.2e-4, -2.57e-3, 5158.778539022815, 1.4584e-4])
# hypothesis found: np.roots alone left a backward error of 1.3e-9 (now polished too)
@example(coeffs=[-1e-4, -(10**1.5), -1.0, -1000.0, -1e-4])
# CI found: the polish carried a poor root near 1.755 onto the root at -0.0019, so each
# root was a root (backward error small) and one root was missing; such rows now go to
# np.roots too
@example(coeffs=[-1.0, -526.1158829895603, -1.0, 171.5437896342879, -0.00017154378963428788])
def test_closed_form_roots_are_roots_across_magnitudes(coeffs: list[float]) -> None:
    """Coefficients log-uniform over 1e-4..1e4 (roots up to ~1e8 apart): every root has a
    relative backward error <= 1e-9, and the closed solver finds np.roots's roots."""
    c = np.array([coeffs])
    roots = polynomial_roots(c, "closed")
    assert np.all(np.isfinite(roots))
    assert backward_error(c, roots).max() <= 1e-9
    ref = np.roots(c[0, ::-1])
    _match(roots[0], ref, 1e-6 * max(1.0, float(np.abs(ref).max())))


def test_backward_error_is_zero_at_exact_roots_and_one_far_away() -> None:
    c = np.array([[-2.0, 1.0], [6.0, -5.0]])  # x - 2, 6 - 5x
    err = backward_error(c, np.array([[2.0 + 0j], [1.2 + 0j]]))
    assert err.max() == 0.0
    far = backward_error(np.array([[1.0, 0.0, 1.0]]), np.array([[1e9 + 0j, 0.0 + 0j]]))
    np.testing.assert_allclose(far, [[1.0, 1.0]])
    assert backward_error(c, np.array([[np.nan + 0j], [np.inf + 0j]])).tolist() == [[np.inf]] * 2


def test_degenerate_leading_coefficients_drop_the_degree() -> None:
    c = np.array([[-2.0, 1.0, 0.0, 0.0, 0.0], [6.0, -5.0, 1.0, 0.0, 0.0], [0, 0, 0, 0, 0.0]])
    r = polynomial_roots(c)
    assert r[0, 0] == 2.0 and np.isnan(r[0, 1:]).all()
    np.testing.assert_allclose(np.sort(r[1, :2].real), [2.0, 3.0])
    assert np.isnan(r[1, 2:]).all()
    assert np.isnan(r[2]).all()  # zero polynomial: no root


def test_polynomial_roots_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="shape"):
        polynomial_roots(np.ones(3))
    with pytest.raises(ValueError, match="root solver"):
        polynomial_roots(np.ones((1, 3)), "newton")
    with pytest.raises(ValueError, match="degree 4"):
        polynomial_roots(np.ones((1, 6)), "closed")


def test_root_rule_takes_the_admissible_real_root_nearest_degree_one() -> None:
    roots = np.array(
        [
            [1.9, 2.3, -1.0, np.nan],  # nearest to 2.0 -> 1.9
            [1.0 + 0.5j, 1.0 - 0.5j, 5.0, np.nan],  # complex pair excluded -> 5.0
            [0.01, 2.5, 3.0, 7.0],  # 0.01 below p_min -> 2.5
            [-1.0, 1.0 + 1j, 1.0 - 1j, np.nan],  # nothing admissible -> NaN
        ]
    )
    got = choose_root(roots, np.array([2.0, 1.0, 0.0, 1.0]), 0.1)
    np.testing.assert_array_equal(got[:3], [1.9, 5.0, 2.5])
    assert np.isnan(got[3])


# ---------------------------------------------------------------- coefficients


def _sinusoid(x: np.ndarray, k: float, amp: float, phase: float) -> Derivatives:
    """Exact derivatives of ``amp sin(k x + phase)`` in the consistent estimator's taps."""
    taps = {f"u{a}0": np.vstack([amp * k**a * np.sin(k * x + phase + a * np.pi / 2)] * 2)
            for a in range(5)}  # fmt: skip
    zero = np.zeros_like(taps["u00"])
    taps.update({f"u{a}{b}": zero for a in range(5) for b in range(1, 5 - a)})
    taps["u00"] = taps["u00"] + 100.0
    return Derivatives(E=taps["u00"], Ex=taps["u10"], Ey=zero, taps=taps)


def _sinusoid_errors(disparity: float) -> list[float]:
    f, depth, k, n = 100.0, 20.0, 2 * np.pi / 16, 200
    cam = PinholeCamera(n, 2, f)
    x = cam.pixel_grid()[0][0]
    d1 = _sinusoid(x, k, 40.0, 0.3)
    d2 = _sinusoid(x + disparity, k, 40.0, 0.3)  # E2(x) = E1(x - r), r = -disparity
    motion = MotionIncrement.stereo(disparity * depth / f)
    errs = []
    for degree in (1, 2, 3, 4):
        r = range_g3_poly(d1, d2, cam, motion, LOOSE, PolynomialConfig(degree=degree))
        assert r.valid.all()
        errs.append(float(np.median(np.abs(r.range - depth) / depth)))
    return errs


def test_truncation_error_orders_on_exact_derivatives() -> None:
    """With exact derivatives the only error is the Taylor truncation of eqs 4-6.

    Degree 1 leaves an O(r³) term in eq 10, i.e. a relative range error O((k r)²);
    degree 3 cancels it (O((k r)⁴)). Degree 2 adds ``a2 δ² ≈ -¼ r³ D³E`` alone, while the
    complete r³ term is ``-1/12 r³ D³E``: its error is twice degree 1's (the odd degree
    completes each order; degree 4 likewise adds part of the r⁵ term).
    """
    small, double = _sinusoid_errors(0.5), _sinusoid_errors(1.0)
    assert double[0] / small[0] == pytest.approx(4.0, rel=0.1)
    assert double[2] / small[2] == pytest.approx(16.0, rel=0.15)
    assert small[1] / small[0] == pytest.approx(2.0, rel=0.1)
    assert small[2] < 0.01 * small[0]
    assert small[3] < small[2]


def test_coefficients_match_the_printed_low_order_terms() -> None:
    """a1 = ½(g1+g2)·v, a2 = ¼ vᵀ(H2-H1)v (eq 6), b1 = (g2-g1)·v, b2 = ½ vᵀ(H1+H2)v (eq 7)."""
    rng = np.random.default_rng(3)
    e1 = rng.normal(128, 30, (24, 40))
    e2 = np.roll(e1, 1, axis=1) + rng.normal(0, 1, e1.shape)
    cfg = EstimatorConfig(order=2, variant="consistent")
    d1, d2 = estimate_derivatives(e1, cfg), estimate_derivatives(e2, cfg)
    cam = PinholeCamera(40, 24, 50.0)
    motion = MotionIncrement.from_attitudes(position2=(0.3, 0.2, -0.1))  # fwd, right, down
    fwd, right, down = motion.camera_displacement
    xp, yp = cam.pixel_grid()
    vx, vy = xp * fwd - 50.0 * right, yp * fwd - 50.0 * down
    (a1, a2), (b1, b2) = polynomial_coefficients(d1, d2, cam, motion, 2)

    def quad(d: Derivatives) -> np.ndarray:
        return d.Exx * vx**2 + 2 * d.Exy * vx * vy + d.Eyy * vy**2

    np.testing.assert_allclose(a1, 0.5 * ((d1.Ex + d2.Ex) * vx + (d1.Ey + d2.Ey) * vy))
    np.testing.assert_allclose(a2, 0.25 * (quad(d2) - quad(d1)), atol=1e-9)
    np.testing.assert_allclose(b1, (d2.Ex - d1.Ex) * vx + (d2.Ey - d1.Ey) * vy, atol=1e-9)
    np.testing.assert_allclose(b2, 0.5 * (quad(d1) + quad(d2)), atol=1e-9)


# ---------------------------------------------------------------- ranging


@pytest.fixture(scope="module")
def plane_pair():
    f, depth, disparity = 77.0, 20.0, 3.0
    return render_plane(
        depth=depth, size=(64, 96), f_px=f, baseline=disparity * depth / f, noise_sigma=0.0,
        texture_scale=0.5,
    )  # fmt: skip


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("order", [1, 2, 4])
def test_degree_one_is_range_g3_bit_for_bit(plane_pair, variant: str, order: int) -> None:
    s = plane_pair
    cfg = EstimatorConfig(order=order, variant=variant)
    d1, d2 = estimate_derivatives(s.image1, cfg), estimate_derivatives(s.image2, cfg)
    ref = range_g3(d1, d2, s.camera, s.motion, LOOSE)
    got = range_g3_poly(d1, d2, s.camera, s.motion, LOOSE, PolynomialConfig(degree=1))
    np.testing.assert_array_equal(got.range, ref.range)
    np.testing.assert_array_equal(got.valid, ref.valid)


def test_degree_one_is_range_g3_on_a_lab_crop() -> None:
    s = render_scene("lab", size=(96, 96))
    cfg = EstimatorConfig(order=3, variant="paper")
    d1, d2 = estimate_derivatives(s.image1, cfg), estimate_derivatives(s.image2, cfg)
    ref = range_g3(d1, d2, s.camera, s.motion)
    got = range_g3_poly(d1, d2, s.camera, s.motion, None, PolynomialConfig(degree=1))
    np.testing.assert_array_equal(got.range, ref.range)


def test_higher_odd_degree_helps_at_three_pixels_disparity(plane_pair) -> None:
    """Noise-free textured plane, 3 px disparity: the truncation error dominates and the
    degree-3 and degree-4 polynomials beat degree 1 (measured medians 7.8%, 3.8%, 2.2%)."""
    s = plane_pair
    cfg = EstimatorConfig(order=4, variant="consistent")
    d1, d2 = estimate_derivatives(s.image1, cfg), estimate_derivatives(s.image2, cfg)
    ranging = RangingConfig(threshold_e=1.0, threshold_g=1.0, range_max=1e3)
    err = {}
    for degree in (1, 3, 4):
        r = range_g3_poly(d1, d2, s.camera, s.motion, ranging, PolynomialConfig(degree=degree))
        ok = r.valid[16:, 16:]
        assert ok.mean() > 0.6
        err[degree] = np.median(np.abs(r.range[16:, 16:][ok] - 20.0) / 20.0)
    assert err[3] < 0.7 * err[1]
    assert err[4] < 0.7 * err[1]


@pytest.mark.parametrize("degree", [2, 3, 4])
def test_companion_solver_agrees_with_closed_form(plane_pair, degree: int) -> None:
    s = plane_pair
    cfg = EstimatorConfig(order=degree, variant="consistent")
    d1, d2 = estimate_derivatives(s.image1, cfg), estimate_derivatives(s.image2, cfg)
    crop = np.s_[20:28, 30:60]
    res = {
        solver: range_g3_poly(
            d1, d2, s.camera, s.motion, LOOSE, PolynomialConfig(degree=degree, solver=solver)
        )
        for solver in ("closed", "companion")
    }
    np.testing.assert_array_equal(res["closed"].valid[crop], res["companion"].valid[crop])
    np.testing.assert_allclose(res["closed"].range[crop], res["companion"].range[crop], rtol=1e-9)


def test_terms_and_invalid_pixels(plane_pair) -> None:
    s = plane_pair
    cfg = EstimatorConfig(order=3, variant="consistent")
    d1, d2 = estimate_derivatives(s.image1, cfg), estimate_derivatives(s.image2, cfg)
    r = range_g3_poly(d1, d2, s.camera, s.motion, LOOSE, PolynomialConfig(degree=3))
    assert {"c1", "a1", "a2", "a3", "b1", "b2", "b3", "delta", "delta1", "error_residual"} <= set(
        r.terms
    )
    v = r.valid
    np.testing.assert_allclose(r.range[v], 1.0 / r.terms["delta"][v])  # stereo: Δz0 = 0
    np.testing.assert_allclose(  # the chosen root satisfies eq 10
        sum(r.terms[f"a{k}"] * r.terms["delta"] ** k for k in (1, 2, 3))[v],
        r.terms["c1"][v],
        atol=1e-9,
    )
    assert np.all(r.range[~v] == LOOSE.range_max)
    strict = range_g3_poly(
        d1, d2, s.camera, s.motion, LOOSE, PolynomialConfig(degree=3, max_error=0.5)
    )
    assert not np.any(strict.valid & ~v)
    assert np.all(np.abs(strict.terms["error_residual"][strict.valid]) <= 0.5)


def test_degree_needs_estimator_order(plane_pair) -> None:
    s = plane_pair
    d = estimate_derivatives(s.image1, EstimatorConfig(order=2, variant="consistent"))
    with pytest.raises(ValueError, match="order >= 3"):
        range_g3_poly(d, d, s.camera, s.motion, LOOSE, PolynomialConfig(degree=3))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"degree": 0}, "degree"),
        ({"degree": 5}, "degree"),
        ({"degree": 2.5}, "degree"),
        ({"solver": "bisect"}, "solver"),
        ({"newton_steps": -1}, "newton_steps"),
        ({"max_error": 0.0}, "max_error"),
        ({"max_error": math.nan}, "max_error"),
    ],
)
def test_config_validation(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        PolynomialConfig(**kwargs)


@pytest.mark.parametrize("name", G3_POLY_METHODS)
def test_named_methods(plane_pair, name: str) -> None:
    assert name in METHODS
    s = plane_pair
    degree, variant = int(name[3]), name.split("_")[1]
    got = run_method(name, s.image1, s.image2, s.camera, s.motion, ranging=LOOSE)
    cfg = EstimatorConfig(order=degree, variant=variant)
    d1, d2 = estimate_derivatives(s.image1, cfg), estimate_derivatives(s.image2, cfg)
    ref = range_g3_poly(d1, d2, s.camera, s.motion, LOOSE, PolynomialConfig(degree=degree))
    np.testing.assert_array_equal(got.range, ref.range)
