"""P3, the fixed-point G6 (SPEC §12, issue 16): the shipped default against its golden
and the issue's targets, zero overflows on every pair it was sized on, the streaming
schedule (line buffers and latency in lines) through the interface, the Keys ROM, and
the cases it refuses. Bit-exactness against ``tests/oracle_p3.py`` is in
``tests/test_bitexact.py`` (parametrised over every pipeline)."""

from __future__ import annotations

import json
from dataclasses import replace
from fractions import Fraction

import numpy as np
import pytest
from bitexact_cases import assert_bit_exact, lab_crop, p3_case
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles import ORACLES

from rangefx.golden.geometry import MotionIncrement
from rangefx.golden.multiscale import streaming_schedule
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.realdata import (
    Perturbation,
    disparity_from_range,
    load_motorcycle,
    middlebury_metrics,
    perturb_right,
    search_range,
)
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p3 import cost as p3_model_cost
from rangefx.rtl_model.p3 import model as p3_model
from rangefx.rtl_model.p3.model import buffer_bits, keys_exact, keys_rom, keys_weights
from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import PIPELINES
from rangefx.tools import report
from rangefx.tools.cli import main
from rangefx.tools.studies.cases import real_pair_case, scene_case

P3 = PIPELINES["p3"]


def test_default_on_lab_meets_the_issue_targets():
    """``lab``: 0 overflows, median |fixed - golden| / golden <= 0.5 %, valid agreement
    >= 99 %, every object's median within 3 % of the truth, valid fraction >= 0.5."""
    case = scene_case("lab")
    result = P3.run(case, taps=False)
    golden = P3.golden(case).result
    assert result.overflow_total == 0 and result.saturated_registers == ()
    both = result.valid & golden.valid
    rel = np.abs(result.range[both] - golden.range[both]) / golden.range[both]
    assert np.median(rel) <= 5e-3
    assert np.mean(result.valid == golden.valid) >= 0.99
    assert result.valid_fraction >= 0.5
    scene = case.scene
    rows = report.object_table(
        result.range, result.valid, scene.labels1, scene.objects, scene.depth1
    )
    assert len(rows) == 5
    for row in rows:
        assert abs(row["estimated_median"] / row["actual"] - 1) <= 0.03, row["object"]


@pytest.mark.parametrize("factor", [4, 8, 16, 19])
def test_no_overflow_on_the_motorcycle_pair(factor):
    """The factors ``rangefx eval`` scores, as shipped (the limit from the width) and
    with the search range as a user's max_disparity, the vertical term's box form (the
    default), its window form and off: 0 overflows, P3 within 0.5 % of G6."""
    case = real_pair_case("motorcycle", factor)
    md = float(search_range(load_motorcycle(factor)))
    configs = (
        P3.default_config(),
        P3.default_config(max_disparity=md),
        P3.default_config(vertical_radius=0),
        P3.default_config(vertical_radius=0, max_disparity=md),
        P3.default_config(vertical=False),
    )
    for config in configs:
        result = P3.run(case, config, taps=False)
        golden = P3.golden(case, config).result
        assert result.overflow_total == 0, {k: v for k, v in result.overflows.items() if v}
        assert result.saturated_registers == ()
        both = result.valid & golden.valid
        rel = np.abs(result.range[both] - golden.range[both]) / golden.range[both]
        assert np.median(rel) <= 5e-3 and np.mean(result.valid == golden.valid) >= 0.99


