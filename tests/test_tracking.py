"""Tests of G1, the irradiance-tracking navigation scheme (`rangefx.golden.tracking`)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rangefx.golden.tracking import (
    LowPassConfig,
    TrackingConfig,
    chapter2_config,
    chapter2_scene,
    lowpass_range,
    navigation_range,
    sampling_interval_bound,
    simulate_tracking,
)

PIXEL = (40.0, 30.0)
# The default section with its last plane stretched to X = 200 ft: the pixel crosses its
# last joint at t ≈ 2.27 s and then stays on one plane, so there is a settled window.
LONG_SECTION = ((-40.0, 70.0), (-8.0, 62.0), (12.0, 72.0), (30.0, 58.0), (200.0, 66.0))


# ---------------------------------------------------------------- eq 7


@pytest.mark.parametrize("velocity", [(10.0, 5.0, 0.0), (-4.0, 8.0, 2.0), (0.0, 6.0, -3.0)])
@pytest.mark.parametrize(("xp", "zp"), [(40.0, 30.0), (-25.0, 10.0), (60.0, -45.0)])
def test_navigation_equation_with_exact_derivatives(velocity, xp: float, zp: float) -> None:
    """Eq 7 with the bracket fixed returns the true depth from exact derivatives.

    Derivatives are central differences with tiny steps of the analytic scene, so they
    are exact to ~1e-7 relative; the printed bracket (E_z term outside) would not be.
    """
    scene = chapter2_scene(velocity=velocity)
    t, ds, dt = 0.3, 1e-3, 1e-5
    e = scene.irradiance
    ex = (e(xp + ds, zp, t) - e(xp - ds, zp, t)) / (2 * ds)
    ez = (e(xp, zp + ds, t) - e(xp, zp - ds, t)) / (2 * ds)
    et = (e(xp, zp, t + dt) - e(xp, zp, t - dt)) / (2 * dt)
    got = navigation_range(et, ex, ez, xp, zp, velocity, scene.f_px)
    assert got == pytest.approx(float(scene.true_range(xp, zp, t)), rel=1e-5)


def test_navigation_range_divides_by_et() -> None:
    r = navigation_range(np.array([0.0, 2.0]), np.array([1.0, 1.0]), 0.0, 0.0, 0.0,
                         (1.0, 0.0, 0.0), 100.0)  # fmt: skip
    assert math.isinf(r[0]) and r[1] == pytest.approx(50.0)


# ---------------------------------------------------------------- eqs 9-10


def test_sampling_bound_printed_form_by_hand() -> None:
    xp, zp, depth, vel, f = 40.0, 30.0, 60.0, (10.0, 5.0, 0.0), 256.0
    u, v = xp * 5.0 - f * 10.0, zp * 5.0  # eq 10's brackets
    want = 1.0 * 2.0 * depth / abs(-(2.0 * u + 1.0 * v))
    got = sampling_interval_bound(xp, zp, depth, vel, f, dx=1.0, dz=2.0)
    assert got == pytest.approx(want)
    absolute = sampling_interval_bound(xp, zp, depth, vel, f, dx=1.0, dz=2.0, form="absolute")
    assert absolute == pytest.approx(2.0 * depth / (2.0 * abs(u) + abs(v)))
    assert absolute <= got


def test_sampling_bound_printed_form_cancels() -> None:
    """N_r (eq 10) is signed: opposite flow components can make the printed bound infinite."""
    f = 100.0
    # u' = -f ẋ0 = -100, v' = zp ẏ0 = 100 at zp = 100 with ẏ0 = 1
    assert math.isinf(sampling_interval_bound(0.0, 100.0, 50.0, (1.0, 1.0, 0.0), f))
    assert math.isfinite(
        sampling_interval_bound(0.0, 100.0, 50.0, (1.0, 1.0, 0.0), f, form="absolute")
    )


@pytest.mark.parametrize(("xp", "zp"), [PIXEL, (-30.0, -20.0), (5.0, 60.0)])
def test_absolute_bound_is_one_pixel_of_image_motion(xp: float, zp: float) -> None:
    """At Δt = the absolute bound the scene point seen at (x_p, z_p) moves one pixel (L1)."""
    scene = chapter2_scene()
    depth = float(scene.true_range(xp, zp, 0.0))
    h = float(sampling_interval_bound(xp, zp, depth, scene.velocity, scene.f_px, form="absolute"))
    cam0, cam1 = scene.camera_position(0.0), scene.camera_position(h)
    point = cam0 + depth * np.array([xp / scene.f_px, 1.0, zp / scene.f_px])
    rel = point - cam1
    x1, z1 = scene.f_px * rel[0] / rel[1], scene.f_px * rel[2] / rel[1]  # eqs 1-2
    assert abs(x1 - xp) + abs(z1 - zp) == pytest.approx(1.0, rel=0.03)


def test_sampling_bound_rejects_bad_form() -> None:
    with pytest.raises(ValueError, match="bound form"):
        sampling_interval_bound(1.0, 1.0, 1.0, (1.0, 0.0, 0.0), 1.0, form="loose")
    with pytest.raises(ValueError, match="dx"):
        sampling_interval_bound(1.0, 1.0, 1.0, (1.0, 0.0, 0.0), 1.0, dx=0.0)


def test_raw_error_shrinks_with_the_sampling_interval() -> None:
    """The report's rule (1/5-1/10 of the eq-9 bound): a finer interval, a better raw range."""
    scene = chapter2_scene()
    errs = []
    for fraction in (1.0, 0.5, 0.1):
        cfg = chapter2_config(scene, *PIXEL, fraction=fraction, threshold=0.1 * fraction / 0.1)
        run = simulate_tracking(scene, *PIXEL, cfg, round(3.0 / cfg.h) + 1)
        errs.append(np.nanmedian(np.abs(run.range_raw - run.truth) / run.truth))
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 0.05


