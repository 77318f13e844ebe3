"""P2 pipeline (Riccati sweep, issue 5): config, default-config budgets on ``lab`` vs
golden G5, cycle stamps, throughput assertion, line-buffer bits, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import SCENE_RICCATI
from rangefx.golden.riccati import range_g5
from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.p2.config import P2_SIGNALS, P2Config, loop_latency
from rangefx.rtl_model.p2.model import (
    FWD_LOOP,
    FWD_READ,
    IN_LATENCY,
    OUT_LATENCY,
    SWEEP_READ,
    group_starts,
    p2_schedule,
    sweep_address,
)
from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import PIPELINES
from rangefx.rtl_model.stream import input_cycles, pixel_cycles
from rangefx.tools.cli import main
from rangefx.tools.studies.runner import compare_ranges


def run_pair(image1, image2, camera, motion, config, riccati, timing=None, **kw):
    """P2 through its pipeline's public ``run`` on a stereo case of the pair."""
    case = Case(image1, image2, camera, motion, settings={"riccati": riccati})
    return PIPELINES["p2"].run(case, config, timing, **kw)


@pytest.fixture(scope="module")
def lab_runs(lab):
    cfg = SCENE_RICCATI["lab"]
    res = run_pair(lab.image1, lab.image2, lab.camera, lab.motion, P2Config.default(), cfg)
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
    res = run_pair(im1, im2, PinholeCamera(n, m, 600.0), MotionIncrement.stereo(0.1), cfg,
                 SCENE_RICCATI["lab"], timing=TimingConfig(hblank=hblank), taps=False)  # fmt: skip
    tin = pixel_cycles((m, n), TimingConfig(hblank=hblank))[0]
    assert np.array_equal(res.in_cycles, tin)
    j, k = np.mgrid[0:m, 0:n]
    grp, lane = j // lanes, j % lanes
    tb = loop_latency(cfg)
    ready = ((grp + 1) * lanes - 1) * (n + hblank) + n + IN_LATENCY
    want = ready + n * max(lanes, tb) + tb + k * lanes + lane + OUT_LATENCY
    assert np.array_equal(res.out_cycles, want)
    assert res.latency == int((want - tin).max())
    # one pixel per clock out: every output cycle distinct, one line per line time
    assert np.unique(res.out_cycles).size == m * n
    w = {k: f.word for k, f in cfg.formats.items()}
    assert res.line_buffer_bits == 2 * lanes * n * (w["p2_d"] + w["p2_ghat"])
    # D and ΔĜ (each one bit wider than d, Ĝ), r, S~, Q~: the forward pass recomputes a
    sweep = (w["p2_d"] + 1) + w["p2_r"] + w["p2_st"] + w["p2_q"] + (w["p2_ghat"] + 1)
    assert res.sweep_buffer_bits == lanes * n * sweep  # one bank (sweep_address)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("gap_prob", [0.0, 0.3])
def test_band_cycle_maps_equal_the_whole_frame_schedule(threads, gap_prob):
    """The bands fill their rows of both cycle maps (closed form without gaps): the same
    as the input beats and :func:`p2_schedule` over the whole frame, for a line count that
    splits a group of lanes between the two threads' bands."""
    cfg = P2Config.default()
    m, n = 3 * cfg.effective_lanes() + 1, 20
    timing = TimingConfig(hblank=4, vblank=3, gap_prob=gap_prob, seed=5)
    im1 = np.random.default_rng(2).integers(0, 256, (m, n))
    res = run_pair(im1, np.roll(im1, 1, axis=1), PinholeCamera(n, m, 600.0),
                 MotionIncrement.stereo(0.1), cfg, SCENE_RICCATI["lab"], timing=timing,
                 taps=False, threads=threads)  # fmt: skip
    tin = input_cycles((m, n), timing)[-1]
    want, info, _ = p2_schedule(tin, cfg, timing.hblank)
    assert np.array_equal(res.in_cycles, tin)
    assert np.array_equal(res.out_cycles, want)
    assert res.latency == int((want - tin).max()) and res.schedule == info


