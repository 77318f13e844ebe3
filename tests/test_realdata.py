"""Middlebury 2014 motorcycle loader, evaluation metrics and ``rangefx eval``."""

from __future__ import annotations

import json
import math
import socket

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rangefx.golden import realdata
from rangefx.golden.realdata import (
    MOTORCYCLE_CALIBRATION,
    Perturbation,
    choose_factor,
    evaluate,
    load_motorcycle,
    perturb_right,
)
from rangefx.golden.scenes import render_scene
from rangefx.tools.cli import main

CAL = MOTORCYCLE_CALIBRATION


@pytest.fixture(scope="module")
def moto():
    return load_motorcycle()


def test_loads_offline(monkeypatch):
    def no_network(*args, **kwargs):
        raise OSError("network disabled in this test")

    monkeypatch.setattr(socket, "socket", no_network)
    monkeypatch.setattr(socket, "create_connection", no_network)
    realdata._shipped.cache_clear()
    data = load_motorcycle(24)
    assert data.image1.shape == (500 // 24, 741 // 24)


def test_default_factor_gives_a_median_disparity_of_about_2_px(moto):
    assert choose_factor(2.0) == moto.factor == 19
    assert abs(moto.median_disparity - 2.0) < 0.25
    assert moto.image1.shape == moto.image2.shape == (500 // 19, 741 // 19)
    assert moto.unit == "mm"


@pytest.mark.parametrize("factor", [8, 19])
def test_ground_truth_is_consistent_with_the_calibration(factor):
    data = load_motorcycle(factor)
    known = np.isfinite(data.depth)
    assert 0.5 < known.mean() < 1.0  # unknown truth exists and is +inf, not NaN
    assert not np.isnan(data.depth).any()
    f_px = CAL["f_px"] / factor
    assert data.camera.f_px == pytest.approx(f_px)
    np.testing.assert_allclose(
        data.depth[known] * data.disparity[known], f_px * CAL["baseline_mm"], rtol=1e-12
    )
    # the metric depth includes the principal-point offset and is nearer
    assert np.all(data.metric_depth[known] < data.depth[known])
    assert data.range_max == pytest.approx(2 * data.depth[known].max())


def test_camera_2_is_on_the_right_like_the_lab_pair(moto):
    lab = render_scene("lab", size=(16, 16))
    assert moto.motion.camera_displacement[1] == pytest.approx(CAL["baseline_mm"])
    assert np.sign(moto.motion.camera_displacement[1]) == np.sign(lab.motion.camera_displacement[1])
    np.testing.assert_allclose(moto.motion.camera_displacement[[0, 2]], 0.0)


@pytest.mark.parametrize("register", [False, True])
def test_left_x_matches_right_x_minus_d(register):
    """At the shipped scale the left pixel x shows what the right shows at x - d."""
    data = load_motorcycle(1, register=register)
    e1, e2, d = data.image1, data.image2, data.disparity
    rows, cols = np.nonzero(np.isfinite(d))
    keep = (cols - np.ceil(d[rows, cols]).astype(int) >= 0) & (
        cols + np.ceil(d[rows, cols]).astype(int) < e1.shape[1]
    )
    rows, cols = rows[keep], cols[keep]
    minus = np.rint(cols - d[rows, cols]).astype(int)
    plus = np.rint(cols + d[rows, cols]).astype(int)
    err_minus = np.mean(np.abs(e1[rows, cols] - e2[rows, minus]))
    err_plus = np.mean(np.abs(e1[rows, cols] - e2[rows, plus]))
    assert err_minus < 0.5 * err_plus


def test_registration_adds_the_principal_point_offset():
    a = load_motorcycle(19)
    b = load_motorcycle(19, register=True)
    shift = round(CAL["doffs"]) / 19
    assert b.median_disparity == pytest.approx(a.median_disparity + shift, abs=0.3)
    known = np.isfinite(b.depth)
    np.testing.assert_allclose(b.depth[known], b.metric_depth[known], rtol=0.005)


@pytest.mark.parametrize("factor", [0, -2, 2.5, True, 1000])
def test_bad_factor(factor):
    with pytest.raises(ValueError, match="factor"):
        load_motorcycle(factor)


def test_evaluate_by_hand():
    truth = np.array([[10.0, 20.0, np.inf], [40.0, 50.0, np.nan]])
    rng = np.array([[10.4, 23.0, 7.0], [40.0, 99.0, 1.0]])
    valid = np.array([[True, True, True], [True, False, True]])
    out = evaluate(rng, valid, truth)
    # scored: 10.4/10 (4 %), 23/20 (15 %), 40/40 (0 %); 4 known truth pixels
    assert out["density"] == pytest.approx(3 / 4)
    assert out["n_scored"] == 3
    assert out["median_rel_error"] == pytest.approx(0.04)
    assert out["within_5pct"] == pytest.approx(2 / 3)
    assert out["within_10pct"] == pytest.approx(2 / 3)


@settings(max_examples=40, deadline=None)
@given(
    truth=arrays(np.float64, (4, 5), elements=st.floats(1.0, 1e4)),
    valid=arrays(np.bool_, (4, 5)),
    scale=st.floats(0.5, 2.0),
)
def test_evaluate_properties(truth, valid, scale):
    out = evaluate(truth * scale, valid, truth)
    n = int(valid.sum())
    assert out["density"] == pytest.approx(n / truth.size)
    if n:
        assert out["median_rel_error"] == pytest.approx(abs(scale - 1))
        assert out["within_5pct"] == (1.0 if abs(scale - 1) <= 0.05 else 0.0)
    else:
        assert math.isnan(out["median_rel_error"])


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((np.zeros((2, 2)), np.zeros((2, 3), bool), np.ones((2, 2))), "one shape"),
        ((np.zeros((2, 2)), np.zeros((2, 2)), np.ones((2, 2))), "boolean"),
        ((np.zeros((2, 2)), np.zeros((2, 2), bool), -np.ones((2, 2))), "positive"),
        ((np.full((2, 2), np.nan), np.ones((2, 2), bool), np.ones((2, 2))), "not finite"),
    ],
)
def test_evaluate_rejects_bad_input(args, message):
    with pytest.raises(ValueError, match=message):
        evaluate(*args)