# ---------------------------------------------------------------- convergence


@pytest.mark.parametrize("tau", [0.1, 0.4])
def test_lowpassed_range_converges_to_the_true_range(tau: float) -> None:
    """After the filter settles, the low-passed range at the pixel is the true range.

    Window: from 5τ after the pixel's last joint crossing (the truth's last slope break)
    to the end of a 5 s run at h = 1/10 of the eq-9 bound (the report's rule). The
    tolerance is the sum of

    * settling: a first-order filter keeps ``e^-5`` (0.7%) of an error present 5τ ago
      (the raw range is within 100% of the truth: at most 0.7% remains);
    * lag: on a plane the truth is a ramp, which the filter follows ``τ |dR/dt|``
      behind (``h e^(-h/τ) / (1 - e^(-h/τ)) ≈ τ`` per unit slope);
    * discretisation of eq 7's ratio ``E_x / E_t``: for an irradiance component of
      ``k`` rad/pixel, the central difference errs by ``(k Δx)² / 6`` and the
      backward difference in time by ``k m / 2`` (``m`` the image motion per frame,
      ≤ 0.1 px at t = 0 by the sampling rule, larger as the camera closes in); the
      ratio's relative error is at most the sum of both, for numerator and denominator,
      taken at the shortest wavelength and the largest motion in the window.

    Measured (tau 0.1 / 0.4 s): 5.0% / 6.5% against tolerances of about 11% / 13%.
    """
    scene = chapter2_scene(section=LONG_SECTION)
    xp, zp = PIXEL
    cfg = chapter2_config(scene, xp, zp, fraction=0.1)
    run = simulate_tracking(scene, xp, zp, cfg, round(5.0 / cfg.h) + 1, (tau,))
    truth, t = run.truth, run.t
    kinks = np.flatnonzero(np.abs(np.diff(truth, 2)) > 1e-6 * truth[1:-1]) + 1
    window = t >= t[kinks[-1]] + 5.0 * tau
    assert window.sum() > 100
    rate = np.max(np.abs(np.gradient(truth, t))[window])
    r_min, r_max = np.min(truth[window]), np.max(truth[window])
    lag = tau * rate / r_min
    shortest = min(term[1] for term in scene.irradiance_terms)  # ft on the surface
    k = 2 * np.pi / (shortest * scene.f_px / r_max)  # rad per pixel in the image
    vx, vy, vz = scene.velocity
    motion = cfg.h * (abs(xp * vy - scene.f_px * vx) + abs(zp * vy - scene.f_px * vz)) / r_min
    discretisation = 2.0 * (k * motion / 2.0 + (k * cfg.dx) ** 2 / 6.0)
    tolerance = math.exp(-5.0) + lag + discretisation
    filtered = run.range_filtered[tau]
    rel = np.abs(filtered[window] - truth[window]) / truth[window]
    assert np.max(rel) <= tolerance
    assert tolerance < 0.15  # the tolerance itself stays meaningful


