"""P2 pipeline (Riccati sweep, issue 5): config, default-config budgets on ``lab`` vs
golden G5, cycle stamps, throughput assertion, line-buffer bits, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import SCENE_RICCATI
from rangefx.golden.riccati import range_g5
from rangefx.golden.scenes import render_scene
from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.p2.config import P2_SIGNALS, P2Config, loop_latency
from rangefx.rtl_model.p2.model import IN_LATENCY, OUT_LATENCY, run_p2
from rangefx.rtl_model.stream import pixel_cycles
from rangefx.tools.cli import main
from rangefx.tools.studies.runner import compare_ranges


@pytest.fixture(scope="module")
def lab():
    return render_scene("lab")


@pytest.fixture(scope="module")
def lab_runs(lab):
    cfg = SCENE_RICCATI["lab"]
    res = run_p2(lab.image1, lab.image2, lab.camera, lab.motion, P2Config.default(), cfg)
    gold = range_g5(lab.image1, lab.image2, lab.camera, lab.motion, cfg)
    return res, gold


# -- config ---------------------------------------------------------------------------
def test_default_config_round_trips_and_p1_is_untouched(tmp_path):
    cfg = P2Config.default()
    assert set(cfg.formats) == set(P2_SIGNALS)
    path = tmp_path / "p2.toml"
    cfg.save(path)
    assert P2Config.load(path) == cfg
    assert not set(P2_SIGNALS) & set(P1Config.default().formats)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"p2_w": FixedFormat(True, 50, 6, Quant.RND, Overflow.SAT)}, "'p2_lam'"),
        ({"p2_r": FixedFormat(False, 26, 25, Quant.RND, Overflow.WRAP)}, "'p2_r'"),
        ({"p2_st": FixedFormat(True, 26, 8, Quant.RND, Overflow.SAT)}, "'p2_st'"),
    ],
)
def test_bad_configs_name_the_signal(change, message):
    with pytest.raises(ValueError, match=message):
        P2Config.default().with_formats(**change)


def test_bad_toml_is_rejected():
    text = P2Config.default().to_toml()
    with pytest.raises(ValueError, match="p2_q"):
        P2Config.from_toml("\n".join(x for x in text.splitlines() if not x.startswith("p2_q")))
    with pytest.raises(ValueError, match="srt"):
        P2Config.from_toml(text.replace('divider = "reciprocal"', 'divider = "srt"'))


# -- lab, default config vs golden G5 ---------------------------------------------------
def test_lab_default_config_meets_the_budgets(lab_runs):
    res, gold = lab_runs
    assert res.overflow_total == 0
    cmp = compare_ranges(res, gold)
    assert cmp["median_rel_range_diff"] <= 0.01
    assert cmp["valid_agreement"] >= 0.99
    assert cmp["n_valid_both"] > 0.4 * res.valid.size


def test_taps_track_golden_signals(lab_runs, lab):
    """S = β s S~, Q = β s Q~, e and A agree with golden G5 away from the right edge (γ
    clamp) on almost every pixel; where they differ it is the κ floor after runs of
    ``d_k + d_k+1 = 0`` (S~ is bounded there, golden S grows by αδ per step)."""
    res, gold = lab_runs
    cfg, f = SCENE_RICCATI["lab"], res.config.formats
    beta_px = cfg.beta * cfg.pixel_pitch
    cols = slice(8, -8)
    s = f["p2_st"].to_float(res.taps["s"])[:, cols] * beta_px
    assert np.mean(np.abs(s / gold.terms["S"][:, cols] - 1) < 1e-3) > 0.88
    q = f["p2_q"].to_float(res.taps["q"])[:, cols] * beta_px
    assert np.percentile(np.abs(q - gold.terms["Q"][:, cols]), 99) < 1e-3
    e = f["p2_e"].to_float(res.taps["e"])
    assert np.mean(np.abs(e - gold.terms["e"]) < 0.05) > 0.99
    a = f["p2_a"].to_float(res.taps["a"])[:, :-1]
    a_gold = gold.terms["A"][:, :-1] * cfg.pixel_pitch  # A per inch² -> per pixel²
    assert np.allclose(a, a_gold, rtol=1e-4, atol=1e-5)


# -- timing ----------------------------------------------------------------------------
@pytest.mark.parametrize("hblank", [0, 9])
def test_cycle_stamps_closed_form(hblank):
    cfg = P2Config.default()
    lanes = cfg.effective_lanes()
    m, n = 2 * lanes, 24
    rng = np.random.default_rng(1)
    im1 = rng.integers(0, 256, (m, n))
    im2 = np.roll(im1, 1, axis=1)
    res = run_p2(im1, im2, PinholeCamera(n, m, 600.0), MotionIncrement.stereo(0.1), cfg,
                 SCENE_RICCATI["lab"], timing=TimingConfig(hblank=hblank), taps=False)  # fmt: skip
    tin = pixel_cycles((m, n), TimingConfig(hblank=hblank))[0]
    assert np.array_equal(res.in_cycles, tin)
    j, k = np.mgrid[0:m, 0:n]
    grp, lane = j // lanes, j % lanes
    tb = loop_latency(cfg)
    ready = ((grp + 1) * lanes - 1) * (n + hblank) + n + IN_LATENCY
    want = ready + (n - 1) * max(lanes, tb) + tb + k * lanes + lane + OUT_LATENCY
    assert np.array_equal(res.out_cycles, want)
    assert res.latency == int((want - tin).max())
    # one pixel per clock out: every output cycle distinct, one line per line time
    assert np.unique(res.out_cycles).size == m * n
    w = {k: f.word for k, f in cfg.formats.items()}
    assert res.line_buffer_bits == 2 * lanes * n * (w["p2_d"] + w["p2_ghat"])
    sweep = w["p2_a"] + w["p2_r"] + w["p2_st"] + w["p2_q"] + (w["p2_ghat"] + 1) + 1
    assert res.sweep_buffer_bits == 2 * lanes * n * sweep


def test_throughput_assertion():
    """Fewer lanes than the loop latency cannot sweep a line per line time with zero
    blanking: rejected; enough blanking makes the same design legal."""
    cfg = P2Config.default().with_(lanes=2)
    m, n = 4, 16
    im = np.zeros((m, n), dtype=np.int64)
    args = (im, im, PinholeCamera(n, m, 600.0), MotionIncrement.stereo(0.1), cfg)
    with pytest.raises(ValueError, match="one pixel per clock"):
        run_p2(*args, SCENE_RICCATI["lab"], taps=False)
    tb = loop_latency(cfg)
    hblank = -(-((n - 1) * tb) // 2) - n
    res = run_p2(*args, SCENE_RICCATI["lab"], timing=TimingConfig(hblank=hblank), taps=False)
    assert res.schedule["backward_cycles"] <= res.schedule["group_period"]


def test_gaps_change_only_cycle_stamps(lab):
    crop = (slice(200, 230), slice(100, 164))
    im1, im2 = lab.image1[crop], lab.image2[crop]
    cam = PinholeCamera(64, 30, lab.camera.f_px)
    base = run_p2(im1, im2, cam, lab.motion, None, SCENE_RICCATI["lab"])
    gap = run_p2(im1, im2, cam, lab.motion, None, SCENE_RICCATI["lab"],
                 timing=TimingConfig(hblank=3, vblank=5, gap_prob=0.3, seed=2))  # fmt: skip
    for k in base.taps:
        assert np.array_equal(base.taps[k], gap.taps[k])
    assert (gap.out_cycles >= base.out_cycles).all() and (gap.out_cycles > gap.in_cycles).all()


# -- CLI -------------------------------------------------------------------------------
def test_cli_run_p2_json(capsys):
    assert main(["run", "--scene", "lab", "--pipeline", "p2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["pipeline"] == "p2"
    assert out["overflows"]["total"] == 0 and set(P2_SIGNALS) <= set(out["overflows"])
    assert out["median_rel_range_diff"] <= 0.01 and out["valid_agreement"] >= 0.99
    assert out["line_buffer_bits"] > 0 and out["latency_cycles"] > 0
    assert [r["object"] for r in out["table"]] == [r["object"] for r in out["golden_table"]]


def test_demo_helper(tmp_path, lab):
    from rangefx.tools.cli.demo import demo_pipelines

    out = demo_pipelines(lab, tmp_path)["p2"]
    assert out["overflows"]["total"] == 0 and out["valid_agreement"] >= 0.99
    for f in ("range_p2.png", "hist_p2.png", "table_p2.csv"):
        assert (tmp_path / f).is_file()
