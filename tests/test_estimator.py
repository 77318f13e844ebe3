"""Known-answer tests of the causal derivative estimator (`rangefx.golden.estimator`).

Reference responses are written out by hand from the discrete recursion of SPEC §3
(``p[k+1] = p[k] + c (x[k] - p[k])``, cascaded ``order`` times) and never reuse the
library's code.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rangefx.golden.estimator import (
    EstimatorConfig,
    causal_estimator_1d,
    estimate_derivatives,
)

VARIANTS = ("paper", "consistent")
POLES = (0.25, 0.5, 1.0)
N = 30


# ---------------------------------------------------------------- impulse responses


def _first_order_impulse(c: float, length: int) -> np.ndarray:
    """p[k] of one section, zero init, unit impulse at k = 0: c (1 - c)^(k-1), p[0] = 0."""
    return np.array([0.0 if k == 0 else c * (1.0 - c) ** (k - 1) for k in range(length)])


def _second_order_impulse(c: float, length: int) -> np.ndarray:
    """Last state of two cascaded sections: (k - 1) c^2 (1 - c)^(k - 2) for k >= 2."""
    return np.array(
        [0.0 if k < 2 else (k - 1) * c**2 * (1.0 - c) ** (k - 2) for k in range(length)]
    )


def _impulse(length: int = N) -> np.ndarray:
    x = np.zeros(length)
    x[0] = 1.0
    return x


@pytest.mark.parametrize("c", POLES)
@pytest.mark.parametrize("variant", VARIANTS)
def test_order1_impulse_response(variant: str, c: float) -> None:
    cfg = EstimatorConfig(pole=c, order=1, variant=variant, bias=0.0, init="zero")
    r1, r2 = causal_estimator_1d(_impulse(), cfg)
    p = _first_order_impulse(c, N + 1)
    delta = np.zeros(N)
    delta[0] = 1.0
    if variant == "paper":
        want_r1 = p[:N]
    else:
        want_r1 = 0.5 * (p[:N] + p[1 : N + 1])
    want_r2 = c * (delta - p[:N])  # the forward difference p[k+1] - p[k]
    np.testing.assert_allclose(r1, want_r1, rtol=0, atol=1e-15)
    np.testing.assert_allclose(r2, want_r2, rtol=0, atol=1e-15)
    # r2 is also literally the forward difference of the paper's r1
    np.testing.assert_allclose(r2, p[1 : N + 1] - p[:N], rtol=0, atol=1e-15)


@pytest.mark.parametrize("c", POLES)
@pytest.mark.parametrize("variant", VARIANTS)
def test_order2_impulse_response(variant: str, c: float) -> None:
    cfg = EstimatorConfig(pole=c, order=2, variant=variant, bias=0.0, init="zero")
    r1, r2, r3 = causal_estimator_1d(_impulse(), cfg)
    y = _second_order_impulse(c, N + 2)
    k = np.arange(N)
    if variant == "paper":
        want = (y[k], y[k + 1] - y[k], y[k + 2] - 2 * y[k + 1] + y[k])
    else:  # every output centred at k + 1
        want = (y[k + 1], 0.5 * (y[k + 2] - y[k]), y[k + 2] - 2 * y[k + 1] + y[k])
    for got, exp in zip((r1, r2, r3), want, strict=True):
        np.testing.assert_allclose(got, exp, rtol=0, atol=1e-15)


@pytest.mark.parametrize("variant", VARIANTS)
def test_impulse_response_along_axis0_matches_axis1(variant: str) -> None:
    cfg = EstimatorConfig(pole=0.5, order=2, variant=variant, bias=0.0, init="zero")
    x = np.zeros((N, 3))
    x[0, :] = 1.0
    y = _second_order_impulse(0.5, N + 2)
    r1 = causal_estimator_1d(x, cfg, axis=0)[0]
    want = y[:N] if variant == "paper" else y[1 : N + 1]
    for col in range(3):
        np.testing.assert_allclose(r1[:, col], want, rtol=0, atol=1e-15)


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("variant", VARIANTS)
def test_dc_gain_is_exact(variant: str, order: int) -> None:
    cfg = EstimatorConfig(pole=0.3, order=order, variant=variant, init="first")
    outs = causal_estimator_1d(np.full(25, 37.25), cfg)
    assert np.all(outs[0] == 37.25)
    for d in outs[1:]:
        assert np.all(d == 0.0)


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("variant", VARIANTS)
def test_constant_image_gives_exact_image_and_zero_derivatives(variant: str, order: int) -> None:
    cfg = EstimatorConfig(pole=0.5, order=order, variant=variant, bias=16.0)
    d = estimate_derivatives(np.full((10, 14), 93.5), cfg)
    np.testing.assert_array_equal(d.E, 93.5)
    fields = [d.Ex, d.Ey] + ([d.Exx, d.Eyy, d.Exy] if order == 2 else [])
    for arr in fields:
        np.testing.assert_array_equal(arr, 0.0)
    if order == 1:
        assert d.Exx is None and d.Eyy is None and d.Exy is None


# ---------------------------------------------------------------- polynomial inputs

SETTLED = 50  # (1 - 0.5)^50 ~ 1e-15: transients of c = 0.5 have died out


@pytest.mark.parametrize("order", [1, 2])
def test_consistent_x_ramp(order: int) -> None:
    slope = 1.75
    img = np.tile(slope * np.arange(96, dtype=float) + 3.0, (20, 1))
    cfg = EstimatorConfig(pole=0.5, order=order, variant="consistent")
    d = estimate_derivatives(img, cfg)
    np.testing.assert_allclose(d.Ex[:, SETTLED:], slope, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(d.Ey, 0.0)  # columns are constant: exactly zero
    if order == 2:
        np.testing.assert_allclose(d.Exx[:, SETTLED:], 0.0, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(d.Exy, 0.0)


@pytest.mark.parametrize("order", [1, 2])
def test_consistent_y_ramp(order: int) -> None:
    slope = -2.5
    img = np.tile((slope * np.arange(96, dtype=float) + 300.0)[:, None], (1, 12))
    cfg = EstimatorConfig(pole=0.5, order=order, variant="consistent")
    d = estimate_derivatives(img, cfg)
    np.testing.assert_allclose(d.Ey[SETTLED:, :], slope, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(d.Ex, 0.0)  # rows are constant: exactly zero
    if order == 2:
        np.testing.assert_allclose(d.Eyy[SETTLED:, :], 0.0, rtol=0, atol=1e-9)


def test_consistent_order2_quadratic_second_derivative() -> None:
    a = 0.0125
    x = np.arange(128, dtype=float)
    img = np.tile(a * x**2 + 0.5 * x + 10.0, (6, 1))
    cfg = EstimatorConfig(pole=0.5, order=2, variant="consistent")
    d = estimate_derivatives(img, cfg)
    np.testing.assert_allclose(d.Exx[:, 70:], 2 * a, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(d.Eyy, 0.0)


def test_consistent_order2_y_quadratic_second_derivative() -> None:
    a = -0.02
    y = np.arange(128, dtype=float)
    img = np.tile((a * y**2 + 200.0)[:, None], (1, 5))
    cfg = EstimatorConfig(pole=0.5, order=2, variant="consistent")
    d = estimate_derivatives(img, cfg)
    np.testing.assert_allclose(d.Eyy[70:, :], 2 * a, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(d.Exx, 0.0)


@pytest.mark.parametrize("bias", [0.0, 16.0, 1000.0])
def test_paper_x_ramp_with_bias(bias: float) -> None:
    # Columns are constant, so s1 == r1 exactly and s1 r2 / r1 == r2 -> slope.
    slope = 0.8
    img = np.tile(slope * np.arange(96, dtype=float) + 40.0, (16, 1))
    cfg = EstimatorConfig(pole=0.5, order=1, variant="paper", bias=bias)
    d = estimate_derivatives(img, cfg)
    np.testing.assert_array_equal(d.taps["s1"], d.taps["r1"])
    np.testing.assert_allclose(d.Ex[:, SETTLED:], slope, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(d.Ey, 0.0)


def test_paper_bias_changes_ex_on_nonseparable_image() -> None:
    """SPEC §3: in the paper variant the bias alters s1 r2 / r1 (not so in consistent)."""
    rng = np.random.default_rng(3)
    img = rng.uniform(0, 255, size=(12, 16))
    p0 = estimate_derivatives(img, EstimatorConfig(variant="paper", bias=1.0))
    p1 = estimate_derivatives(img, EstimatorConfig(variant="paper", bias=500.0))
    assert np.max(np.abs(p0.Ex - p1.Ex)) > 1e-3
    c0 = estimate_derivatives(img, EstimatorConfig(variant="consistent", bias=1.0))
    c1 = estimate_derivatives(img, EstimatorConfig(variant="consistent", bias=500.0))
    np.testing.assert_allclose(c0.Ex, c1.Ex, rtol=0, atol=1e-9)
    np.testing.assert_allclose(c0.Ey, c1.Ey, rtol=0, atol=1e-9)
    np.testing.assert_allclose(c0.E, c1.E, rtol=0, atol=1e-9)


# ---------------------------------------------------------------- causality


def _outputs(d) -> list[np.ndarray]:
    arrs = [d.E, d.Ex, d.Ey, d.Exx, d.Eyy, d.Exy, *d.taps.values()]
    return [a for a in arrs if a is not None]


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("variant", VARIANTS)
def test_causality_in_raster_order(variant: str, order: int) -> None:
    rng = np.random.default_rng(11)
    m, n = 12, 16
    img = rng.uniform(0, 255, size=(m, n))
    cfg = EstimatorConfig(pole=0.5, order=order, variant=variant)
    base = _outputs(estimate_derivatives(img, cfg))
    flat_index = np.arange(m * n).reshape(m, n)
    for j, i in [(0, 0), (0, 7), (3, 0), (5, 9), (11, 15), (7, 15)]:
        changed = img.copy()
        changed[j, i] += 57.0
        new = _outputs(estimate_derivatives(changed, cfg))
        before = flat_index < j * n + i
        for a, b in zip(base, new, strict=True):
            np.testing.assert_array_equal(a[before], b[before])
        # ...and the change does reach later outputs (the check is not vacuous)
        assert any(not np.array_equal(a, b) for a, b in zip(base, new, strict=True))


# ---------------------------------------------------------------- validation


@pytest.mark.parametrize("pole", [0.0, -0.1, 2.0, 5.0])
def test_unstable_pole_rejected(pole: float) -> None:
    with pytest.raises(ValueError, match="unstable"):
        EstimatorConfig(pole=pole)


def test_oscillating_pole_rejected() -> None:
    with pytest.raises(ValueError, match="oscillating"):
        EstimatorConfig(pole=1.5)


@pytest.mark.parametrize("pole", [math.nan, math.inf, "0.5", None])
def test_non_finite_pole_rejected(pole) -> None:
    with pytest.raises(ValueError):
        EstimatorConfig(pole=pole)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"order": 0},
        {"order": 5},
        {"order": 1.5},
        {"variant": "exact"},
        {"init": "last"},
        {"bias": -1.0},
        {"bias": math.nan},
    ],
)
def test_bad_config_rejected(kwargs: dict) -> None:
    with pytest.raises(ValueError):
        EstimatorConfig(**kwargs)


@pytest.mark.parametrize("c", [1e-6, 0.25, 1.0])
def test_valid_poles_accepted(c: float) -> None:
    assert EstimatorConfig(pole=c).pole == c


def test_from_continuous() -> None:
    with pytest.raises(ValueError, match="unstable"):
        EstimatorConfig.from_continuous(5.0, discretisation="euler")
    cfg = EstimatorConfig.from_continuous(5.0, discretisation="zoh", variant="consistent")
    assert cfg.pole == pytest.approx(1.0 - math.exp(-5.0), rel=1e-15)
    assert cfg.variant == "consistent"
    assert EstimatorConfig.from_continuous(0.5, 1.0).pole == 0.5  # SPIE a = 0.5, h = 1
    assert EstimatorConfig.from_continuous(0.25, 2.0, discretisation="zoh").pole == (
        pytest.approx(1.0 - math.exp(-0.5), rel=1e-15)
    )
    for bad in [
        {"a": 0.0},
        {"a": -1.0},
        {"a": 1.0, "h": 0.0},
        {"a": 0.5, "discretisation": "tustin"},
    ]:
        with pytest.raises(ValueError):
            EstimatorConfig.from_continuous(**bad)


# ---------------------------------------------------------------- bad images


@pytest.mark.parametrize(
    "image",
    [
        np.zeros((4, 4, 3)),
        np.zeros(8),
        np.zeros((1, 8)),
        np.array([[1.0, np.nan], [2.0, 3.0]]),
        np.array([[1.0, np.inf], [2.0, 3.0]]),
        np.array([["a", "b"], ["c", "d"]]),
        np.array([[1, 2], [3, 4]], dtype=object),
        np.ones((3, 3), dtype=complex),
    ],
    ids=["3d", "1d", "one-row", "nan", "inf", "str", "object", "complex"],
)
def test_estimate_derivatives_rejects_bad_images(image: np.ndarray) -> None:
    with pytest.raises(ValueError):
        estimate_derivatives(image)


def test_integer_images_accepted_and_equal_float() -> None:
    rng = np.random.default_rng(5)
    img = rng.integers(0, 256, size=(8, 9), dtype=np.uint8)
    a = estimate_derivatives(img)
    b = estimate_derivatives(img.astype(float))
    np.testing.assert_array_equal(a.Ex, b.Ex)
    np.testing.assert_array_equal(a.E, b.E)