def test_raw_range_has_the_reports_anomalies() -> None:
    """Fig. 5: the raw range spikes where E_M,t crosses zero; the low-pass removes them."""
    scene = chapter2_scene()
    cfg = chapter2_config(scene, *PIXEL, fraction=0.1, threshold=0.01)
    run = simulate_tracking(scene, *PIXEL, cfg, round(4.0 / cfg.h) + 1, (0.1,))
    rel = np.abs(run.range_raw - run.truth) / run.truth
    assert np.nanmax(rel) > 0.5  # spikes
    late = run.t > 3.0
    assert np.max(np.abs(run.range_filtered[0.1] - run.truth)[late] / run.truth[late]) < 0.3


def test_zero_temporal_derivative_still_tracks() -> None:
    """E_t assumed zero (report: "letting the tracking process compensate"): coarser."""
    scene = chapter2_scene()
    cfg = chapter2_config(scene, *PIXEL, fraction=0.1, temporal="zero")
    run = simulate_tracking(scene, *PIXEL, cfg, round(3.0 / cfg.h) + 1)
    assert np.nanmedian(np.abs(run.range_raw - run.truth) / run.truth) < 0.15


def test_tracking_model_follows_the_image() -> None:
    scene = chapter2_scene()
    cfg = chapter2_config(scene, *PIXEL, fraction=0.1)
    run = simulate_tracking(scene, *PIXEL, cfg, 500)
    assert np.max(np.abs(run.model - run.irradiance)[10:]) < 2.0  # grey levels
    assert run.model[0] == run.irradiance[0]


def test_simulation_vectorises_over_pixels() -> None:
    scene = chapter2_scene()
    cfg = chapter2_config(scene, *PIXEL, fraction=0.2)
    xs, zs = np.array([40.0, -20.0]), np.array([30.0, 10.0])
    both = simulate_tracking(scene, xs, zs, cfg, 200, (0.1,))
    one = simulate_tracking(scene, -20.0, 10.0, cfg, 200, (0.1,))
    assert both.range_raw.shape == (200, 2)
    np.testing.assert_array_equal(both.range_raw[:, 1], one.range_raw)
    np.testing.assert_array_equal(both.range_filtered[0.1][:, 1], one.range_filtered[0.1])


# ---------------------------------------------------------------- low-pass filter


def test_lowpass_ramp_lag_and_hold() -> None:
    h, tau, slope = 0.01, 0.2, 3.0
    t = np.arange(2000) * h
    raw = 50.0 + slope * t
    valid = np.ones_like(raw, dtype=bool)
    out = lowpass_range(raw, valid, h, tau)
    lag = slope * h * math.exp(-h / tau) / (1.0 - math.exp(-h / tau))
    assert raw[-1] - out[-1] == pytest.approx(lag, rel=1e-9)
    assert lag == pytest.approx(slope * tau, rel=0.03)
    valid[1500:1600] = False
    held = lowpass_range(np.where(valid, raw, 1e9), valid, h, tau)
    assert np.all(held[1500:1600] == held[1499])


