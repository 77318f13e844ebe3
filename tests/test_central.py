"""G2: optical ranging equation (ch. 3 eq 15) with central differences (eqs 18-19)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rangefx.golden.central import (
    CentralConfig,
    central_differences,
    range_error_ratio,
    range_g2,
)
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import METHODS, run_method
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.scenes import render_plane
from rangefx.tools import report


def _shifted_pair(profile, disparity: float, shape=(6, 40)):
    """E1(i) = p(i), E2(i) = p(i + D): image 2 shows at i - D what image 1 shows at i."""
    m, n = shape
    i = np.arange(n, dtype=np.float64)
    e1 = np.broadcast_to(profile(i), (m, n)).copy()
    e2 = np.broadcast_to(profile(i + disparity), (m, n)).copy()
    return e1, e2


def test_central_differences_are_eqs_18_19_with_nan_borders():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, size=(7, 9)).astype(np.uint8)
    e, ex, ey = central_differences(img)
    f = img.astype(float)
    np.testing.assert_array_equal(ex[:, 1:-1], (f[:, 2:] - f[:, :-2]) / 2)
    np.testing.assert_array_equal(ey[1:-1, :], (f[2:, :] - f[:-2, :]) / 2)
    assert np.isnan(ex[:, [0, -1]]).all() and np.isnan(ey[[0, -1], :]).all()
    np.testing.assert_array_equal(e, f)


@settings(max_examples=40, deadline=None)
@given(
    slope=st.floats(0.5, 8.0) | st.floats(-8.0, -0.5),
    disparity=st.floats(0.2, 4.0),
    f_px=st.floats(50.0, 2000.0),
    baseline=st.floats(0.01, 10.0),
)
def test_linear_irradiance_gives_the_exact_depth(slope, disparity, f_px, baseline):
    """Eq 13 is exact for a linear irradiance; eq 14's residual is then zero."""
    e1, e2 = _shifted_pair(lambda x: 100.0 + slope * x, disparity)
    cam = PinholeCamera(e1.shape[1], e1.shape[0], f_px)
    cfg = CentralConfig(threshold_e=0.0, range_max=1e12)
    res = range_g2(e1, e2, cam, MotionIncrement.stereo(baseline), cfg)
    inner = res.valid[1:-1, 1:-1]
    assert inner.all()
    depth = f_px * baseline / disparity
    np.testing.assert_allclose(res.range[1:-1, 1:-1], depth, rtol=1e-9)
    np.testing.assert_allclose(range_error_ratio(res.terms)[1:-1, 1:-1], 0.0, atol=1e-12)


def test_eq14_flags_a_curved_irradiance():
    e1, e2 = _shifted_pair(lambda x: 100.0 + 0.2 * (x - 5.0) ** 2, 2.0)
    cam = PinholeCamera(e1.shape[1], e1.shape[0], 600.0)
    res = range_g2(e1, e2, cam, MotionIncrement.stereo(0.1), CentralConfig(threshold_e=0.0))
    ratio = range_error_ratio(res.terms)[1:-1, 10:-1]
    assert np.all(ratio > 0.01)
    # the gate built on eq 14 removes exactly those pixels
    gated = range_g2(
        e1,
        e2,
        cam,
        MotionIncrement.stereo(0.1),
        CentralConfig(threshold_e=0.0, max_error_ratio=0.01),
    )
    assert not gated.valid[1:-1, 10:-1].any()


@pytest.mark.parametrize("depth", [15.0, 30.0, 60.0])
def test_plane_depth_within_8_percent(depth):
    scene = render_plane(depth=depth, size=(32, 96), f_px=618.0, texture_scale=0.25)
    res = range_g2(scene.image1, scene.image2, scene.camera, scene.motion, CentralConfig(2.0, 2.0))
    assert res.valid.mean() > 0.3
    assert abs(np.median(res.range[res.valid]) / depth - 1) < 0.08


