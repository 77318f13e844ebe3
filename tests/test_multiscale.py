"""G6 (golden multi-scale ranging, SPEC §12) on a known synthetic shift, its config and
streaming schedule, and the Middlebury protocol of ``rangefx eval``."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from skimage import data as skdata

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import METHODS, SCENE_RANGING, run_method
from rangefx.golden.multiscale import (
    AUTO_MAX_LEVELS,
    ZNCC_FLOOR,
    ZNCC_SCALE,
    MultiscaleConfig,
    claimed_max_disparity,
    disparity_g6,
    normalise_image,
    range_g6,
    streaming_schedule,
    warp_rows,
)
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.realdata import (
    Perturbation,
    disparity_from_range,
    load_motorcycle,
    middlebury_metrics,
    perturb_right,
    search_range,
)
from rangefx.golden.scenes import render_scene
from rangefx.tools import report
from rangefx.tools.cli import main
from rangefx.tools.studies import evaluation
from rangefx.tools.studies.evaluation import (
    MIDDLEBURY_KEYS,
    MIDDLEBURY_METHODS,
    MIDDLEBURY_PIPELINES,
    PEERS,
    peer_disparities,
    run_peers,
)

#: Sub-pixel steps of the synthetic shift: the texture is area-averaged over blocks of
#: this many texels, so a shift of ``s`` texels is an exact shift of ``s / _SUB`` px.
_SUB = 4
SHIFTS = (0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0)
_INTERIOR = np.s_[8:-8, 16:-8]  # away from the replicated borders and the unseen strip


@pytest.fixture(scope="module")
def texture() -> np.ndarray:
    return skdata.camera().astype(np.float64)


def shifted_pair(texture: np.ndarray, d: float) -> tuple[np.ndarray, np.ndarray]:
    """``E1(x) = E2(x - d)`` exactly: both views area-averaged from one texture."""
    s = round(d * _SUB)
    assert s == d * _SUB
    width = texture.shape[1] - 64
    a, b = texture[:, :width], texture[:, s : s + width]

    def area(z: np.ndarray) -> np.ndarray:
        m, n = z.shape[0] // _SUB * _SUB, z.shape[1] // _SUB * _SUB
        return z[:m, :n].reshape(m // _SUB, _SUB, n // _SUB, _SUB).mean(axis=(1, 3))

    return area(a), area(b)


def fixed_point_bound(e1: np.ndarray, e2: np.ndarray, d: float, cfg: MultiscaleConfig):
    """Per-pixel bound of the converged G6 error: ``ε_rms / g_rms`` (Cauchy–Schwarz).

    At the fixed point ``Σ w g e(u*) = 0``; with ``e(u*) ≈ -ε + (u* - d) g`` (``ε`` the
    interpolation error of the warp at the true shift, ``W(d) - E1``) this gives
    ``|u* - d| = |Σ w g ε| / Σ w g² <= sqrt(Σ w ε²) / sqrt(Σ w g²)``.
    """
    from scipy.ndimage import correlate1d

    w = cfg.window()

    def window(a: np.ndarray) -> np.ndarray:
        return correlate1d(correlate1d(a, w, axis=1, mode="nearest"), w, axis=0, mode="nearest")

    warped, _ = warp_rows(e2, np.full(e1.shape, d))
    eps = warped - e1
    g = 0.5 * (np.gradient(e1, axis=1) + np.gradient(warped, axis=1))
    return np.sqrt(window(eps * eps) / window(g * g))


def test_g6_error_stays_under_the_fixed_point_bound_up_to_the_claimed_disparity(texture):
    """Median |u - d| <= the median fixed-point bound at the worst sub-pixel fraction
    (t = 1/2, where cubic interpolation errs most), for every shift up to the claim of the
    default pyramid (2^(L-1) px); the clip is set beyond the claim so that it cannot help.
    G3 exceeds the same bound from 3 px on (the first-order Taylor limit)."""
    cfg = MultiscaleConfig(levels=4, max_disparity=12.0)
    assert claimed_max_disparity(cfg) == 8.0
    e1, e2 = shifted_pair(texture, 0.5)
    bound = float(np.median(fixed_point_bound(e1, e2, 0.5, cfg)[_INTERIOR]))
    assert 0.2 < bound < 0.6  # the interpolation error of this texture, measured
    camera = PinholeCamera(e1.shape[1], e1.shape[0], 100.0)
    for d in SHIFTS:
        e1, e2 = shifted_pair(texture, d)
        out = disparity_g6(e1, e2, cfg)
        err = np.abs(out["disparity"] - d)[_INTERIOR]
        assert np.median(err) <= bound / 2, d
        assert out["valid"][_INTERIOR].mean() >= 0.7, d
        if d >= 3.0:
            g3 = run_method(
                "g3_consistent", e1, e2, camera, MotionIncrement.stereo(1.0),
                ranging=RangingConfig(range_max=1e6),
            )  # fmt: skip
            e3 = np.abs(100.0 / g3.range - d)[_INTERIOR][g3.valid[_INTERIOR]]
            assert np.median(e3) > bound, d


def test_g6_on_the_lab_pair_meets_the_issue_targets():
    """Every object's median range within 3 % and a valid fraction >= 0.5 (issue 16)."""
    scene = render_scene("lab")
    assert "g6_multiscale" in METHODS
    r = run_method(
        "g6_multiscale", scene.image1, scene.image2, scene.camera, scene.motion,
        ranging=SCENE_RANGING["lab"],
    )  # fmt: skip
    assert r.valid.mean() >= 0.5
    for row in report.object_table(r.range, r.valid, scene.labels1, scene.objects, scene.depth1):
        assert abs(row["estimated_median"] / row["actual"] - 1) <= 0.03, row["object"]
    assert np.all(r.range[~r.valid] == SCENE_RANGING["lab"].range_max)