def test_eval_command_json(capsys):
    assert main(["eval", "--dataset", "motorcycle", "--protocol", "report", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["factor"] == 19 and out["unit"] == "mm"
    assert set(out["methods"]) == {"g2_central", "g3_consistent", "g3_paper", "g5_riccati"}
    for figures in out["methods"].values():
        assert 0 < figures["density"] <= 1
        assert 0 <= figures["median_rel_error"] < 1
        assert figures["within_5pct"] <= figures["within_10pct"]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["eval", "--dataset", "kitti"], "unknown dataset 'kitti'"),
        (["eval", "--factor", "x"], "--factor must be an integer"),
        (["eval", "--factor", "0"], "factor"),
        (["eval", "--factor", "19", "--max-disparity", "-3"], "--max-disparity must be"),
        (["eval", "--factor", "19", "--perturb", "gain=x"], "--perturb: gain must be"),
        (["eval", "--factor", "19", "--perturb", "tilt=2"], "--perturb: 'tilt=2' is not"),
        (["eval", "--factor", "19", "--perturb", "gain=0"], "--perturb: gain must be > 0"),
        (["eval", "--protocol", "report", "--perturb", "gain=2"], "--perturb applies to"),
    ],
)
def test_eval_command_errors(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error:") and message in err[0]


def test_perturbation_does_what_it_says():
    """Gain and offset exactly, a 1 px vertical shift moves the rows down by one, noise
    is seeded, the result is clipped to the sensor's 0..255, the truth is kept."""
    data = load_motorcycle(19)
    e2 = data.image2
    p = Perturbation(gain=1.1, offset=-5.0)
    np.testing.assert_allclose(p.apply(e2), np.clip(1.1 * e2 - 5.0, 0, 255))
    np.testing.assert_allclose(Perturbation(vshift=1.0).apply(e2)[1:], e2[:-1], atol=1e-9)
    noisy = Perturbation(noise=5.0, seed=3)
    assert np.array_equal(noisy.apply(e2), noisy.apply(e2))
    assert not np.array_equal(noisy.apply(e2), Perturbation(noise=5.0, seed=4).apply(e2))
    assert Perturbation(gain=3.0).apply(e2).max() == 255.0
    assert Perturbation().is_identity and not p.is_identity
    out = perturb_right(data, Perturbation(blur=1.0))
    assert out.image1 is data.image1 and out.disparity is data.disparity
    assert not np.array_equal(out.image2, e2)