def test_line_buffers_and_latency_follow_the_streaming_schedule():
    """Every buffer of G6's schedule is counted with its formats, the output leaves
    ``latency_lines`` lines after its input line (flush lines after the frame), and no
    frame store."""
    config = P3.default_config()
    f = config.formats
    m, n = 512, 512
    sched = streaming_schedule(config.multiscale(), n, m)
    bits = buffer_bits(config, (m, n))
    lv0 = sched["levels"][0]
    assert bits["coarse_delay"] >= lv0["buffer_words"]["coarse_delay"] * f["p3_pix"].word
    words = sum(sum(lv["buffer_words"].values()) for lv in sched["levels"])
    assert words == sched["buffer_words"]
    cost = P3.cost(config, (m, n))
    assert cost.line_buffer_bits == sum(bits.values()) and cost.frame_store_bits == 0
    # one more bit of the pyramid word costs every line that holds a coarse level
    wider = config.with_formats(p3_pyr=replace(f["p3_pyr"], word=f["p3_pyr"].word + 1))
    assert P3.cost(wider, (m, n)).line_buffer_bits > cost.line_buffer_bits
    case = scene_case("lab")
    result = P3.run(case, taps=False)
    # 512 px wide: limit 64 px, 5 levels (the auto depth's cap), each coarser level
    # doubling the delay; the coarsest level's normalisation adds R = 4 of its lines; the
    # vertical term one line a warp stage at every level (2 + 4 + 8 + 16 + 32 = 62)
    assert result.schedule["levels"] == 5
    assert result.schedule["latency_lines"] == sched["latency_lines"] == 308 + 16 * 4 + 62
    assert result.line_buffer_bits == cost.line_buffer_bits
    lines = (result.out_cycles - result.in_cycles) // n  # no blanking: n clocks per line
    assert lines.min() == sched["latency_lines"]


def test_keys_rom_is_the_exact_cubic_at_its_fractions():
    config = P3.default_config()
    rom = keys_rom(config)
    frac = config.formats["p3_keys"].frac
    assert rom.shape == (1 << config.keys_bits, 4)
    for i in (0, 1, 77, 128, 255):
        t = Fraction(i, rom.shape[0])
        exact = keys_weights(float(t))
        assert np.allclose(rom[i] * 2.0**-frac, exact, atol=2.0 ** -(frac + 1))
    assert rom[0].tolist() == [0, 1 << frac, 0, 0]  # t = 0: the pixel itself
    assert abs(int(rom.sum(axis=1).max()) - (1 << frac)) <= 2  # partition of unity


def test_cases_p3_does_not_model_are_errors():
    with pytest.raises(ValueError, match="P3 models stereo mode only"):
        P3.run(scene_case("runway"))
    case = scene_case("lab")
    mirrored = Case(case.image1, case.image2, case.camera, MotionIncrement.stereo(-0.1))
    with pytest.raises(ValueError, match="second camera on the right"):
        P3.run(mirrored)