def test_g6_mirrors_a_left_baseline():
    scene = render_scene("lab", size=(64, 64))
    right = run_method(
        "g6_multiscale", scene.image1, scene.image2, scene.camera, scene.motion,
        ranging=RangingConfig(range_max=100.0),
    )  # fmt: skip
    left = run_method(
        "g6_multiscale", scene.image2[:, ::-1], scene.image1[:, ::-1], scene.camera,
        MotionIncrement.stereo(-0.1), ranging=RangingConfig(range_max=100.0),
    )  # fmt: skip
    assert left.valid.any()
    assert left.range.shape == right.range.shape


def test_g6_rejects_the_motion_form():
    scene = render_scene("runway", size=(32, 32))
    with pytest.raises(ValueError, match="stereo pair"):
        run_method("g6_multiscale", scene.image1, scene.image2, scene.camera, scene.motion)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"levels": 0}, "levels"),
        ({"warps": 2.5}, "warps"),
        ({"sigma": -1.0}, "sigma"),
        ({"threshold_r": float("nan")}, "threshold_r"),
        ({"max_disparity": 0.0}, "max_disparity"),
    ],
)
def test_config_rejects_bad_values(changes, message):
    with pytest.raises(ValueError, match=message):
        MultiscaleConfig(**changes)


def test_window_is_normalised_and_symmetric():
    w = MultiscaleConfig().window()
    assert w.size == 2 * MultiscaleConfig().radius + 1
    assert w.sum() == pytest.approx(1.0)
    np.testing.assert_array_equal(w, w[::-1])


