"""G5: Padé constraint, Bryson weights, backward sweep (ch. 5)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import METHODS, run_method
from rangefx.golden.riccati import (
    PAPER_PIXEL_PITCH_IN,
    PAPER_WEIGHTS,
    RiccatiConfig,
    bryson_config,
    bryson_weights,
    range_g5,
    riccati_signal_ranges,
    riccati_sweep,
    weights_in_pixels,
)
from rangefx.golden.scenes import render_plane
from rangefx.tools import report

_F = 618.0


@pytest.fixture(scope="module")
def plane():
    return render_plane(depth=30.0, size=(24, 96), f_px=_F)


def _brute_force_z(g_hat, a, delta, alpha, beta, gamma):
    """Exact minimiser of the discretised eq-12 cost by linear least squares."""
    n = g_hat.size
    # G_k = Ĝ_0 + δ Σ_{i<k} A_i z_i  ->  G - Ĝ = M z - (Ĝ - Ĝ_0)
    m = np.tril(np.ones((n, n - 1)), -1) * (delta * a[: n - 1])
    t = g_hat - g_hat[0]
    w = np.full(n, math.sqrt(alpha * delta))
    w[-1] = math.sqrt(gamma)
    lhs = np.vstack([w[:, None] * m, math.sqrt(beta * delta) * np.eye(n - 1)])
    rhs = np.concatenate([w * t, np.zeros(n - 1)])
    return np.linalg.lstsq(lhs, rhs, rcond=None)[0]


log_weight = st.floats(-2.0, 2.0).map(lambda e: 10.0**e)


@settings(max_examples=60, deadline=None)
@given(
    e1=arrays(np.float64, 9, elements=st.floats(0, 255)),
    e2=arrays(np.float64, 9, elements=st.floats(0, 255)),
    alpha=log_weight,
    beta=log_weight,
    gamma=log_weight,
    sampling=st.sampled_from(["edge", "centre"]),
)
def test_lq_sweep_is_the_exact_minimiser_of_the_discrete_cost(e1, e2, alpha, beta, gamma, sampling):
    cfg = RiccatiConfig(alpha=alpha, beta=beta, gamma=gamma, pixel_pitch=1.0, a_sampling=sampling)
    lines = riccati_sweep(e1[None, :], e2[None, :], 20.0, 0.5, cfg)
    z_ref = _brute_force_z(lines.G_hat[0], lines.A[0], 1.0, alpha, beta, gamma)
    z = lines.z[0, :-1]
    scale = max(1.0, float(np.abs(z_ref).max()))
    np.testing.assert_allclose(z, z_ref, atol=1e-6 * scale)


@settings(max_examples=60, deadline=None)
@given(
    image=arrays(np.uint8, (2, 3, 12)),
    alpha=st.floats(-12, 12).map(lambda e: 10.0**e),
    beta=st.floats(-12, 12).map(lambda e: 10.0**e),
    gamma=st.floats(-12, 12).map(lambda e: 10.0**e),
)
def test_lq_sweep_is_stable_for_any_positive_weights(image, alpha, beta, gamma):
    cfg = RiccatiConfig(alpha=alpha, beta=beta, gamma=gamma, pixel_pitch=1.0)
    lines = riccati_sweep(image[0], image[1], _F, 0.1, cfg)
    for name in ("S", "K", "G", "Q", "e"):
        assert np.isfinite(getattr(lines, name)).all(), name
    assert np.isfinite(lines.z[:, :-1]).all()
    assert (lines.S > 0).all()
    r = lines.r[:, :-1]
    assert ((r > 0) & (r <= 1)).all()


def test_literal_recurrence_explodes_at_the_first_step(plane):
    """Eqs 35-36 as printed, paper weights: S jumps from γ = 1e6 by > 1e6x in one step."""
    cfg = RiccatiConfig(form="literal")
    lines = riccati_sweep(plane.image1, plane.image2, plane.camera.f_px, 0.1, cfg)
    assert np.all(lines.S[:, -1] == PAPER_WEIGHTS[2])
    moving = np.abs(lines.E_diff[:, -1]) >= 2  # A ≠ 0 at the right edge
    assert moving.any()
    assert np.all(lines.S[moving, -2] > 1e6 * PAPER_WEIGHTS[2])
    z = lines.z[:, :-1]
    assert np.mean(~np.isfinite(z) | (np.abs(z) > 1e6)) > 0.5  # no usable range
    # the default form on the same data stays bounded by γ
    lq = riccati_sweep(plane.image1, plane.image2, plane.camera.f_px, 0.1, RiccatiConfig())
    assert lq.S.max() <= PAPER_WEIGHTS[2] * (1 + 1e-9)


@pytest.mark.parametrize("depth", [15.0, 30.0, 60.0])
def test_plane_depth_within_8_percent(depth):
    scene = render_plane(depth=depth, size=(32, 96), f_px=_F, texture_scale=0.25)
    res = range_g5(scene.image1, scene.image2, scene.camera, scene.motion)
    assert res.valid.mean() > 0.3
    assert abs(np.median(res.range[res.valid]) / depth - 1) < 0.08


def test_wrong_baseline_side_gives_no_valid_range():
    scene = render_plane(depth=30.0, size=(32, 96), f_px=_F, texture_scale=0.25)
    res = range_g5(scene.image1, scene.image2, scene.camera, MotionIncrement.stereo(-0.1))
    assert res.valid.mean() < 0.1


def test_weights_in_inches_and_in_pixels_give_the_same_range(plane):
    inches = RiccatiConfig()  # the paper's numbers, image plane in inches
    pixels = inches.in_pixels()
    assert pixels.pixel_pitch == 1.0 and pixels.alpha == pytest.approx(PAPER_PIXEL_PITCH_IN)
    a = range_g5(plane.image1, plane.image2, plane.camera, plane.motion, inches)
    b = range_g5(plane.image1, plane.image2, plane.camera, plane.motion, pixels)
    np.testing.assert_allclose(a.terms["raw_range"], b.terms["raw_range"], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(a.valid, b.valid)


@pytest.mark.parametrize("rescale", [True, False])
def test_scene_length_unit(plane, rescale):
    """Inches -> mm: rescaled weights give the same range (x 25.4); the paper's numbers
    reused verbatim do not (SPEC §9: the weights are unit-dependent)."""
    mm = 25.4
    ref = range_g5(plane.image1, plane.image2, plane.camera, plane.motion, RiccatiConfig())
    cfg = RiccatiConfig(pixel_pitch=PAPER_PIXEL_PITCH_IN * mm, range_max=100.0 * mm)
    if rescale:  # α per mm of line; β per mm of line and per mm² of range
        cfg = cfg.with_(alpha=1.0 / mm, beta=1e-3 / mm**3)
    res = range_g5(plane.image1, plane.image2, plane.camera, MotionIncrement.stereo(0.1 * mm), cfg)
    both = ref.valid & res.valid
    ratio = np.median(res.range[both] / mm / ref.range[both])
    if rescale:
        np.testing.assert_allclose(
            res.terms["raw_range"] / mm, ref.terms["raw_range"], rtol=1e-9, atol=1e-9
        )
    else:
        assert abs(ratio - 1) > 0.2


def test_bryson_rule_reproduces_the_paper_weights():
    """Eqs 14-16 with |G - Ĝ| <= 2.26, z <= 71.6 in over 512 px: the paper's numbers."""
    cfg = bryson_config(512, 71.6)
    a, b, g = weights_in_pixels(*PAPER_WEIGHTS, PAPER_PIXEL_PITCH_IN)
    assert cfg.alpha == pytest.approx(a, rel=0.01)
    assert cfg.beta == pytest.approx(b, rel=0.01)
    assert cfg.gamma == pytest.approx(g, rel=0.01)
    assert bryson_weights(2.0, 4.0, 8.0) == (1 / 8, 1 / 16, 1 / 4)