def test_wrong_baseline_side_gives_no_valid_range():
    """Camera 2 is to the right; telling G2 it is on the left makes every range negative."""
    scene = render_plane(depth=30.0, size=(32, 96), f_px=618.0, texture_scale=0.25)
    res = range_g2(
        scene.image1, scene.image2, scene.camera, MotionIncrement.stereo(-0.1), CentralConfig(2, 2)
    )
    assert res.valid.sum() < 0.02 * res.valid.size


@pytest.mark.parametrize("t_e", [0.0, 2.0, 15.0])
def test_threshold_and_invalid_pixels(t_e):
    scene = render_plane(depth=25.0, size=(24, 64), f_px=618.0)
    cfg = CentralConfig(threshold_e=t_e, range_max=80.0)
    res = range_g2(scene.image1, scene.image2, scene.camera, scene.motion, cfg)
    assert np.all(np.abs(res.terms["c1"][res.valid]) >= t_e)
    assert np.all(res.range[~res.valid] == 80.0)
    assert np.all((res.range[res.valid] > 0) & (res.range[res.valid] <= 80.0))
    assert not res.valid[:, [0, -1]].any() and not res.valid[[0, -1], :].any()


def test_higher_threshold_keeps_fewer_pixels():
    scene = render_plane(depth=25.0, size=(24, 64), f_px=618.0)
    counts = [
        range_g2(
            scene.image1, scene.image2, scene.camera, scene.motion, CentralConfig(t)
        ).valid.sum()
        for t in (0.0, 5.0, 15.0)
    ]
    assert counts[0] > counts[1] > counts[2]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"threshold_e": -1.0}, "threshold_e"),
        ({"threshold_g": math.nan}, "threshold_g"),
        ({"max_error_ratio": 0.0}, "max_error_ratio"),
        ({"range_max": 0.0}, "range_max"),
    ],
)
def test_config_rejects_bad_values(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CentralConfig(**kwargs)


def test_shape_errors():
    cam = PinholeCamera(8, 6, 100.0)
    a = np.zeros((6, 8))
    with pytest.raises(ValueError, match="shapes differ"):
        range_g2(a, np.zeros((6, 9)), cam, MotionIncrement.stereo(0.1))
    with pytest.raises(ValueError, match="camera"):
        range_g2(np.zeros((5, 8)), np.zeros((5, 8)), cam, MotionIncrement.stereo(0.1))


def test_g2_registered_and_matches_range_g2():
    assert "g2_central" in METHODS
    scene = render_plane(depth=25.0, size=(16, 48), f_px=618.0)
    cfg = RangingConfig(threshold_e=3.0, threshold_g=1.0, range_max=90.0)
    a = run_method(
        "g2_central", scene.image1, scene.image2, scene.camera, scene.motion, ranging=cfg
    )
    b = range_g2(
        scene.image1,
        scene.image2,
        scene.camera,
        scene.motion,
        CentralConfig(3.0, 1.0, range_max=90.0),
    )
    np.testing.assert_array_equal(a.range, b.range)
    np.testing.assert_array_equal(a.valid, b.valid)


def test_lab_g2_underestimates_more_than_g3_consistent(lab):
    """Measured (docs/golden_g2_g5.md): raw central differences bias every object near."""
    cfg = RangingConfig(threshold_e=2.0, threshold_g=2.0, range_max=100.0)
    tables = {}
    for m in ("g2_central", "g3_consistent"):
        r = run_method(m, lab.image1, lab.image2, lab.camera, lab.motion, ranging=cfg)
        tables[m] = report.object_table(r.range, r.valid, lab.labels1, lab.objects, lab.depth1)
    for g2, g3 in zip(tables["g2_central"], tables["g3_consistent"], strict=True):
        assert g2["n_points"] >= 100
        assert g2["rel_error_of_median"] < 0  # every object ranged too near
        assert abs(g2["rel_error_of_median"]) > abs(g3["rel_error_of_median"])