def test_streaming_schedule_by_hand():
    """L = 4, limit 8 px, k = 2 warps, r = 4: λ3 = k r = 8 coarse lines; each finer
    level waits 4 + 2 λ_{l+1} lines for the coarse estimate, then adds k r. The
    normalisation (R = 4) runs beside that wait: only the coarsest level's R lines add
    latency; it holds 2 R lines per camera and level, and the delay lines R fewer."""
    cfg = MultiscaleConfig(levels=4, max_disparity=8.0, normalise="none", vertical=False)
    s = streaming_schedule(cfg, 512)
    lam = [lv["latency_lines"] for lv in s["levels"]]
    delay = [lv["delay_lines"] for lv in s["levels"]]
    assert lam[3] == 8 and delay[3] == 0
    assert delay[2] == 4 + 2 * 8 and lam[2] == delay[2] + 8
    assert delay[1] == 4 + 2 * lam[2] and lam[1] == delay[1] + 8
    assert delay[0] == 4 + 2 * lam[1] and s["latency_lines"] == lam[0] == delay[0] + 8 == 148
    assert [lv["width"] for lv in s["levels"]] == [512, 256, 128, 64]
    lv0 = s["levels"][0]["buffer_words"]
    assert lv0["warp_row"] == 2 * (8 + 4)  # E2 row buffer: the largest disparity + 4 taps
    assert lv0["coarse_delay"] == 2 * 140 * 512 and lv0["normalise"] == 0
    assert s["buffer_words"] == sum(sum(lv["buffer_words"].values()) for lv in s["levels"])
    norm = streaming_schedule(cfg.with_(normalise="local_mean", normalise_radius=4), 512)
    lam = [lv["latency_lines"] for lv in norm["levels"]]
    assert lam == [4 + 2 * 84 + 8, 4 + 2 * 36 + 8, 4 + 2 * 12 + 8, 4 + 8] == [180, 84, 36, 12]
    for lv in norm["levels"]:
        assert lv["buffer_words"]["normalise"] == 2 * 8 * lv["width"]
        assert lv["buffer_words"]["coarse_delay"] == 2 * max(lv["delay_lines"] - 4, 0) * lv["width"]


def test_middlebury_metrics_by_hand():
    truth = np.array([[1.0, 2.0, np.inf], [4.0, 0.5, 3.0]])
    est = np.array([[1.25, 3.5, 9.0], [4.0, 0.5, 0.0]])
    valid = np.array([[True, True, True], [True, False, True]])
    metric = np.array([[10.0, 5.0, np.inf], [2.5, 12.5, 3.0]])
    # f B = 10, doffs 0: scored (valid, known) = (0,0), (0,1), (1,0),
    # (1,2); |errors| 0.25, 1.5, 0, 3
    out = middlebury_metrics(est, valid, truth, metric, 0.0, 2.0, 5.0)
    assert out["density"] == 5 / 6  # over all pixels, the unknown-truth one included
    assert out["n_scored"] == 4
    assert out["mae_px"] == (0.25 + 1.5 + 0.0 + 3.0) / 4
    assert out["bad_0_5"] == 50.0  # 1.5 and 3
    assert out["bad_1"] == 50.0
    assert out["bad_2"] == 25.0  # 3 only
    # Z = 10 / d: 8, 10/3.5, 2.5, inf(d = 0) vs 10, 5, 2.5, 3 -> 0.2, 0.428..., 0, inf
    assert out["rel_depth_error"] == pytest.approx((0.2 + (1 - (10 / 3.5) / 5)) / 2)
    with_doffs = middlebury_metrics(est, valid, truth, metric, 1.0, 2.0, 5.0)
    # Z = 10 / (d + 1): 10/2.25, 10/4.5, 2, 10 vs 10, 5, 2.5, 3
    expected = np.median([1 - 1 / 2.25, 1 - 2 / 4.5, 0.2, 10 / 3 - 1])
    assert with_doffs["rel_depth_error"] == pytest.approx(expected)


def test_middlebury_metrics_reject_bad_input():
    z = np.zeros((2, 2))
    with pytest.raises(ValueError, match="one shape"):
        middlebury_metrics(z, np.zeros((2, 3), bool), z, z, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="boolean"):
        middlebury_metrics(z, z, z, z, 0.0, 1.0, 1.0)