def test_lowpass_starts_at_first_valid_sample() -> None:
    raw = np.array([9.0, 5.0, 5.0, 7.0])
    valid = np.array([False, True, True, True])
    out = lowpass_range(raw, valid, 1.0, 1.0)
    assert np.isnan(out[0]) and out[1] == 5.0 and out[2] == 5.0
    assert out[3] == pytest.approx(5.0 + (1 - math.exp(-1.0)) * 2.0)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.tuples(st.floats(1.0, 500.0), st.booleans()), min_size=1, max_size=60),
    st.floats(1e-3, 10.0),
)
def test_lowpass_stays_within_the_valid_inputs(samples, tau: float) -> None:
    raw = np.array([s[0] for s in samples])
    valid = np.array([s[1] for s in samples])
    out = lowpass_range(raw, valid, 0.01, tau)
    for i in range(len(raw)):
        seen = raw[: i + 1][valid[: i + 1]]
        if seen.size == 0:
            assert np.isnan(out[i])
        else:
            assert seen.min() - 1e-9 <= out[i] <= seen.max() + 1e-9


# ---------------------------------------------------------------- configuration


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"h": 0.01, "a": 200.0}, "unstable"),
        ({"h": 0.0, "a": 1.0}, "h must"),
        ({"h": 0.01, "a": 10.0, "b": -1.0}, "b must"),
        ({"h": 0.01, "a": 10.0, "temporal": "central"}, "temporal"),
        ({"h": 0.01, "a": 10.0, "threshold": math.nan}, "threshold"),
    ],
)
def test_tracking_config_validation(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        TrackingConfig(**kwargs)


def test_rates_from_the_weights_of_eq_15() -> None:
    cfg = TrackingConfig.from_weights(0.01, 0.5, 0.25, alpha=4.0, beta=1.0, gamma=1e-4)
    assert cfg.a == pytest.approx(math.sqrt(0.5 / 1e-4))
    assert cfg.b == pytest.approx(0.25)
    assert cfg.c == pytest.approx(0.5)
    with pytest.raises(ValueError, match="eq 21"):
        TrackingConfig.from_weights(0.01, 0.7, 0.4, alpha=1.0, beta=1.0, gamma=1.0)


def test_bad_runs_are_rejected() -> None:
    scene = chapter2_scene()
    cfg = chapter2_config(scene, *PIXEL)
    with pytest.raises(ValueError, match="steps"):
        simulate_tracking(scene, *PIXEL, cfg, 1)
    with pytest.raises(ValueError, match="tau"):
        simulate_tracking(scene, *PIXEL, cfg, 10, (0.0,))
    with pytest.raises(ValueError, match="leaves the scene"):
        simulate_tracking(scene, 0.0, 2000.0, cfg, 10)
    with pytest.raises(ValueError, match="gain"):
        chapter2_config(scene, *PIXEL, gain=2.0)
    with pytest.raises(ValueError, match="tau"):
        LowPassConfig(-1.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"section": ((1.0, 2.0), (0.0, 3.0))}, "increase"),
        ({"section": ((1.0, 2.0),)}, "shape"),
        ({"f_px": 0.0}, "f_px"),
    ],
)
def test_scene_validation(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        chapter2_scene(**kwargs)


def test_scene_is_continuous_across_joints() -> None:
    """Irradiance continuous across a joint, its gradient not (the report's Figs 3-4)."""
    scene = chapter2_scene()
    # the pixel whose ray hits the joint at X = -8 ft, Y = 62 ft from the origin at t = 0
    xp_joint = scene.f_px * -8.0 / 62.0
    eps = 1e-6
    left, right = (
        scene.irradiance(xp_joint - eps, 0.0, 0.0),
        scene.irradiance(xp_joint + eps, 0.0, 0.0),
    )
    assert abs(left - right) < 1e-3
    assert scene.true_range(xp_joint, 0.0, 0.0) == pytest.approx(62.0)