def test_range_max_option_reaches_p3(capsys):
    """``--range-max`` is a case option P3 reads (its only one): the register holds it."""
    argv = ["run", "--pipeline", "p3", "--scene", "lab", "--range-max", "50", "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["registers"]["range_max"] == [50.0, 50.0] and out["overflows"]["total"] == 0


def test_keys_rom_overflow_is_counted_as_its_signal():
    """A ROM that cannot hold its weights (s11.11 WRAP turns the weight 1.0 into 0) is
    counted under ``p3_keys``, once per weight, and logged with the exact weights'
    range; the default ROM holds them all."""
    case = p3_case(4, "random")
    default = P3.run(case, taps=False)
    assert default.overflows["p3_keys"] == 0
    exact = [Fraction(w, 2 ** (3 * 8 + 1)) for i in range(256) for w in keys_exact(i, 8)]
    assert default.minmax["p3_keys"] == (float(min(exact)), 1.0)
    f = default.config.formats["p3_keys"]
    wrap = default.config.with_formats(p3_keys=FixedFormat(True, 11, 11, Quant.TRN, Overflow.WRAP))
    result = P3.run(case, wrap, taps=False)
    outside = sum(not -0.5 <= w < 0.5 for w in exact)  # the weights s11.11 cannot hold
    assert outside > 0 and result.overflows["p3_keys"] == outside
    assert result.overflow_total >= outside
    assert keys_rom(wrap)[0].tolist() == [0, 0, 0, 0]  # t = 0: W = 0, silently
    assert f.signed


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("quant", [Quant.RND, Quant.TRN])
def test_oracle_and_model_agree_on_negative_fraction_bits(seed, quant):
    """The optimiser's ``u1.-15`` style formats (an LSB above 1): every signal that may
    have them gets 1..4 negative fraction bits, narrowed so that some overflow; the
    model and the oracle agree bit for bit."""
    rng = np.random.default_rng(seed)
    base = P3.default_config()
    keep = {"p3_pix", "p3_u", "p3_keys", "p3_win", "p3_sgg", *base.HOST_REGISTERS}
    formats = {}
    for name, f in base.formats.items():
        if name in keep:
            formats[name] = f
            continue
        frac = -int(rng.integers(1, 5))
        word = max(2, f.word - (f.frac - frac) - int(rng.integers(0, 3)))
        formats[name] = FixedFormat(f.signed, word, frac, quant, f.overflow)
    config = base.with_(formats=formats)
    case = p3_case(seed, "random" if seed != 2 else "lab")
    ref = ORACLES["p3"].run(case, config)
    assert_bit_exact(P3.run(case, config, taps=True), ref)
    assert any(np.any(ref.taps[t] != 0) for t in ("warp0", "sge0", "du0"))


@pytest.mark.parametrize("overflow", [Overflow.SAT, Overflow.WRAP])
def test_casts_beyond_a_62_bit_shift_are_bit_exact(overflow):
    """The line work's and the box's casts run in the loop that forms their values
    where every shift is within 62 bits (``cast_by_plan``), else in a loop per cast
    (``cast_row``): ``p3_e``, ``p3_gy`` and the five box sums with their LSB 62 bits
    above zero take the second; model == oracle bit for bit, with taps and without."""
    base = P3.default_config(levels=2)
    formats = dict(base.formats)
    for name in ("p3_e", "p3_gy", "p3_bgg", "p3_bge", "p3_byy", "p3_bgy", "p3_bye"):
        formats[name] = FixedFormat(formats[name].signed, 8, -62, Quant.RND, overflow)
    config = base.with_(formats=formats)
    assert config.vertical_form == "box"
    frac = {name: f.frac for name, f in config.formats.items()}
    assert min(frac["p3_warp"], frac["p3_grad"], frac["p3_g"]) >= 1  # the shifts: > 62
    case = p3_case(5, "random")
    ref = ORACLES["p3"].run(case, config)
    assert_bit_exact(P3.run(case, config, taps=True), ref)
    fast = P3.run(case, config, taps=False, threads=1)
    assert np.array_equal(fast.range_raw, ref.range_raw)
    assert dict(fast.overflows) == ref.overflows and dict(fast.minmax) == ref.minmax


#: The signals the line work and the box cast in the loops that form them, and integer
#: bits (with the sign) too few for ``p3_case(6, "lab")``'s values.
FUSED_CAST_SIGNALS = {
    "p3_grad": 3, "p3_g": 2, "p3_e": 2, "p3_gy": 2, "p3_bgg": 6, "p3_bge": 5, "p3_byy": 6,
    "p3_bgy": 5, "p3_bye": 5, "p3_bdet": 12, "p3_bnv": 10,
}  # fmt: skip


@pytest.mark.parametrize(
    ("quant", "overflow"), [(Quant.RND, Overflow.SAT), (Quant.TRN_ZERO, Overflow.WRAP)]
)
def test_casts_in_the_loops_that_form_them_count_every_overflow(quant, overflow):
    """The line work's and the box's signals narrowed so that each overflows: the
    model's counts, min/max and outputs equal the oracle's with taps and without (the
    stages without taps cast bdet and bnv in a loop of their own), in plain modes and in
    the others."""
    base = P3.default_config(levels=2)
    formats = dict(base.formats)
    for name, bits in FUSED_CAST_SIGNALS.items():
        f = formats[name]
        formats[name] = FixedFormat(f.signed, f.frac + bits, f.frac, quant, overflow)
    config = base.with_(formats=formats)
    case = p3_case(6, "lab")
    ref = ORACLES["p3"].run(case, config)
    assert all(ref.overflows[name] > 0 for name in FUSED_CAST_SIGNALS), {
        k: ref.overflows[k] for k in FUSED_CAST_SIGNALS
    }
    assert_bit_exact(P3.run(case, config, taps=True), ref)
    fast = P3.run(case, config, taps=False, threads=1)
    assert np.array_equal(fast.range_raw, ref.range_raw)
    assert dict(fast.overflows) == ref.overflows and dict(fast.minmax) == ref.minmax


@pytest.mark.parametrize(
    "perturb", [{"gain": 0.9}, {"gain": 1.1}, {"offset": -10.0}, {"vshift": 1.0}]
)
def test_no_overflow_when_the_cameras_differ(perturb):
    """1/4, the right image as a real rig's (``rangefx eval --perturb``): the shipped
    formats still give 0 overflows with the vertical term off, in its window form and in
    its box form (the default; a gain of 0.9 drives |du| to 34.8 px)."""
    case = real_pair_case("motorcycle", 4)
    data = perturb_right(load_motorcycle(4), Perturbation(**perturb))
    image2 = np.clip(np.rint(data.image2), 0, 255).astype(np.int64)
    for design in ({"vertical": False}, {"vertical_radius": 0}, {}):
        config = P3.default_config(**design)
        result = P3.run(replace(case, image2=image2), config, taps=False)
        assert result.overflow_total == 0, {k: v for k, v in result.overflows.items() if v}


def test_p3_builds_the_normalisations_it_models():
    """``zncc`` (a square root and a divider per pixel) is G6's only: P3 says so; the
    normalised level is a tap of each stream in ``p3_norm``, absent without it."""
    with pytest.raises(ValueError, match="P3 builds normalise 'none' or 'local_mean'"):
        P3.default_config(normalise="zncc")
    names = {t.name: t for t in P3.tap_table(P3.default_config())}
    assert names["e1.norm"].signal == names["e2.norm"].signal == "p3_norm"
    assert "e1.norm" not in {t.name for t in P3.tap_table(P3.default_config(normalise="none"))}


# -- the vertical term (issue 38) -------------------------------------------------------
VERTICAL_SIGNALS = (
    "p3_gy", "p3_ryy", "p3_rgy", "p3_rye", "p3_syy", "p3_sgy", "p3_sye", "p3_det", "p3_nu",
    "p3_nv", "p3_res", "p3_du",
)  # fmt: skip


@pytest.mark.parametrize(
    ("seed", "kind", "design"),
    [
        (1, "random", {}),
        (2, "lab", {"radius": 2, "sigma": 1.0, "levels": 2, "divider": "restoring"}),
        (3, "random", {"warps": 3, "coarse_lag": 1, "normalise": "none", "levels": 2}),
        (4, "lab", {"radius": 1, "sigma": 0.8, "levels": 3, "keys_bits": 4, "warps": 1}),
    ],
)
def test_vertical_term_is_bit_exact_against_the_oracle(seed, kind, design):
    """The 2x2 normal equations (``vertical``): every tap, the outputs, every overflow
    count and min/max as the oracle's exact arithmetic gives them, with taps and without
    (the same outputs, counts and log)."""
    config = P3.default_config(vertical=True, vertical_radius=0, **design)
    case = p3_case(seed, kind)
    ref = ORACLES["p3"].run(case, config)
    result = P3.run(case, config, taps=True)
    assert_bit_exact(result, ref)
    assert {"ay", "gy0", "det0", "nu0", "nv"} <= set(result.taps)
    fast = P3.run(case, config, taps=False)
    assert np.array_equal(fast.range_raw, ref.range_raw)
    assert np.array_equal(fast.valid, ref.valid)
    assert dict(fast.overflows) == ref.overflows and dict(fast.minmax) == ref.minmax


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**16),
    quant=st.sampled_from([Quant.RND, Quant.TRN]),
    overflow=st.sampled_from([Overflow.SAT, Overflow.WRAP]),
    drop=st.lists(st.tuples(st.integers(0, 12), st.integers(-2, 3)), min_size=12, max_size=12),
)
def test_vertical_term_is_bit_exact_over_formats(seed, quant, overflow, drop):
    """Property: the vertical signals in any modes, narrowed by 0..12 integer bits and
    -2..3 fraction bits (so that some overflow, wrap or saturate), model == oracle bit for
    bit."""
    base = P3.default_config(vertical=True, vertical_radius=0, radius=2, sigma=1.0, levels=2)
    _assert_narrowed_bit_exact(base, VERTICAL_SIGNALS, drop, quant, overflow, seed)


