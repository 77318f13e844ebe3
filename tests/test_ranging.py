"""Known-answer tests of the ranging equations (`rangefx.golden.ranging`)."""

from __future__ import annotations

import numpy as np
import pytest

from rangefx.golden.estimator import Derivatives, EstimatorConfig, estimate_derivatives
from rangefx.golden.geometry import MotionIncrement, PinholeCamera, k_coefficients
from rangefx.golden.methods import run_method
from rangefx.golden.ranging import RangingConfig, range_g3, range_g4
from rangefx.golden.scenes import render_scene

VARIANTS = ("paper", "consistent")
LOOSE = RangingConfig(threshold_e=0.1, threshold_g=0.1, range_max=1e6, min_denominator=0.1)


# ---------------------------------------------------------------- G3 on a linear ramp


@pytest.mark.parametrize("d", [0.3, 1.0, 2.5])
@pytest.mark.parametrize("variant", VARIANTS)
def test_g3_linear_ramp_known_disparity(variant: str, d: float) -> None:
    f, z, g = 120.0, 20.0, 2.0
    b = d * z / f  # baseline so that the disparity f b / z is d
    cam = PinholeCamera(96, 32, f)
    xp, _ = cam.pixel_grid()
    e1 = g * xp + 100.0
    e2 = g * (xp + d) + 100.0  # right camera: E2(xp) = E1(xp + d)
    cfg = EstimatorConfig(pole=0.5, variant=variant)
    d1, d2 = estimate_derivatives(e1, cfg), estimate_derivatives(e2, cfg)
    res = range_g3(d1, d2, cam, MotionIncrement.stereo(b), LOOSE)
    steady = np.s_[:, 40:]
    np.testing.assert_allclose(res.range[steady], z, rtol=1e-6)
    assert res.valid[steady].all()
    np.testing.assert_allclose(f * b / res.range[steady], d, rtol=1e-6)
    np.testing.assert_allclose(res.terms["c1"][steady], -g * d, rtol=1e-9)
    # run_method gives the same answer through the named-method path
    res2 = run_method(f"g3_{variant}", e1, e2, cam, MotionIncrement.stereo(b), ranging=LOOSE)
    np.testing.assert_array_equal(res2.range, res.range)


@pytest.mark.parametrize("variant", VARIANTS)
def test_g3_vertical_baseline_on_y_ramp(variant: str) -> None:
    """Camera 2 displaced downwards: disparity along y, image a y-ramp."""
    f, z, dy, g = 100.0, 10.0, 1.5, 3.0
    b = dy * z / f
    cam = PinholeCamera(16, 96, f)
    _, yp = cam.pixel_grid()
    e1 = g * yp + 200.0
    e2 = g * (yp + dy) + 200.0
    motion = MotionIncrement.from_attitudes(position2=(0.0, 0.0, b))  # NED down = camera down
    np.testing.assert_allclose(motion.camera_displacement, [0.0, 0.0, b])
    cfg = EstimatorConfig(pole=0.5, variant=variant)
    res = range_g3(estimate_derivatives(e1, cfg), estimate_derivatives(e2, cfg), cam, motion, LOOSE)
    np.testing.assert_allclose(res.range[50:, :], z, rtol=1e-6)


def test_g3_thresholds_and_range_max() -> None:
    f, z, g, d = 120.0, 20.0, 2.0, 1.0
    b = d * z / f
    cam = PinholeCamera(96, 8, f)
    xp, _ = cam.pixel_grid()
    cfg = EstimatorConfig(variant="consistent")
    d1 = estimate_derivatives(g * xp + 100.0, cfg)
    d2 = estimate_derivatives(g * (xp + d) + 100.0, cfg)
    motion = MotionIncrement.stereo(b)
    steady = np.s_[:, 40:]
    # |c1| = 2 < T_E = 2.5: nothing valid, everything at range_max
    res = range_g3(d1, d2, cam, motion, RangingConfig(threshold_e=2.5, threshold_g=0.1))
    assert not res.valid.any()
    np.testing.assert_array_equal(res.range, 100.0)
    # gradient 2 < T_g = 3
    res = range_g3(d1, d2, cam, motion, RangingConfig(threshold_e=0.1, threshold_g=3.0))
    assert not res.valid[steady].any()
    # z = 20 > range_max = 15
    res = range_g3(d1, d2, cam, motion, RangingConfig(0.1, 0.1, range_max=15.0))
    assert not res.valid[steady].any()
    np.testing.assert_array_equal(res.range[steady], 15.0)
    res = range_g3(d1, d2, cam, motion, RangingConfig(0.1, 0.1, range_max=25.0))
    assert res.valid[steady].all()
    assert res.valid_fraction >= 56 / 96


