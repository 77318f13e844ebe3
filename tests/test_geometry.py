"""Known-answer tests of the camera / frame geometry (`rangefx.golden.geometry`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rangefx.golden.geometry import (
    MotionIncrement,
    PinholeCamera,
    camera_from_inertial,
    camera_points_from_range,
    inertial_from_camera,
    k_coefficients,
    rotation_body_to_camera,
    rotation_inertial_to_body,
)

ROTATIONS = (rotation_body_to_camera, rotation_inertial_to_body)


def _random_motion(seed: int) -> MotionIncrement:
    rng = np.random.default_rng(seed)
    return MotionIncrement.from_attitudes(
        camera_angles=tuple(rng.uniform(-0.3, 0.3, 3)),
        camera_offset=tuple(rng.uniform(-2, 2, 3)),
        attitude1=tuple(rng.uniform(-math.pi, math.pi, 3) * [1, 0.3, 0.3]),
        attitude2=tuple(rng.uniform(-math.pi, math.pi, 3) * [1, 0.3, 0.3]),
        position1=tuple(rng.uniform(-50, 50, 3)),
        position2=tuple(rng.uniform(-50, 50, 3)),
    )


# ---------------------------------------------------------------- rotations


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("rot", ROTATIONS)
def test_rotation_orthonormal(rot, seed: int) -> None:
    rng = np.random.default_rng(seed)
    T = rot(*rng.uniform(-math.pi, math.pi, 3))
    np.testing.assert_allclose(T @ T.T, np.eye(3), rtol=0, atol=1e-14)
    assert np.linalg.det(T) == pytest.approx(1.0, abs=1e-14)


def test_zero_angles_are_identity() -> None:
    for rot in ROTATIONS:
        np.testing.assert_array_equal(rot(0.0, 0.0, 0.0), np.eye(3))


def test_yaw_90_degrees() -> None:
    # Heading east: north is to port (-y_b), east is along the nose (+x_b).
    T2 = rotation_inertial_to_body(math.pi / 2, 0.0, 0.0)
    np.testing.assert_allclose(T2 @ [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(T2 @ [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(T2 @ [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], atol=1e-15)


def test_pitch_and_roll_single_axis() -> None:
    th = 0.3
    # Nose up by theta: local down in body axes is (-sin th, 0, cos th), i.e. aft.
    T2 = rotation_inertial_to_body(0.0, th, 0.0)
    np.testing.assert_allclose(T2 @ [0, 0, 1.0], [-math.sin(th), 0, math.cos(th)], atol=1e-15)
    ph = 0.4
    # Right wing down by phi: down in body = (0, sin ph, cos ph).
    T2 = rotation_inertial_to_body(0.0, 0.0, ph)
    np.testing.assert_allclose(T2 @ [0, 0, 1.0], [0, math.sin(ph), math.cos(ph)], atol=1e-15)


def test_eq11_matrix_entries() -> None:
    e1, e2, e3 = 0.2, -0.4, 0.7
    c1, s1, c2, s2, c3, s3 = (
        math.cos(e1),
        math.sin(e1),
        math.cos(e2),
        math.sin(e2),
        math.cos(e3),
        math.sin(e3),
    )
    want = np.array(
        [
            [c2 * c1, c2 * s1, -s2],
            [s3 * s2 * c1 - c3 * s1, s3 * s2 * s1 + c3 * c1, s3 * c2],
            [c3 * s2 * c1 + s3 * s1, c3 * s2 * s1 - s3 * c1, c3 * c2],
        ]
    )
    np.testing.assert_allclose(rotation_body_to_camera(e1, e2, e3), want, rtol=0, atol=1e-15)
    # composition: x-roll after y-pitch after z-yaw
    Rz = np.array([[c1, s1, 0], [-s1, c1, 0], [0, 0, 1]])
    Ry = np.array([[c2, 0, -s2], [0, 1, 0], [s2, 0, c2]])
    Rx = np.array([[1, 0, 0], [0, c3, s3], [0, -s3, c3]])
    np.testing.assert_allclose(Rx @ Ry @ Rz, want, rtol=0, atol=1e-15)


# ---------------------------------------------------------------- frame transforms


@pytest.mark.parametrize("seed", range(4))
def test_inertial_from_camera_inverts_camera_from_inertial(seed: int) -> None:
    m = _random_motion(seed)
    rng = np.random.default_rng(100 + seed)
    pts = rng.uniform(-100, 100, size=(7, 3))
    xc = camera_from_inertial(m, pts, frame=1)
    np.testing.assert_allclose(inertial_from_camera(m, xc), pts, rtol=0, atol=1e-11)
    np.testing.assert_allclose(
        camera_from_inertial(m, inertial_from_camera(m, pts)), pts, rtol=0, atol=1e-11
    )


def test_camera_from_inertial_known_values() -> None:
    # Vehicle at (10, 0, 0) heading east, camera 1 unit ahead of the nose, no camera tilt.
    m = MotionIncrement.from_attitudes(
        camera_offset=(1.0, 0.0, 0.0),
        attitude1=(math.pi / 2, 0.0, 0.0),
        position1=(10.0, 0.0, 0.0),
    )
    # A point 5 east of the vehicle is 4 ahead of the camera; 2 north of it is 2 to port.
    xc = camera_from_inertial(m, np.array([12.0, 5.0, -3.0]))
    np.testing.assert_allclose(xc, [4.0, -2.0, -3.0], atol=1e-14)


def test_stereo_motion() -> None:
    m = MotionIncrement.stereo(0.25)
    np.testing.assert_array_equal(m.camera_displacement, [0.0, 0.25, 0.0])
    p = np.array([20.0, 1.0, -0.5])
    np.testing.assert_allclose(
        camera_from_inertial(m, p, frame=2) - camera_from_inertial(m, p, frame=1),
        [0.0, -0.25, 0.0],
        atol=1e-15,
    )


@pytest.mark.parametrize("seed", range(4))
def test_camera_displacement_matches_frames(seed: int) -> None:
    m = _random_motion(seed)
    # Camera-2 centre expressed in camera-1 coordinates is the displacement.
    centre2 = inertial_from_camera(
        MotionIncrement(m.T1, m.l, m.T2 + m.dT2, m.dT2, m.dxv, m.xv + m.dxv), np.zeros(3)
    )
    np.testing.assert_allclose(
        camera_from_inertial(m, centre2, frame=1), m.camera_displacement, atol=1e-10
    )


# ---------------------------------------------------------------- k0..k5 (eqs 22-26)


@pytest.mark.parametrize("seed", range(6))
def test_k_coefficients_exact(seed: int) -> None:
    m = _random_motion(seed)
    f = 350.0
    rng = np.random.default_rng(200 + seed)
    xc1 = np.array([rng.uniform(20, 80), rng.uniform(-10, 10), rng.uniform(-10, 10)])
    X = inertial_from_camera(m, xc1)
    a = camera_from_inertial(m, X, frame=1)
    b = camera_from_inertial(m, X, frame=2)
    np.testing.assert_allclose(a, xc1, rtol=1e-13)
    xp, yp = f * a[1] / a[0], f * a[2] / a[0]
    (k0, k1, k2), (k3, k4, k5) = k_coefficients(m, np.array(xp), np.array(yp), f)
    d = b - a
    x_c = a[0]
    np.testing.assert_allclose(d / x_c, [k0 + k3 / x_c, k1 + k4 / x_c, k2 + k5 / x_c], atol=1e-12)

    # eqs 25-26 give the true pixel displacement of the point between the frames
    xp2, yp2 = f * b[1] / b[0], f * b[2] / b[0]
    den = 1 + k0 + k3 / x_c
    dxp = (f * k1 - xp * k0 + (f * k4 - xp * k3) / x_c) / den
    dyp = (f * k2 - yp * k0 + (f * k5 - yp * k3) / x_c) / den
    np.testing.assert_allclose([dxp, dyp], [xp2 - xp, yp2 - yp], rtol=1e-10, atol=1e-9)

    # eq 28 with exact disparities: a1 dxp + b1 dyp = c1 (eq 27) for arbitrary a1, b1
    # must return x_c (fixed sign c1 = E1 - E2).
    a1, b1 = rng.uniform(-5, 5, 2)
    c1 = a1 * dxp + b1 * dyp
    x_hat = (k3 * c1 - a1 * (f * k4 - xp * k3) - b1 * (f * k5 - yp * k3)) / (
        a1 * (f * k1 - xp * k0) + b1 * (f * k2 - yp * k0) - c1 * (1 + k0)
    )
    assert x_hat == pytest.approx(x_c, rel=1e-9)


def test_k_coefficients_pure_translation() -> None:
    m = MotionIncrement.from_attitudes(position2=(3.0, -1.0, 0.5))
    xp = np.arange(6.0).reshape(2, 3)
    yp = -xp
    k012, k345 = k_coefficients(m, xp, yp, 100.0)
    assert k012.shape == (3, 2, 3)
    np.testing.assert_array_equal(k012, 0.0)
    np.testing.assert_array_equal(k345, [-3.0, 1.0, -0.5])


def test_camera_points_from_range() -> None:
    pts = camera_points_from_range(np.array([10.0, 20.0]), np.array([5.0, -2.0]), 1.0, 50.0)
    np.testing.assert_allclose(pts, [[10.0, 1.0, 0.2], [20.0, -0.8, 0.4]], atol=1e-15)


# ---------------------------------------------------------------- camera


def test_pixel_grid() -> None:
    cam = PinholeCamera(5, 3, 100.0)
    xp, yp = cam.pixel_grid()
    assert xp.shape == yp.shape == (3, 5)
    np.testing.assert_array_equal(xp[0], [-2, -1, 0, 1, 2])
    np.testing.assert_array_equal(yp[:, 0], [-1, 0, 1])
    xp, yp = PinholeCamera(4, 4, 10.0, cx=0.0, cy=1.0).pixel_grid()
    np.testing.assert_array_equal(xp[0], [0, 1, 2, 3])
    np.testing.assert_array_equal(yp[:, 0], [-1, 0, 1, 2])


def test_from_fov() -> None:
    cam = PinholeCamera.from_fov(200, 100, 90.0)
    assert cam.f_px == pytest.approx(100.0, rel=1e-14)


@pytest.mark.parametrize(
    "args",
    [(8, 8, 0.0), (8, 8, -1.0), (8, 8, math.nan), (8, 8, math.inf), (1, 8, 10.0), (8, 1, 10.0)],
)
def test_bad_camera(args) -> None:
    with pytest.raises(ValueError):
        PinholeCamera(*args)


@pytest.mark.parametrize("fov", [0.0, 180.0, -10.0])
def test_bad_fov(fov: float) -> None:
    with pytest.raises(ValueError):
        PinholeCamera.from_fov(64, 64, fov)


@pytest.mark.parametrize("b", [0.0, math.nan, math.inf])
def test_bad_stereo_baseline(b: float) -> None:
    with pytest.raises(ValueError):
        MotionIncrement.stereo(b)