def _assert_narrowed_bit_exact(base, signals, drop, quant, overflow, seed):
    """``signals`` of ``base`` narrowed by ``drop``'s (integer, fraction) bits in
    ``quant``/``overflow`` (the quotients saturate), model == oracle on a seeded case,
    with taps and without."""
    formats = dict(base.formats)
    for name, (d_int, d_frac) in zip(signals, drop, strict=True):
        f = formats[name]
        ovf = Overflow.SAT if name in base.QUOTIENTS else overflow
        word = max(2, f.word - d_int - d_frac)
        formats[name] = FixedFormat(f.signed, word, f.frac - d_frac, quant, ovf)
    config = base.with_(formats=formats)
    case = p3_case(seed % 7, "random" if seed % 2 else "lab")
    ref = ORACLES["p3"].run(case, config)
    assert_bit_exact(P3.run(case, config, taps=True), ref)
    fast = P3.run(case, config, taps=False)  # the stages without taps: their own loops
    assert np.array_equal(fast.range_raw, ref.range_raw)
    assert dict(fast.overflows) == ref.overflows and dict(fast.minmax) == ref.minmax


def test_vertical_term_schedule_and_cost():
    """Each warp stage takes one more line (the column differences need line y + 1), the
    output leaves the schedule's latency after its input, and the vertical term's line
    buffers, registers and multipliers are counted."""
    off, on = P3.default_config(vertical=False), P3.default_config(vertical_radius=0)
    m, n = 512, 512
    s_off = streaming_schedule(off.multiscale(), n, m)
    s_on = streaming_schedule(on.multiscale(), n, m)
    warps = on.warps
    assert s_on["levels"][-1]["latency_lines"] == s_off["levels"][-1]["latency_lines"] + warps
    assert buffer_bits(off, (m, n))["vertical"] == 0 < buffer_bits(on, (m, n))["vertical"]
    c_off, c_on = P3.cost(off, (m, n)), P3.cost(on, (m, n))
    assert c_on.dsp > c_off.dsp and c_on.register_bits > c_off.register_bits
    assert c_on.line_buffer_bits == sum(buffer_bits(on, (m, n)).values())
    result = P3.run(scene_case("lab"), on, taps=False)
    assert result.schedule["latency_lines"] == s_on["latency_lines"]
    lines = (result.out_cycles - result.in_cycles) // n
    assert lines.min() == s_on["latency_lines"]