# ---------------------------------------------------------------- G4 vs G3


@pytest.fixture(scope="module")
def lab_scene():
    return render_scene("lab", size=(96, 96))


def _check_g4_equals_g3(d1, d2, cam, motion, config) -> None:
    r3 = range_g3(d1, d2, cam, motion, config)
    r4 = range_g4(d1, d2, cam, motion, config)
    raw3, raw4 = r3.terms["raw_range"], r4.terms["raw_range"]
    both = np.isfinite(raw3) & np.isfinite(raw4)
    np.testing.assert_array_equal(np.isfinite(raw3), np.isfinite(raw4))
    assert both.sum() > 0.5 * both.size
    np.testing.assert_allclose(raw4[both], raw3[both], rtol=1e-9, atol=0)
    np.testing.assert_array_equal(r4.valid, r3.valid)
    assert r3.valid.any()
    np.testing.assert_allclose(r4.range, r3.range, rtol=1e-9, atol=0)


@pytest.mark.parametrize("variant", VARIANTS)
def test_g4_reduces_to_g3_on_lab_scene(lab_scene, variant: str) -> None:
    cfg = EstimatorConfig(variant=variant)
    d1 = estimate_derivatives(lab_scene.image1, cfg)
    d2 = estimate_derivatives(lab_scene.image2, cfg)
    _check_g4_equals_g3(d1, d2, lab_scene.camera, lab_scene.motion, RangingConfig())


def _synthetic_pair(shape=(40, 56), shift=(0.7, 0.4)) -> tuple[np.ndarray, np.ndarray]:
    m, n = shape
    jj, ii = np.mgrid[0:m, 0:n].astype(float)

    def pattern(x, y):
        return 120 + 50 * np.sin(0.31 * x + 0.1 * y) + 40 * np.cos(0.23 * y - 0.05 * x)

    return pattern(ii, jj), pattern(ii + shift[0], jj + shift[1])


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("move", [(2.0, 0.5, 0.0), (3.0, -0.4, 0.2), (-1.0, 0.3, -0.1)])
def test_g4_reduces_to_g3_translating(variant: str, move) -> None:
    e1, e2 = _synthetic_pair()
    cam = PinholeCamera(56, 40, 60.0)
    motion = MotionIncrement.from_attitudes(position1=(5.0, 1.0, -2.0), position2=move)
    cfg = EstimatorConfig(variant=variant)
    d1, d2 = estimate_derivatives(e1, cfg), estimate_derivatives(e2, cfg)
    _check_g4_equals_g3(d1, d2, cam, motion, RangingConfig(range_max=1e4))


@pytest.mark.parametrize("variant", VARIANTS)
def test_g4_printed_sign_flips_about_twice_forward(variant: str) -> None:
    """SPEC §9: with c1 = E2 - E1 (as printed) x_c = 2 Δx_forward - depth."""
    e1, e2 = _synthetic_pair()
    cam = PinholeCamera(56, 40, 60.0)
    fwd = 2.5
    motion = MotionIncrement.from_attitudes(position2=(fwd, 0.4, 0.0))
    np.testing.assert_allclose(motion.camera_displacement, [fwd, 0.4, 0.0])
    cfg = EstimatorConfig(variant=variant)
    d1, d2 = estimate_derivatives(e1, cfg), estimate_derivatives(e2, cfg)
    fixed = range_g4(d1, d2, cam, motion, c1_sign="fixed").terms["raw_range"]
    printed = range_g4(d1, d2, cam, motion, c1_sign="printed").terms["raw_range"]
    both = np.isfinite(fixed) & np.isfinite(printed)
    assert both.sum() > 0.5 * both.size
    np.testing.assert_allclose(
        printed[both], 2 * fwd - fixed[both], rtol=1e-9, atol=1e-9 * np.abs(fixed[both]).max()
    )