def _eval_json(capsys, argv: list[str]) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_eval_middlebury_json_keys(capsys):
    out = _eval_json(capsys, ["eval", "--factor", "19", "--json"])
    assert out["protocol"] == "middlebury" and out["factor"] == 19
    assert list(out["factors"]) == ["19"]
    methods = out["factors"]["19"]["methods"]
    assert list(methods) == [*MIDDLEBURY_METHODS, *MIDDLEBURY_PIPELINES]
    assert out["factors"]["19"]["overflows"] == {"p3": 0, "p3_gt_informed": 0}
    assert set(out["factors"]["19"]["gt_informed"]) == {"g6_multiscale", "p3"}
    for figures in methods.values():
        assert set(figures) == set(MIDDLEBURY_KEYS)
        assert 0 < figures["density"] <= 1
        assert figures["bad_0_5"] >= figures["bad_1"] >= figures["bad_2"] >= 0
    g6, g3 = methods["g6_multiscale"], methods["g3_consistent"]
    assert g6["mae_px"] < g3["mae_px"] and g6["density"] > g3["density"]
    assert set(out["fixed_point"]) >= {"p1_paper", "p1_consistent", "p2", "p3"}
    # P3, the fixed-point G6, scores as its golden does on the pair's integer grey levels
    p3 = methods["p3"]
    assert abs(p3["density"] - g6["density"]) < 0.01 and abs(p3["mae_px"] - g6["mae_px"]) < 0.02