def test_vertical_term_meets_the_misalignment_target():
    """1/8, the right image 1 px lower (``rangefx eval --perturb vshift=1``): with the
    vertical term P3 keeps density >= 0.75 and MAE <= 0.6 px; without it, it does not."""
    data = load_motorcycle(8)
    shifted = perturb_right(data, Perturbation(vshift=1.0))
    figures = {}
    case = replace(
        real_pair_case("motorcycle", 8),
        image2=np.clip(np.rint(shifted.image2), 0, 255).astype(np.int64),
    )
    for vertical in (False, True):
        config = P3.default_config(vertical=vertical, vertical_radius=0, threshold_g=1.0)
        result = P3.run(case, config, taps=False)
        assert result.overflow_total == 0
        disparity = disparity_from_range(result.range * 1e3, shifted)  # m -> the pair's mm
        figures[vertical] = middlebury_metrics(
            disparity, result.valid, shifted.disparity, shifted.metric_depth,
            shifted.doffs_px, shifted.camera.f_px, abs(shifted.motion.camera_displacement[1]),
        )  # fmt: skip
    assert figures[True]["density"] >= 0.75 and figures[True]["mae_px"] <= 0.6, figures
    assert figures[False]["mae_px"] > 0.6, figures


@pytest.mark.parametrize(
    "design",
    [
        {},
        {"vertical": False},
        {"vertical": True, "vertical_radius": 0, "radius": 2, "sigma": 1.0},
        {"divider": "restoring", "warps": 3},
        {"vertical": True, "vertical_radius": 3, "radius": 2, "sigma": 1.0},
        {"vertical": False, "radius": 6, "sigma": 2.5},
    ],
)
def test_two_bands_of_lines_give_the_one_thread_result(design):
    """On two threads each level of ``BAND_PIXELS`` or more runs its line work in two
    bands of lines, each with its own log: every tap, the outputs, every overflow count
    and min/max equal the one-thread run's (the oracle checks that one,
    tests/test_bitexact.py), also where narrowed signals overflow."""
    rng = np.random.default_rng(7)
    im1, im2, camera = lab_crop(rng, 64, 96)
    assert 64 * 96 >= p3_model.BAND_PIXELS  # level 0 is split
    case = Case(im1, im2, camera, MotionIncrement.stereo(0.1),
                settings={"ranging": RangingConfig(range_max=100.0)})  # fmt: skip
    config = P3.default_config(**design)
    narrowed = {k: replace(config.formats[k], word=config.formats[k].word - 6)
                for k in ("p3_g", "p3_rge", "p3_du")}  # fmt: skip
    overflowing = config.with_(formats={**config.formats, **narrowed})
    for cfg in (config, overflowing):
        one = P3.run(case, cfg, taps=True, threads=1)
        assert_same = (one.range_raw, one.valid, dict(one.overflows), dict(one.minmax))
        for taps in (True, False):
            two = P3.run(case, cfg, taps=taps, threads=2)
            assert np.array_equal(two.range_raw, assert_same[0])
            assert np.array_equal(two.valid, assert_same[1])
            assert (dict(two.overflows), dict(two.minmax)) == assert_same[2:]
            for name, tap in two.taps.items():
                assert np.array_equal(tap, one.taps[name]), name
    assert one.overflows["p3_g"] > 0 and one.overflows["p3_du"] > 0