def test_g4_with_rotation_exact_disparity() -> None:
    """Eq 28 on a linear image with the exact eq 25-26 disparity returns the range."""
    m = MotionIncrement.from_attitudes(
        camera_angles=(0.02, -0.03, 0.01),
        attitude1=(0.1, 0.05, -0.02),
        attitude2=(0.1015, 0.0505, -0.0195),
        position1=(0.0, 0.0, -10.0),
        position2=(2.0, -0.2, -10.05),
    )
    cam = PinholeCamera(64, 48, 80.0)
    xp, yp = cam.pixel_grid()
    x_c = 50.0 + 0.2 * xp  # an arbitrary known range map
    (k0, k1, k2), (k3, k4, k5) = k_coefficients(m, xp, yp, cam.f_px)
    den = 1 + k0 + k3 / x_c
    dxp = (cam.f_px * k1 - xp * k0 + (cam.f_px * k4 - xp * k3) / x_c) / den
    dyp = (cam.f_px * k2 - yp * k0 + (cam.f_px * k5 - yp * k3) / x_c) / den
    gx, gy = 3.0, -1.5
    # Build the derivative pairs directly: exact gradients and E1 - E2 = g . disparity
    e1 = 100.0 + np.zeros_like(xp)
    e2 = e1 - (gx * dxp + gy * dyp)
    zeros = np.zeros_like(xp)
    d1 = Derivatives(E=e1, Ex=zeros + gx, Ey=zeros + gy)
    d2 = Derivatives(E=e2, Ex=zeros + gx, Ey=zeros + gy)
    res = range_g4(d1, d2, cam, m, RangingConfig(0.0, 0.0, range_max=1e3, min_denominator=0.0))
    np.testing.assert_allclose(res.terms["raw_range"], x_c, rtol=1e-9)


# ---------------------------------------------------------------- bad input


def _derivs(shape):
    return estimate_derivatives(np.arange(np.prod(shape), dtype=float).reshape(shape))


def test_mismatched_shapes_rejected() -> None:
    cam = PinholeCamera(10, 8, 50.0)
    motion = MotionIncrement.stereo(0.1)
    for solve in (range_g3, range_g4):
        with pytest.raises(ValueError):
            solve(_derivs((8, 10)), _derivs((8, 12)), cam, motion)
        with pytest.raises(ValueError):
            solve(_derivs((8, 12)), _derivs((8, 12)), cam, motion)  # camera is 8x10
    with pytest.raises(ValueError):
        run_method("g3_paper", np.zeros((8, 10)), np.zeros((8, 12)), cam, motion)


def test_zero_motion_rejected() -> None:
    cam = PinholeCamera(10, 8, 50.0)
    still = MotionIncrement.from_attitudes()
    for solve in (range_g3, range_g4):
        with pytest.raises(ValueError):
            solve(_derivs((8, 10)), _derivs((8, 10)), cam, still)


def test_bad_c1_sign_and_method() -> None:
    cam = PinholeCamera(10, 8, 50.0)
    d = _derivs((8, 10))
    with pytest.raises(ValueError):
        range_g4(d, d, cam, MotionIncrement.stereo(0.1), c1_sign="E2-E1")
    with pytest.raises(ValueError):
        run_method("g5_paper", np.zeros((8, 10)), np.zeros((8, 10)), cam, MotionIncrement.stereo(1))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"threshold_e": -1.0},
        {"threshold_g": float("nan")},
        {"min_denominator": float("inf")},
        {"range_max": 0.0},
        {"range_max": float("inf")},
    ],
)
def test_bad_ranging_config(kwargs: dict) -> None:
    with pytest.raises(ValueError):
        RangingConfig(**kwargs)