def test_eval_peers_skipped_cleanly_without_opencv(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "cv2", None)  # `import cv2` raises ImportError
    out = _eval_json(capsys, ["eval", "--factor", "19", "--peers", "--json"])
    assert "OpenCV is not installed" in out["peers"]["note"]
    assert not set(PEERS) & set(out["factors"]["19"]["methods"])
    assert main(["eval", "--factor", "19", "--peers"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: note:") and "peers skipped" in err[0]


def test_eval_peers_with_opencv(capsys):
    pytest.importorskip("cv2")
    out = _eval_json(capsys, ["eval", "--factor", "19", "--peers", "--json"])
    methods = out["factors"]["19"]["methods"]
    assert out["peers"]["note"] is None
    for peer in PEERS:
        assert set(methods[peer]) == set(MIDDLEBURY_KEYS) and methods[peer]["density"] > 0


def test_eval_peers_need_the_middlebury_protocol(capsys):
    assert main(["eval", "--protocol", "report", "--peers"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--peers applies to --protocol middlebury" in err[0]
    assert main(["eval", "--protocol", "kitti"]) == 2
    assert "unknown protocol 'kitti'" in capsys.readouterr().err


def test_coarse_lag_trades_delay_lines_for_a_stale_coarse_estimate():
    lagged = streaming_schedule(
        MultiscaleConfig(levels=4, max_disparity=8.0, coarse_lag=8, normalise="none",
                         vertical=False), 512, 512,
    )  # fmt: skip
    assert [lv["delay_lines"] for lv in lagged["levels"]] == [84, 36, 12, 0]
    assert lagged["latency_lines"] == 92
    e1 = np.tile(np.arange(40.0), (40, 1)) ** 2 % 97
    a = disparity_g6(e1, e1, MultiscaleConfig(levels=2))
    b = disparity_g6(e1, e1, MultiscaleConfig(levels=2, coarse_lag=3))
    assert a["disparity"].shape == b["disparity"].shape


@pytest.mark.parametrize(
    ("width", "given", "limit", "levels"),
    [
        (185, {}, 185 / 8, 5),  # the motorcycle pair at 1/4 (the auto depth's cap)
        (512, {}, 64.0, 5),  # lab: the cap, not the 7 levels the limit asks
        (39, {}, 39 / 8, 4),  # and at 1/19
        (4, {}, 1.0, 1),  # never below the coarse level's pixel
        (185, {"max_disparity": 16.0}, 16.0, 5),  # the user's limit sets the depth
        (185, {"levels": 3}, 185 / 8, 3),  # the user's depth is kept
    ],
)
def test_the_limit_and_the_depth_come_from_the_user_or_the_width(width, given, limit, levels):
    """No ground truth: the disparity limit is the user's or 1/8 of the width, the
    pyramid depth the user's or the fewest levels whose claim covers the limit."""
    cfg = MultiscaleConfig(**given).resolve(width)
    assert cfg.disparity_limit == pytest.approx(limit) and cfg.levels == levels
    assert claimed_max_disparity(cfg) >= limit or "levels" in given or levels == AUTO_MAX_LEVELS
    assert cfg.levels <= AUTO_MAX_LEVELS or "levels" in given
    assert cfg.resolve(width) == cfg  # resolved: nothing left to choose
    with pytest.raises(ValueError, match="resolve"):
        _ = MultiscaleConfig().disparity_limit


@pytest.mark.parametrize("factor", [4, 8, 16, 19])
def test_g6_as_shipped_scores_as_with_the_ground_truth_limit(factor):
    """The shipped settings (limit from the width) on the motorcycle pair give the
    figures of the run given the ground truth's search range, within 1 %."""
    data = load_motorcycle(factor)
    figures = {}
    for label, cfg in (
        ("shipped", MultiscaleConfig()),
        ("gt", MultiscaleConfig(max_disparity=float(search_range(data)))),
    ):
        r = range_g6(data.image1, data.image2, data.camera, data.motion, cfg,
                     RangingConfig(range_max=data.range_max))  # fmt: skip
        figures[label] = middlebury_metrics(
            disparity_from_range(r.range, data), r.valid, data.disparity, data.metric_depth,
            data.doffs_px, data.camera.f_px, abs(float(data.motion.camera_displacement[1])),
        )  # fmt: skip
    shipped, gt = figures["shipped"], figures["gt"]
    assert shipped["density"] >= 0.99 * gt["density"]
    assert shipped["mae_px"] <= 1.01 * gt["mae_px"]


def test_eval_headline_takes_nothing_from_the_ground_truth(capsys, monkeypatch):
    """A different ground-truth search range changes the ``gt_informed`` rows and not a
    figure of the headline (every method, P3 and the peers included)."""
    pytest.importorskip("cv2")
    argv = ["eval", "--factor", "19", "--peers", "--json"]
    plain = _eval_json(capsys, argv)["factors"]["19"]
    monkeypatch.setattr(evaluation, "search_range", lambda data: 40)
    moved = _eval_json(capsys, argv)["factors"]["19"]
    assert moved["methods"] == plain["methods"]
    assert moved["valid_in_both"] == plain["valid_in_both"]
    assert moved["gt_informed"] != plain["gt_informed"]


def test_eval_max_disparity_is_the_users_setting(capsys):
    """``--max-disparity`` equal to the search range reproduces the gt_informed rows."""
    pytest.importorskip("cv2")
    data = load_motorcycle(19)
    out = _eval_json(
        capsys, ["eval", "--factor", "19", "--peers", "--json",
                 "--max-disparity", str(search_range(data))]
    )  # fmt: skip
    assert out["max_disparity"] == search_range(data)
    figures = out["factors"]["19"]
    for name, gt in figures["gt_informed"].items():
        assert figures["methods"][name] == gt, name


def test_peers_are_padded_on_the_left():
    """Unpadded, OpenCV returns nothing in the leftmost numDisparities columns; padded,
    SGBM covers most of them."""
    pytest.importorskip("cv2")
    data = load_motorcycle(19)
    ndisp = peer_disparities(data.camera.width, None)
    assert ndisp == 16  # 39 px wide: OpenCV's sample rule, width / 8 rounded up to 16
    found, note = run_peers(data)
    assert note is None
    disparity, valid = found["opencv_sgbm"]
    assert disparity.shape == data.image1.shape
    assert valid[:, :ndisp].mean() > 0.8


def test_eval_perturb_changes_the_right_image_only(capsys):
    """``--perturb`` is reported and moves the figures; the P3 overflow count is there."""
    argv = ["eval", "--factor", "19", "--json"]
    plain = _eval_json(capsys, argv)
    out = _eval_json(capsys, [*argv, "--perturb", "gain=1.1,vshift=1,seed=2"])
    assert out["perturbation"]["gain"] == 1.1 and out["perturbation"]["vshift"] == 1.0
    assert out["factors"]["19"]["methods"] != plain["factors"]["19"]["methods"]
    assert "p3" in out["factors"]["19"]["overflows"]
    # the fixed-point section runs on the perturbed pair too: its scores move, the
    # golden beside each pipeline runs on the same perturbed case (agreement stays)
    for name in ("p3", "p1_consistent"):
        got, was = out["fixed_point"][name], plain["fixed_point"][name]
        assert got["fixed_vs_truth"] != was["fixed_vs_truth"], name
        assert got["golden_vs_truth"] != was["golden_vs_truth"], name
    assert out["fixed_point"]["p3"]["valid_agreement"] >= 0.99


@settings(max_examples=30, deadline=None)
@given(
    offset=st.floats(-60.0, 60.0),
    radius=st.integers(1, 5),
    seed=st.integers(0, 2**16),
)
# the dev profile's counterexample (docs/testing.md): a corner's box, borders replicated,
# has a deviation of 7.6 grey levels, within 2x the floor, where a gain does not cancel
@example(offset=0.0, radius=1, seed=8877)
def test_local_mean_removal_cancels_an_offset(offset, radius, seed):
    """``local_mean``: an offset between the cameras leaves the normalised image as it
    was; ``zncc`` is eq ``ZNCC_SCALE (e - mean) / sqrt(var + ZNCC_FLOOR^2)`` over the box
    at every pixel, and so cancels a gain where the box's deviation is well above the
    floor (>= 8 ZNCC_FLOOR: within 0.8 %)."""
    e = np.random.default_rng(seed).uniform(0, 255, (12, 15))
    n = normalise_image(e, "local_mean", radius)
    assert np.allclose(normalise_image(e + offset, "local_mean", radius), n, atol=1e-9)
    y, x = 6, 7  # by hand: the pixel less the mean of its box, borders replicated
    rows = np.clip(np.arange(y - radius, y + radius + 1), 0, 11)
    cols = np.clip(np.arange(x - radius, x + radius + 1), 0, 14)
    assert n[y, x] == pytest.approx(e[y, x] - e[np.ix_(rows, cols)].mean())
    gain = 4.0
    z = normalise_image(e, "zncc", radius)
    zg = normalise_image(gain * e + offset, "zncc", radius)
    deviation = np.empty_like(e)
    for y, x in np.ndindex(e.shape):  # by hand, every pixel
        rows = np.clip(np.arange(y - radius, y + radius + 1), 0, 11)
        cols = np.clip(np.arange(x - radius, x + radius + 1), 0, 14)
        box = e[np.ix_(rows, cols)]
        deviation[y, x] = box.std()
        for g, got in ((1.0, z), (gain, zg)):
            want = ZNCC_SCALE * g * (e[y, x] - box.mean()) / np.hypot(g * box.std(), ZNCC_FLOOR)
            assert got[y, x] == pytest.approx(want, rel=1e-6, abs=1e-6)
    away = deviation >= 8 * ZNCC_FLOOR
    assert np.allclose(zg[away], z[away], rtol=0.008, atol=1e-6)


@pytest.mark.parametrize("perturb", [{"gain": 0.9}, {"gain": 1.1}, {"offset": 10.0}])
def test_gain_or_offset_between_the_cameras_moves_g6_mae_by_at_most_10_percent(perturb):
    """The issue's target at 1/8: shipped G6 (local mean removal) within 10 % of its
    unperturbed MAE and density; without the normalisation the same change costs more
    than 40 %."""
    data = load_motorcycle(8)

    def score(d, cfg):
        out = disparity_g6(d.image1, d.image2, cfg)
        baseline = abs(float(d.motion.camera_displacement[1]))
        return middlebury_metrics(out["disparity"], out["valid"], d.disparity,
                                  d.metric_depth, d.doffs_px, d.camera.f_px, baseline)  # fmt: skip

    moved = perturb_right(data, Perturbation(**perturb))
    for cfg, most in ((MultiscaleConfig(), 0.10), (MultiscaleConfig(normalise="none"), None)):
        plain, got = score(data, cfg), score(moved, cfg)
        change = abs(got["mae_px"] / plain["mae_px"] - 1)
        if most is None:
            assert change > 0.4
        else:
            assert change <= most and got["density"] >= 0.95 * plain["density"]


def test_the_vertical_term_tolerates_a_pixel_of_misalignment():
    """The window form of ``vertical`` (``vertical_radius`` 0, ``threshold_g`` 1): a 1 px
    vertical shift of the right image at 1/8 keeps the MAE <= 0.6 px where the 1-D fit
    errs by > 1 px."""
    data = perturb_right(load_motorcycle(8), Perturbation(vshift=1.0))
    baseline = abs(float(data.motion.camera_displacement[1]))
    mae = {}
    for vertical in (False, True):
        cfg = MultiscaleConfig(vertical=vertical, vertical_radius=0, threshold_g=1.0)
        out = disparity_g6(data.image1, data.image2, cfg)
        d, v = out["disparity"], out["valid"]
        f_px = data.camera.f_px
        m = middlebury_metrics(
            d, v, data.disparity, data.metric_depth, data.doffs_px, f_px, baseline
        )
        mae[vertical] = m["mae_px"]
    assert mae[False] > 1.0 and mae[True] <= 0.6


BOX = {"vertical": True, "vertical_radius": 8, "threshold_r": 25.0, "threshold_g": 0.5}


@pytest.mark.parametrize("vshift", [1.0, -1.0])
def test_the_box_form_of_the_vertical_term_meets_the_target_both_ways(vshift):
    """``vertical_radius`` 8 (``v`` from the 17 x 17 box, ``u`` from the 1-D fit on ``e +
    gy v``): a 1 px vertical shift of the right image at 1/8, down or up, keeps density
    >= 0.75 and MAE <= 0.6 px (the window form misses the MAE shifted up)."""
    data = perturb_right(load_motorcycle(8), Perturbation(vshift=vshift))
    out = disparity_g6(data.image1, data.image2, MultiscaleConfig(**BOX))
    baseline = abs(float(data.motion.camera_displacement[1]))
    m = middlebury_metrics(out["disparity"], out["valid"], data.disparity, data.metric_depth,
                           data.doffs_px, data.camera.f_px, baseline)  # fmt: skip
    assert m["density"] >= 0.75 and m["mae_px"] <= 0.6


def test_the_box_form_estimates_a_global_vertical_shift():
    """On a smooth random texture shifted 2 px along the rows and 0.4 px down the columns,
    the box form's ``v`` (level 0, last warp) is the vertical shift in the middle of the
    image and the disparity the horizontal one; without ``v`` the disparity errs more."""
    rng = np.random.default_rng(3)
    from scipy.ndimage import gaussian_filter, shift

    big = gaussian_filter(rng.uniform(0, 255, (96, 128)), 2.0) * 4 - 380
    e1 = big
    e2 = shift(big, (-0.4, -2.0), order=3, mode="nearest")  # E2(x - 2, y + 0.4) = E1
    cfg = MultiscaleConfig(levels=2, normalise="none", max_disparity=8.0, **BOX)
    out = disparity_g6(e1, e2, cfg, trace=True)
    mid = (slice(30, 66), slice(30, 100))
    assert abs(np.median(out[f"v{cfg.warps - 1}"][mid]) - 0.4) < 0.05
    err_box = np.abs(out["disparity"][mid] - 2.0).mean()
    plain = disparity_g6(e1, e2, cfg.with_(vertical=False))["disparity"][mid]
    assert err_box < 0.05 < np.abs(plain - 2.0).mean()


def test_the_box_form_schedule():
    """The box form keeps a stage's r + 1 lines and holds five row sums of 2 rv lines down
    the columns in place of the window form's three of 2 r."""
    cfg = MultiscaleConfig(levels=1, warps=2, radius=4, max_disparity=8.0, vertical_radius=0)
    window = streaming_schedule(cfg, 100)
    box = streaming_schedule(cfg.with_(vertical_radius=8), 100)
    assert box["latency_lines"] == window["latency_lines"]
    words = lambda s: s["levels"][0]["buffer_words"]["vertical_products"]  # noqa: E731
    assert words(window) == 2 * 3 * 8 * 100 and words(box) == 2 * 5 * 16 * 100