def _assert_two_threads_give_one_thread_on_lab(config, runs):
    """The 512 x 512 lab frame without taps on two threads, ``runs`` times: the ranges
    (raw and float), validity, cycles, counts and min/max of the one-thread run."""
    case = scene_case("lab")
    one = P3.run(case, config, taps=False, threads=1)
    for _ in range(runs):
        two = P3.run(case, config, taps=False, threads=2)
        assert np.array_equal(two.range_raw, one.range_raw)
        assert np.array_equal(two.valid, one.valid)
        assert (dict(two.overflows), dict(two.minmax)) == (dict(one.overflows), dict(one.minmax))
        assert np.array_equal(two.range, one.range)
        assert np.array_equal(two.in_cycles, one.in_cycles)
        assert np.array_equal(two.out_cycles, one.out_cycles)


def test_two_bands_of_the_fused_stage_have_their_own_rings(monkeypatch):
    """Without the vertical term (``vertical = false``) and taps a warp stage is one pass
    down the lines with the row sums in a ring of lines (``_stage_fused``); on two
    threads the two bands run at once, so each must fill a ring of its own: with one
    ring shared, each band overwrote the other's lines and the 512 x 512 lab frame's
    ranges differed from the one-thread run's and from run to run (issue 38). Which
    lines get overwritten depends on how the threads interleave, so the rings are
    checked directly (no band pair may share memory) besides the frame's outputs, run
    several times."""
    real, calls = p3_model._stage_fused, []

    def spy(*args):
        calls.append(args[-6:])  # rgg, rge, ree, sums, y0, y1
        real(*args)

    monkeypatch.setattr(p3_model, "_stage_fused", spy)
    config = P3.default_config(vertical=False)
    _assert_two_threads_give_one_thread_on_lab(config, runs=4)
    firsts = [c for c in calls if c[4] == 0]
    pairs = [(a, b) for b in calls if b[4] > 0 for a in firsts if a[5] == b[4]]
    assert len(pairs) >= 4 * config.warps
    for a, b in pairs:
        for ring_a, ring_b in zip(a[:3], b[:3], strict=True):
            assert not np.shares_memory(ring_a, ring_b)