def _group_starts_by_hand(firsts, lasts, lanes, back, fwd, tb, reads, hold):
    """The group recurrence of docs/p2_datapath.md (Timing) on Python ints: a group's
    sweep starts when its last line is in and the previous sweep is done (and ``hold``
    after the forward start of group g - 1, whose sweep-buffer words it overwrites), its
    forward pass after its sweep and the previous forward pass; None where group g would
    overwrite the line buffer of group g - 2 before its sweep's last read."""
    m, starts = len(firsts), []
    for gi in range(-(-m // lanes)):
        first, last = gi * lanes, min(m, (gi + 1) * lanes) - 1
        b0 = lasts[last] + 1 + IN_LATENCY
        if gi >= 1:
            b0 = max(b0, starts[gi - 1][0] + back, starts[gi - 1][1] + hold)
        if gi >= 2:
            if starts[gi - 2][0] + reads > firsts[first] + IN_LATENCY:
                return None, gi
        f0 = b0 + back + tb
        if gi >= 1:
            f0 = max(f0, starts[gi - 1][1] + fwd)
        starts.append((b0, f0))
    return starts, -1


@pytest.mark.parametrize(
    ("seed", "arrival"),
    [(0, "gapped"), (1, "gapped"), (2, "gapped"), (3, "tight"), (4, "tight"), (5, "early"),
     (6, "early")],
)  # fmt: skip
def test_group_starts_follow_the_recurrence(seed, arrival):
    """Random line arrivals: ``gapped`` (some lines far late), ``tight`` (one pixel per
    clock without blanking and a short last group) and ``early`` (lines a few cycles
    apart, too fast for the line buffer): every group's start cycles, or the group the
    error names."""
    rng = np.random.default_rng(seed)
    config = P2Config.default()
    lanes, tb = config.effective_lanes(), loop_latency(config)
    n, hblank = int(rng.integers(4, 40)), int(rng.integers(0, 30))
    m = int(rng.integers(3 * lanes, 7 * lanes))
    pb, pf = max(lanes, tb), max(lanes, FWD_LOOP)
    back, fwd = n * pb, n * pf
    # the sweep of g writes slot i's word 1 cycle after the forward of g - 1 reads it
    reads, hold = (n - 1) * pb + lanes, max(pf - pb, (n - 1) * (pf - pb)) - SWEEP_READ - tb + 1
    if arrival == "tight":
        hblank, m = 0, 4 * lanes - 3
        firsts = np.arange(m) * n
        lasts = firsts + n - 1
    else:
        step = (0, 3) if arrival == "early" else (n + hblank, 3 * (n + hblank))
        firsts = np.cumsum(rng.integers(*step, m))
        lasts = firsts + n - 1 + rng.integers(0, 5 * n, m) * (rng.random(m) < 0.2)
    want, bad = _group_starts_by_hand(firsts.tolist(), lasts.tolist(), lanes, back, fwd, tb,
                                      reads, hold)  # fmt: skip
    assert (bad >= 0) == (arrival == "early")  # each outcome is reached
    if arrival == "early":
        with pytest.raises(ValueError, match=f"group {bad} .*group {bad - 2}'s sweep"):
            group_starts(firsts, lasts, n, config, hblank)
    else:  # a strided view of the first cycles, as in_cycles[:, 0]
        cycles = np.stack([firsts, lasts], axis=1)
        starts, info = group_starts(cycles[:, 0], cycles[:, 1], n, config, hblank)
        assert starts.tolist() == [list(s) for s in want]
        assert info["backward_cycles"] == back and info["forward_cycles"] == fwd


_T_B = {d: loop_latency(P2Config.default().with_(divider=d)) for d in ("reciprocal", "restoring")}


@pytest.mark.parametrize(
    ("divider", "lanes", "hblank", "gap_prob"),
    [("reciprocal", 0, 0, 0.0), ("reciprocal", 0, 7, 0.2),
     ("reciprocal", _T_B["reciprocal"] + 1, 0, 0.0), ("restoring", 0, 0, 0.0),
     ("restoring", _T_B["restoring"] + 1, 5, 0.3), ("reciprocal", 3, 1200, 0.0)],
)  # fmt: skip
def test_tap_cycles_are_the_oracles_one_sample_per_cycle(divider, lanes, hblank, gap_prob):
    """Every tap's cycles (the schedule, :mod:`rangefx.rtl_model.p2.taps`) equal the
    oracle's unit-by-unit restatement (``oracle_p2_cycles``), and no tap has two samples on
    one cycle (one register's output per cycle: the 100x64 case where ``e`` had 63 such
    cycles and the backward taps one), with a short last group."""
    from oracle_p2 import oracle_p2_cycles

    from rangefx.rtl_model.p2 import taps as p2_taps

    cfg = P2Config.default().with_(divider=divider, lanes=lanes)
    m, n = 64, 100
    rng = np.random.default_rng(3)
    im1 = rng.integers(0, 256, (m, n))
    timing = TimingConfig(hblank=hblank, gap_prob=gap_prob)
    res = run_pair(im1, np.roll(im1, 1, axis=1), PinholeCamera(n, m, 600.0),
                 MotionIncrement.stereo(0.1), cfg, SCENE_RICCATI["lab"], timing=timing,
                 taps=False)  # fmt: skip
    _, info, rows = p2_schedule(res.in_cycles, cfg, hblank)
    want = oracle_p2_cycles(res.in_cycles, cfg)
    assert np.array_equal(res.out_cycles, want["range"])
    for tap in p2_taps.tap_names():
        got = p2_taps.tap_cycles(tap, cfg, res.in_cycles, rows, info)
        assert np.array_equal(got, want[tap.rpartition(".")[2]]), tap
        assert np.unique(got).size == m * n, f"{tap}: two samples on one cycle"


def _bank_events(cfg, res, hblank):
    """Every access of P2's one sweep buffer over a frame, from the model's stamps: each
    write-back of an entry (line j, column k <= n - 2; the taps ``a`` ... ``q`` leave with
    it) and each forward read (tap ``e`` minus ``FWD_READ``; column n - 1's output is
    zeroed), at its word (:func:`sweep_address`). Arrays (word, cycle, is_write, key, used)
    where ``key`` is (j, k) as ``j n + k`` and ``used``: the read's data is used."""
    from rangefx.rtl_model.p2 import taps as p2_taps

    m, n = res.in_cycles.shape
    _, info, rows = p2_schedule(res.in_cycles, cfg, hblank)
    lanes = info["lanes"]
    write = p2_taps.tap_cycles("a", cfg, res.in_cycles, rows, info).reshape(m, n)
    read = p2_taps.tap_cycles("e", cfg, res.in_cycles, rows, info).reshape(m, n) - FWD_READ
    j, k = np.mgrid[0:m, 0:n]
    group, lane = j // lanes, j % lanes
    word = sweep_address(lane, k, group, n)
    key = j * n + k
    w = k < n - 1
    return (np.concatenate([word[w], word.ravel()]),
            np.concatenate([write[w], read.ravel()]),
            np.concatenate([np.ones(w.sum(), bool), np.zeros(m * n, bool)]),
            np.concatenate([key[w], key.ravel()]),
            np.concatenate([np.ones(w.sum(), bool), (k < n - 1).ravel()]))  # fmt: skip


@pytest.mark.parametrize(
    ("divider", "lanes", "shape", "hblank", "gap_prob"),
    [("reciprocal", 0, None, 0, 0.0), ("restoring", 0, None, 3, 0.2),
     ("reciprocal", 3, (64, 100), 1200, 0.0), ("reciprocal", 20, (64, 100), 80, 0.1),
     ("reciprocal", 40, (100, 64), 0, 0.0)],
)  # fmt: skip
def test_the_one_sweep_buffer_is_written_after_each_read_over_a_frame(
    lab, divider, lanes, shape, hblank, gap_prob
):
    """P2's single-bank sweep buffer over a whole frame (the 512x512 lab frame; 100x64
    crops with lanes below the loop latency and blanking, above it with a short last
    group), from the model's stamps: no word is accessed twice in one cycle, and every
    read whose data is used finds, as the last write of its word before it, its own entry
    (the same line and column). A sweep writing its group's entries in the previous
    group's column order breaks it (checked once by planting it)."""
    cfg = P2Config.default().with_(divider=divider, lanes=lanes)
    im1, im2, camera = lab.image1, lab.image2, lab.camera
    if shape is not None:
        im1, im2 = (
            im1[200 : 200 + shape[0], 100 : 100 + shape[1]],
            im2[200 : 200 + shape[0], 100 : 100 + shape[1]],
        )
        camera = PinholeCamera(shape[1], shape[0], lab.camera.f_px)
    timing = TimingConfig(hblank=hblank, gap_prob=gap_prob, seed=3)
    res = run_pair(im1, im2, camera, lab.motion, cfg, SCENE_RICCATI["lab"], timing=timing,
                   taps=False)  # fmt: skip
    word, cycle, is_write, key, used = _bank_events(cfg, res, hblank)
    order = np.lexsort((cycle, word))
    word, cycle, is_write, key, used = (a[order] for a in (word, cycle, is_write, key, used))
    same = word[1:] == word[:-1]
    assert not (same & (cycle[1:] == cycle[:-1])).any(), "two accesses of a word in one cycle"
    idx = np.arange(word.size)
    last_write = np.maximum.accumulate(np.where(is_write, idx, -1))
    reads = ~is_write & used
    lw = last_write[reads]
    assert (lw >= 0).all(), "a read before any write"
    assert np.array_equal(word[lw], word[reads]) and np.array_equal(key[lw], key[reads])


def test_throughput_assertion():
    """Fewer lanes than the loop latency cannot sweep a line per line time with zero
    blanking: rejected; enough blanking makes the same design legal."""
    cfg = P2Config.default().with_(lanes=2)
    m, n = 4, 16
    im = np.zeros((m, n), dtype=np.int64)
    args = (im, im, PinholeCamera(n, m, 600.0), MotionIncrement.stereo(0.1), cfg)
    with pytest.raises(ValueError, match="one pixel per clock"):
        run_pair(*args, SCENE_RICCATI["lab"], taps=False)
    tb = max(loop_latency(cfg), FWD_LOOP)  # the longer loop sets both periods at 2 lanes
    hblank = -(-(n * tb) // 2) - n
    res = run_pair(*args, SCENE_RICCATI["lab"], timing=TimingConfig(hblank=hblank), taps=False)
    assert res.schedule["backward_cycles"] <= res.schedule["group_period"]


def test_gaps_change_only_cycle_stamps(lab):
    crop = (slice(200, 230), slice(100, 164))
    im1, im2 = lab.image1[crop], lab.image2[crop]
    cam = PinholeCamera(64, 30, lab.camera.f_px)
    base = run_pair(im1, im2, cam, lab.motion, None, SCENE_RICCATI["lab"])
    gap = run_pair(im1, im2, cam, lab.motion, None, SCENE_RICCATI["lab"],
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
    from rangefx.tools.studies.demo import demo_pipelines

    out = demo_pipelines(lab, tmp_path)["p2"]
    assert out["overflows"]["total"] == 0 and out["valid_agreement"] >= 0.99
    for f in ("range_p2.png", "hist_p2.png", "table_p2.csv"):
        assert (tmp_path / f).is_file()


# -- the band kernel (issue 18) ----------------------------------------------------------
def _narrow(config: P2Config, seed: int) -> P2Config:
    """Every datapath signal 2..9 integer bits narrower, in random modes: overflows."""
    rng = np.random.default_rng(seed)
    formats = {}
    for name in P2_SIGNALS:
        f = config.formats[name]
        if name in ("p2_pix", "p2_ka_reg", "p2_m_reg"):
            formats[name] = f
            continue
        ovf = Overflow(int(rng.integers(0, 4)))
        ovf = Overflow.SAT if name == "p2_r" and ovf is Overflow.WRAP else ovf
        word = max(2, f.word - int(rng.integers(2, 10)))
        formats[name] = FixedFormat(f.signed, word, f.frac, Quant(int(rng.integers(0, 7))), ovf)
    return config.with_(formats=formats)


def _divider_fallback(config: P2Config) -> P2Config:
    """``p2_den`` at 28 fraction bits: the restoring divider's dividend ``1 << (F_r + 1 +
    F_den)`` is 2**54, beyond the float quotient of the lane divider, so every column of
    the band kernel takes its ``divide_lanes_scalar`` fallback."""
    f = config.formats["p2_den"]
    config = config.with_formats(p2_den=FixedFormat(f.signed, f.word, 28, f.quant, f.overflow))
    assert config.formats["p2_r"].frac + 1 + 28 >= 53
    return config


@pytest.mark.parametrize(
    ("divider", "variant"), [("reciprocal", "default"), ("restoring", "default"),
                             ("reciprocal", "narrow"), ("restoring", "narrow"),
                             ("restoring", "fallback")],
)  # fmt: skip
def test_band_kernel_equals_the_general_kernel_over_bands_and_threads(lab, divider, variant,
                                                                      monkeypatch):  # fmt: skip
    """37 lines (two full bands of 16 and a short one; two threads split a band) of a
    ``lab`` crop: every tap, output, overflow count and min/max of the band kernel equal
    the general kernel's (itself checked against the oracle in test_bitexact), with the
    log on and off, on one and two threads; default formats, narrow ones that overflow,
    and a divider beyond its lanes' float path (:func:`_divider_fallback`)."""
    from rangefx.rtl_model.p2 import model

    config = P2Config.default().with_(divider=divider)
    narrow = variant == "narrow"
    config = _narrow(config, 7) if narrow else config
    config = _divider_fallback(config) if variant == "fallback" else config
    im1, im2 = lab.image1[100:137, 200:260], lab.image2[100:137, 200:260]
    camera = PinholeCamera(60, 37, lab.camera.f_px)
    cfg = SCENE_RICCATI["lab"]
    assert model.band_fits(model.runtime.format_table(config))

    def run(**kw):
        return run_pair(im1, im2, camera, lab.motion, config, cfg, **kw)

    monkeypatch.setattr(model, "BANDED", False)
    ref = run(threads=1)
    monkeypatch.setattr(model, "BANDED", True)
    # not vacuous: valid ranges with the default formats, overflows with the narrow ones
    assert sum(ref.overflows.values()) > 0 if narrow else ref.valid.any()
    for threads in (1, 2):
        for log in (True, False):
            res = run(threads=threads, log=log)
            assert set(res.taps) == set(ref.taps)
            for name, want in ref.taps.items():
                np.testing.assert_array_equal(res.taps[name], want, err_msg=name)
            np.testing.assert_array_equal(res.range_raw, ref.range_raw)
            np.testing.assert_array_equal(res.valid, ref.valid)
            assert res.overflows == ref.overflows
            assert res.minmax == (ref.minmax if log else {})
    untapped = run(threads=2, taps=False, log=False)
    np.testing.assert_array_equal(untapped.range_raw, ref.range_raw)
    assert untapped.overflows == ref.overflows
    # the float range map, filled by the bands, is the raw map's value
    zf = config.formats["p2_z"]
    np.testing.assert_array_equal(untapped.range, zf.to_float(ref.range_raw))
    np.testing.assert_array_equal(ref.range, zf.to_float(ref.range_raw))


def test_a_cast_shifting_by_more_than_62_bits_takes_the_general_kernel(lab):
    """``p2_den`` at -40 fraction bits: its cast drops 70 bits, beyond cast_by_plan; the
    run takes the general kernel and still equals the oracle."""
    from oracles import ORACLES

    from rangefx.rtl_model.p2 import model
    from rangefx.rtl_model.pipeline import Case

    f = P2Config.default().formats["p2_den"]
    config = P2Config.default().with_formats(
        p2_den=FixedFormat(False, f.word, -40, f.quant, f.overflow)
    )
    assert not model.band_fits(model.runtime.format_table(config))
    camera = PinholeCamera(12, 3, lab.camera.f_px)
    case = Case(lab.image1[200:203, 300:312], lab.image2[200:203, 300:312], camera, lab.motion,
                "stereo", settings={"riccati": SCENE_RICCATI["lab"]})  # fmt: skip
    ref = ORACLES["p2"].run(case, config)
    res = PIPELINES["p2"].run(case, config)
    for name, want in ref.taps.items():
        np.testing.assert_array_equal(res.taps[name], want, err_msg=name)
    assert res.overflows == ref.overflows
    assert res.minmax == ref.minmax