@pytest.mark.parametrize(("sampling", "within"), [("edge", True), ("centre", False)])
def test_lab_every_object_within_15_percent_only_with_edge_sampling(lab, sampling, within):
    cfg = RiccatiConfig(a_sampling=sampling)
    res = range_g5(lab.image1, lab.image2, lab.camera, lab.motion, cfg)
    rows = report.object_table(res.range, res.valid, lab.labels1, lab.objects, lab.depth1)
    errors = [abs(r["rel_error_of_median"]) for r in rows]
    assert all(r["n_points"] >= 100 for r in rows)
    assert (max(errors) <= 0.15) is within, errors


def test_signal_ranges_on_lab_lines(lab):
    rows = slice(200, 232)
    ranges = riccati_signal_ranges(lab, RiccatiConfig().in_pixels(), rows=rows)
    assert set(ranges) >= {"S", "K", "G", "z", "z_valid", "Q", "e"}
    for v in ranges.values():
        assert v["min"] <= v["max"]
    assert ranges["S"]["min"] >= PAPER_PIXEL_PITCH_IN  # S >= αδ
    assert ranges["S"]["max"] == pytest.approx(PAPER_WEIGHTS[2])  # γ at the right edge
    assert 0 < ranges["z_valid"]["min"] and ranges["z_valid"]["max"] <= 100.0
    assert ranges["G"]["int_bits"] == 9  # 2 x 8-bit sums stay within [0, 510]
    # the carried Q = K + S Ĝ and e = G - Ĝ need far fewer bits than K and G
    assert ranges["e"]["int_bits"] < ranges["G"]["int_bits"]
    assert ranges["Q"]["int_bits"] < ranges["K"]["int_bits"]


def test_g5_registered_and_rejects_motion_pairs():
    assert "g5_riccati" in METHODS
    cam = PinholeCamera(16, 8, _F)
    img = np.zeros((8, 16))
    moving = MotionIncrement.from_attitudes(position2=(1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="registered stereo pair"):
        run_method("g5_riccati", img, img, cam, moving)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"alpha": 0.0}, "alpha"),
        ({"beta": -1.0}, "beta"),
        ({"gamma": math.inf}, "gamma"),
        ({"pixel_pitch": 0.0}, "pixel_pitch"),
        ({"form": "euler"}, "form"),
        ({"a_sampling": "corner"}, "a_sampling"),
        ({"threshold_e": -1.0}, "threshold_e"),
    ],
)
def test_config_rejects_bad_values(kwargs, message):
    with pytest.raises(ValueError, match=message):
        RiccatiConfig(**kwargs)


def test_sweep_input_errors():
    img = np.zeros((4, 8))
    with pytest.raises(ValueError, match="shapes differ"):
        riccati_sweep(img, np.zeros((4, 9)), _F, 0.1)
    with pytest.raises(ValueError, match="baseline"):
        riccati_sweep(img, img, _F, 0.0)
    with pytest.raises(ValueError, match="focal length"):
        riccati_sweep(img, img, -1.0, 0.1)