def test_two_bands_of_the_box_form_have_their_own_rings(monkeypatch):
    """The box form (the default) runs a stage without taps as one pass down a band's
    lines (``_stage_box_fused``: the line work, the box's row sums in a ring, the
    correction's row sums in two rings), each band into planes of its own (W, ``g``,
    ``e``, ``gy``, ``rgg``, ``v``; ``Wy`` in a line buffer: it computes the other band's
    lines its column work reaches into them); on two threads the bands run at once, so no
    ring and no such plane may be shared between them (as
    ``test_two_bands_of_the_fused_stage_have_their_own_rings``), and the 512 x 512 lab
    frame's outputs equal the one-thread run's."""
    made = []
    # the band's own planes and rings among the arguments (counted from the end: w, g,
    # e, gy, rgg, the box's ring, v, rge, ree; not ay, shared), then y0, y1
    own = (-13, -12, -11, -9, -8, -7, -6, -5, -4)
    real = p3_model._stage_box_fused

    def spy(*args):
        made.append(tuple(args[k] for k in own) + args[-2:])
        real(*args)

    monkeypatch.setattr(p3_model, "_stage_box_fused", spy)
    config = P3.default_config()
    assert config.vertical_form == "box"
    _assert_two_threads_give_one_thread_on_lab(config, runs=2)
    firsts = [c for c in made if c[-2] == 0]
    pairs = [(a, b) for b in made if b[-2] > 0 for a in firsts if a[-1] == b[-2]]
    assert len(pairs) >= 2 * config.warps
    for a, b in pairs:
        for buf_a, buf_b in zip(a[:-2], b[:-2], strict=True):
            assert not np.shares_memory(buf_a, buf_b)


@pytest.mark.parametrize("design", [{}, {"vertical_radius": 0}])
def test_two_threads_give_one_thread_on_the_lab_frame_with_the_vertical_term(design):
    """The box form (the default) and the window form run in two bands of lines on two
    threads: the 512 x 512 lab frame's ranges, validity, cycles, counts and min/max equal
    the one-thread run's, three runs each."""
    config = P3.default_config(**design)
    assert config.vertical_form == ("box" if not design else "window")
    _assert_two_threads_give_one_thread_on_lab(config, runs=3)


@pytest.mark.parametrize("vertical", [False, True])
def test_windows_wider_than_the_unrolled_radius_are_bit_exact(vertical):
    """Up to ``UNROLLED_RADIUS`` the window's passes run one unrolled sum per pixel; a
    wider window takes the tap-at-a-time loops: every tap, count and min/max as the
    oracle's, and without taps (the fused stage's ring of row sums, two bands) the
    outputs, counts and min/max."""
    radius = p3_model.UNROLLED_RADIUS + 2
    config = P3.default_config(radius=radius, sigma=2.5, levels=2, vertical=vertical,
                               vertical_radius=0)  # fmt: skip
    for seed, kind in ((3, "lab"), (4, "random")):
        case = p3_case(seed, kind)
        ref = ORACLES["p3"].run(case, config)
        assert_bit_exact(P3.run(case, config, taps=True), ref)
        res = P3.run(case, config, taps=False, threads=2)
        assert np.array_equal(res.range_raw, ref.range_raw)
        assert np.array_equal(res.valid, ref.valid)
        assert (dict(res.overflows), dict(res.minmax)) == (ref.overflows, ref.minmax)


# -- the box form of the vertical term (issue 38) ------------------------------------------
BOX_SIGNALS = (
    "p3_gy", "p3_bgg", "p3_bge", "p3_byy", "p3_bgy", "p3_bye", "p3_bdet", "p3_bnv", "p3_v",
    "p3_ev", "p3_rge", "p3_ree",
)  # fmt: skip


@pytest.mark.parametrize(
    ("seed", "kind", "design"),
    [
        (1, "random", {"vertical_radius": 2}),
        (2, "lab", {"vertical_radius": 3, "radius": 2, "sigma": 1.0, "divider": "restoring"}),
        (3, "random", {"vertical_radius": 1, "warps": 3, "coarse_lag": 1, "normalise": "none"}),
        (4, "lab", {"vertical_radius": 8, "radius": 1, "sigma": 0.8, "levels": 3, "warps": 1}),
    ],
)
def test_box_form_is_bit_exact_against_the_oracle(seed, kind, design):
    """The box form (``vertical_radius`` > 0: ``v`` from the box's 2x2 system, ``rv`` lines
    late, the 1-D fit on ``e + gy v``): every tap, the outputs, every overflow count and
    min/max as the oracle's exact arithmetic gives them, with taps and without, on one
    thread and on two."""
    config = P3.default_config(vertical=True, **{"levels": 2, **design})
    case = p3_case(seed, kind)
    ref = ORACLES["p3"].run(case, config)
    result = P3.run(case, config, taps=True, threads=1)
    assert_bit_exact(result, ref)
    assert {"ay", "gy0", "bgg0", "bdet0", "bnv0", "v0", "ev0"} <= set(result.taps)
    assert "nv" not in result.taps and "det0" not in result.taps
    for threads in (1, 2):
        fast = P3.run(case, config, taps=False, threads=threads)
        assert np.array_equal(fast.range_raw, ref.range_raw)
        assert np.array_equal(fast.valid, ref.valid)
        assert dict(fast.overflows) == ref.overflows and dict(fast.minmax) == ref.minmax


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**16),
    quant=st.sampled_from([Quant.RND, Quant.TRN]),
    overflow=st.sampled_from([Overflow.SAT, Overflow.WRAP]),
    drop=st.lists(st.tuples(st.integers(0, 12), st.integers(-2, 3)), min_size=12, max_size=12),
    rv=st.integers(1, 4),
)
def test_box_form_is_bit_exact_over_formats(seed, quant, overflow, drop, rv):
    """Property: the box form's signals in any modes, narrowed by 0..12 integer bits and
    -2..3 fraction bits (so that some overflow, wrap or saturate), model == oracle bit for
    bit."""
    base = P3.default_config(vertical=True, vertical_radius=rv, radius=2, sigma=1.0, levels=2)
    _assert_narrowed_bit_exact(base, BOX_SIGNALS, drop, quant, overflow, seed)


def test_box_form_schedule_and_cost():
    """The box form keeps the window form's lines a stage (``v`` of the line ``rv`` up is
    ready with line ``y``'s ``gy``), the output leaves the schedule's latency after its
    input, and its five exact box row sums of ``2 rv`` lines, registers and multipliers
    are counted."""
    window = P3.default_config(vertical=True, vertical_radius=0)
    box = window.with_(vertical_radius=8)
    m, n = 512, 512
    s_window = streaming_schedule(window.multiscale(), n, m)
    s_box = streaming_schedule(box.multiscale(), n, m)
    assert s_box["latency_lines"] == s_window["latency_lines"]
    bits = buffer_bits(box, (m, n))["vertical"]
    assert bits > buffer_bits(window, (m, n))["vertical"]
    c_box = P3.cost(box, (m, n))
    assert c_box.line_buffer_bits == sum(buffer_bits(box, (m, n)).values())
    assert c_box.dsp > P3.cost(P3.default_config(vertical=False), (m, n)).dsp
    names = {mul.name for mul in p3_model_cost.multipliers(box, (m, n))}
    assert {"bdet: bgg * byy", "ev: gy * v"} <= names and "det: sgg * syy" not in names
    result = P3.run(scene_case("lab"), box, taps=False)
    assert result.schedule["latency_lines"] == s_box["latency_lines"]
    lines = (result.out_cycles - result.in_cycles) // n
    assert lines.min() == s_box["latency_lines"]


@pytest.mark.parametrize("vshift", [1.0, -1.0])
def test_box_form_meets_the_misalignment_target(vshift):
    """1/8, the right image 1 px lower or higher (``rangefx eval --perturb vshift=±1``):
    the box form (``rv`` 8, ``threshold_r`` 25, ``threshold_g`` 0.5) keeps density >= 0.75
    and MAE <= 0.6 px in P3, with 0 overflows."""
    data = load_motorcycle(8)
    shifted = perturb_right(data, Perturbation(vshift=vshift))
    case = replace(
        real_pair_case("motorcycle", 8),
        image2=np.clip(np.rint(shifted.image2), 0, 255).astype(np.int64),
    )
    config = P3.default_config(vertical=True, vertical_radius=8, threshold_r=25.0,
                               threshold_g=0.5)  # fmt: skip
    result = P3.run(case, config, taps=False)
    assert result.overflow_total == 0
    disparity = disparity_from_range(result.range * 1e3, shifted)  # m -> the pair's mm
    m = middlebury_metrics(
        disparity, result.valid, shifted.disparity, shifted.metric_depth,
        shifted.doffs_px, shifted.camera.f_px, abs(shifted.motion.camera_displacement[1]),
    )  # fmt: skip
    assert m["density"] >= 0.75 and m["mae_px"] <= 0.6, m
