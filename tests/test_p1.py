"""P1 pipeline: word-length config, stream timing, cycle faithfulness, instrumentation,
the default config's budgets on the preset scenes, and the CLI."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from numba import njit

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.scenes import render_plane
from rangefx.rtl_model.config import TimingConfig, integer_bits_needed, propose_config
from rangefx.rtl_model.fixedpoint import (
    ANY_MODES,
    PLAIN_MODES,
    FixedFormat,
    Overflow,
    Quant,
    cast_array,
    plain_modes,
)
from rangefx.rtl_model.kernels import (
    divide_lanes_fit,
    divide_row,
    divide_row_lanes,
    floor_log2_lanes,
)
from rangefx.rtl_model.p1 import RANGE_TAPS, stage_latencies
from rangefx.rtl_model.p1.config import P1_SIGNALS, P1Config
from rangefx.rtl_model.p1.model import LINE_BUFFER_READ_AHEAD, RANGE, untranspose_band
from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import PIPELINES
from rangefx.rtl_model.runtime import DIV_RECIPROCAL, divider_setup, format_table
from rangefx.rtl_model.stream import make_stream, pixel_cycles
from rangefx.tools.cli import main
from rangefx.tools.studies import bench
from rangefx.tools.studies import cases as study_cases
from rangefx.tools.studies.runner import compare_ranges, run_case

# -- config ---------------------------------------------------------------------------


def test_default_config_names_every_signal_and_round_trips_through_toml(tmp_path):
    config = P1Config.default()
    assert set(config.formats) == set(P1_SIGNALS)
    path = tmp_path / "c.toml"
    config.save(path)
    again = P1Config.load(path)
    assert again == config
    assert again.name == "c"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace('gv = { format = "s28.4"', 'gv = { format = "s40.4"'), "'num'"),
        (lambda t: t.replace('"SAT" }  # range x_c', '"WRAP" }  # range x_c'), "'range'"),
        (lambda t: t.replace('s28.4", quant = "RND"', 's28.4", quant = "RNDX"', 1), "RNDX"),
        (lambda t: t.replace("[signals]\n", "[signals]\nbogus = 's8.0'\n"), "bogus"),
        (lambda t: "\n".join(x for x in t.splitlines() if not x.startswith("c1 =")), "c1"),
        (lambda t: t.replace('divider = "reciprocal"', 'divider = "srt"'), "srt"),
        (lambda t: t + "[extra]\n", "extra"),
        (lambda t: t.replace("[design]", "[design\n"), "TOML"),
    ],
)
def test_bad_configs_are_rejected_naming_the_culprit(edit, message):
    text = edit(P1Config.default().to_toml())
    with pytest.raises(ValueError, match=message):
        P1Config.from_toml(text)


def test_int64_limit_names_the_signal():
    config = P1Config.default()
    wide = FixedFormat(True, 60, 40, Quant.RND, Overflow.SAT)
    with pytest.raises(ValueError, match=r"signal 'geom_v'.*int64"):
        config.with_formats(k_t_reg=wide)


@pytest.mark.parametrize(
    ("lo", "hi", "signed", "bits"),
    [(0, 255, False, 8), (0, 256, False, 9), (-128, 127, True, 8), (-129, 0, True, 9),
     (0, 0.4, False, -1), (-0.5, 0.25, True, 0), (0, 1.0, True, 2), (0, 0, False, 1),
     (-0.75, 0, True, 1)],
)  # fmt: skip
def test_integer_bits_needed(lo, hi, signed, bits):
    assert integer_bits_needed(lo, hi, signed) == bits


# -- stream and timing ----------------------------------------------------------------


@pytest.mark.parametrize("timing", [TimingConfig(), TimingConfig(hblank=7, vblank=11)])
def test_stream_matches_the_closed_form(timing):
    frames = np.arange(2 * 5 * 6).reshape(2, 5, 6)
    s = make_stream(frames, timing)
    assert np.array_equal(s.pixel_cycles(), pixel_cycles((5, 6), timing, frames=2))
    assert np.array_equal(s.frames_data(), frames)
    assert np.flatnonzero(s.sof).tolist() == s.pixel_cycles()[:, 0, 0].tolist()
    assert np.count_nonzero(s.eol) == 2 * 5 and np.all(s.valid[s.eol])


def test_gaps_delay_pixels_but_keep_their_order():
    frames = np.arange(30).reshape(5, 6)
    s = make_stream(frames, TimingConfig(gap_prob=0.5, seed=3))
    assert s.cycles > 30
    assert np.array_equal(s.frames_data()[0], frames)
    assert np.all(np.diff(s.pixel_cycles().ravel()) >= 1)


@pytest.mark.parametrize("bad", [dict(hblank=-1), dict(gap_prob=1.0), dict(seed=1.5)])
def test_bad_timing_is_rejected(bad):
    with pytest.raises(ValueError, match="timing"):
        TimingConfig(**bad)


# -- the pipeline on a small plane ----------------------------------------------------


@pytest.fixture(scope="module")
def plane():
    return render_plane(depth=30.0, size=(24, 32), f_px=60.0, baseline=0.1, seed=2)


def _run_pair(image1, image2, camera, motion, mode="stereo", timing=None, **kw):
    """P1 through its pipeline's public ``run`` on a case of the pair."""
    ranging = RangingConfig(threshold_e=1.0, threshold_g=1.0, range_max=100.0)
    case = Case(image1, image2, camera, motion, mode, settings={"ranging": ranging})
    return PIPELINES["p1"].run(case, kw.pop("config", P1Config.default()), timing, **kw)


def _run(plane, **kw):
    return _run_pair(plane.image1, plane.image2, plane.camera, plane.motion, **kw)


@pytest.mark.parametrize(
    "timing",
    [TimingConfig(), TimingConfig(hblank=4, vblank=9), TimingConfig(hblank=2, gap_prob=0.3)],
)
@pytest.mark.parametrize("mode", ["stereo", "motion"])
@pytest.mark.parametrize(("threads", "taps"), [(1, True), (2, False)])
def test_cycle_stamps_are_input_cycle_plus_declared_latency(plane, timing, mode, threads, taps):
    """Cycle stamps against the beats of the stream itself (the range bands fill them, and
    the float range map, in the closed form without gaps)."""
    res = _run(plane, timing=timing, mode=mode, threads=threads, taps=taps)
    lat = sum(stage_latencies(res.config).values())
    assert res.latency == lat
    frames = 2 if mode == "motion" else 1
    expected_in = make_stream(np.zeros((frames, 24, 32), int), timing).pixel_cycles()[-1]
    if timing.gap_prob == 0:
        assert np.array_equal(pixel_cycles(plane.image1.shape, timing, frames)[-1], expected_in)
    assert np.array_equal(res.in_cycles, expected_in)
    assert np.array_equal(res.out_cycles, expected_in + lat)
    assert res.total_cycles == int(expected_in[-1, -1]) + lat + 1
    assert np.array_equal(res.range, res.config.formats["range"].to_float(res.range_raw))


def test_gaps_and_blanking_change_no_value(plane):
    a = _run(plane)
    b = _run(plane, timing=TimingConfig(hblank=5, vblank=3, gap_prob=0.4, seed=9))
    assert a.taps.keys() == b.taps.keys()
    for k in a.taps:
        assert np.array_equal(a.taps[k], b.taps[k]), k
    assert not np.array_equal(a.out_cycles, b.out_cycles)


@pytest.mark.parametrize("variant", ["paper", "consistent"])
def test_memory_report(plane, variant):
    config = P1Config.default(variant=variant)
    n = plane.image1.shape[1]
    lb = n * config.formats["col_state"].word
    if variant == "consistent":
        lb += n * config.formats["col2_state"].word
    assert _run(plane, config=config).line_buffer_bits == 2 * lb
    motion = _run(plane, config=config, mode="motion")
    assert motion.line_buffer_bits == lb
    ex = config.formats["col2_out" if variant == "consistent" else "div_quot"].word
    per_pixel = config.formats["col_s1"].word + ex + config.formats["col_s2"].word
    assert motion.frame_store_bits == 24 * 32 * per_pixel


@pytest.mark.parametrize("hblank", [0, 1, 2])
def test_line_buffer_hazard_is_rejected(hblank):
    """A 2-pixel line: the column filter's next read of a column (issued
    LINE_BUFFER_READ_AHEAD cycles early, hdl/p1_colfilt.v) must follow its write-back,
    ``column_filter - 1`` cycles after the pixel: the shortest line period accepted is one
    more than that sum."""
    img = np.zeros((4, 2), dtype=np.uint8)
    cam = PinholeCamera(2, 4, 10.0)
    shortest = stage_latencies(P1Config.default())["column_filter"] + LINE_BUFFER_READ_AHEAD
    timing = TimingConfig(hblank=hblank)
    if 2 + hblank < shortest:
        with pytest.raises(ValueError, match="line-buffer hazard"):
            _run_pair(img, img, cam, MotionIncrement.stereo(0.1), timing=timing)
    else:
        assert _run_pair(img, img, cam, MotionIncrement.stereo(0.1), timing=timing).range.shape


@pytest.mark.parametrize(
    ("images", "message"),
    [
        ((np.zeros((24, 32)), np.zeros((24, 32), np.uint8)), "integer"),
        ((np.zeros((24, 32), np.uint8), np.zeros((24, 31), np.uint8)), "shapes differ"),
        ((np.zeros((8, 8), np.uint8), np.zeros((8, 8), np.uint8)), "camera"),
    ],
)
def test_bad_images_are_rejected(plane, images, message):
    with pytest.raises(ValueError, match=message):
        _run_pair(*images, plane.camera, plane.motion)


def test_taps_are_optional_and_outputs_identical(plane):
    a = _run(plane)
    b = _run(plane, taps=False)
    assert b.taps == {}
    assert np.array_equal(a.range_raw, b.range_raw) and np.array_equal(a.valid, b.valid)
    assert a.overflows == b.overflows and a.minmax == b.minmax
    assert np.array_equal(a.taps["range"], a.range_raw)
    assert set(RANGE_TAPS) <= set(a.taps)


def test_narrow_formats_overflow_and_propose_repairs_them(plane):
    config = P1Config.default()
    narrow = config.with_formats(
        row_r2=replace(config.formats["row_r2"], word=14),  # 4 integer bits for +-64
        c1=replace(config.formats["c1"], word=13),  # +-2
    )
    res = _run(plane, config=narrow)
    assert res.overflows["row_r2"] > 0 and res.overflows["c1"] > 0
    proposed = propose_config(narrow, res.minmax, guard_bits=1)
    for name, (lo, hi) in res.minmax.items():
        fmt = proposed.formats[name]
        assert fmt.frac == narrow.formats[name].frac
        assert fmt.raw_min * fmt.lsb <= lo and hi <= fmt.raw_max * fmt.lsb, name
    # a clipped signal hid its consumers' true ranges: like MATLAB's propose, iterate
    for _ in range(3):
        again = _run(plane, config=proposed)
        if again.overflow_total == 0:
            break
        proposed = propose_config(proposed, again.minmax, guard_bits=1)
    assert again.overflow_total == 0


# -- the default config's budgets on the preset scenes (issue: must show) -------------


@pytest.fixture(scope="module", params=["lab", "runway"])
def scene_case(request):
    return study_cases.scene_case(request.param)


@pytest.mark.parametrize("variant", ["paper", "consistent"])
def test_default_config_meets_the_budget_against_golden(scene_case, variant):
    config = P1Config.default(variant=variant)
    res = run_case(PIPELINES["p1"], scene_case, config)
    golden = PIPELINES["p1"].golden(scene_case, config).result
    figures = compare_ranges(res, golden)
    assert res.overflow_total == 0, {k: v for k, v in res.overflows.items() if v}
    assert figures["median_rel_range_diff"] <= 0.005
    assert figures["valid_agreement"] >= 0.99
    assert figures["n_valid_both"] > 1000


# -- CLI --------------------------------------------------------------------------------


def test_cli_run_p1_json(capsys, tmp_path):
    out = tmp_path / "p1"
    assert main(["run", "--scene", "lab", "--pipeline", "p1", "--json", "--out", str(out)]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures["overflows"]["total"] == 0
    assert set(figures["overflows"]) == {"total", *P1_SIGNALS}
    assert figures["median_rel_range_diff"] <= 0.005
    assert figures["valid_agreement"] >= 0.99
    assert {"range.npy", "valid.npy", "taps.npz", "range.png", "config.toml", "summary.json"} <= {
        p.name for p in out.iterdir()
    }
    taps = np.load(out / "taps.npz")
    assert "e1.row_r1" in taps and "range" in taps


def test_cli_config_show_and_bad_config(capsys, tmp_path):
    assert main(["config", "show"]) == 0
    text = capsys.readouterr().out
    assert P1Config.from_toml(text) == P1Config.default()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('c1 = { format = "s21.11"', 'c1 = { format = "s99.11"'))
    assert main(["run", "--pipeline", "p1", "--config", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'c1'" in err[0]


@pytest.mark.parametrize("variant", ["paper", "consistent"])
def test_one_or_two_threads_give_the_same_run(plane, variant):
    # two threads split the range stage into row bands: every value, overflow count (the
    # column-only signals xp/vx are cast once per band and counted per row) and min/max
    # must equal the single-band run
    config = P1Config.default(variant=variant).with_formats(
        coord=FixedFormat.from_string("s4.0", Quant.TRN, Overflow.SAT)
    )
    a = _run(plane, config=config, threads=1)
    b = _run(plane, config=config, threads=2)
    assert a.overflows["coord"] > 0  # the narrowed counters overflow on both axes
    assert np.array_equal(a.range_raw, b.range_raw) and np.array_equal(a.valid, b.valid)
    assert a.overflows == b.overflows and a.minmax == b.minmax
    assert all(k in a.kernel_cpu_s and a.kernel_cpu_s[k] > 0 for k in ("front_end", "range"))


def test_bench_calibration_loops_compute_what_they_claim():
    """The floors set beside ``cast_ns`` are real work: the constant-format loop is the
    s16.4 RND/SAT cast (values and overflow count), the log loop the row's min/max."""
    raw = np.array([-(2**23) - 200, -129, -128, -127, 0, 127, 128, 129, 383, 2**23 + 9])
    out = np.empty_like(raw)
    lo, hi, count = bench.constant_cast_loop(raw, out, 1)
    expected, overflows = cast_array(raw, 12, FixedFormat.from_string("s16.4", Quant.RND,
                                                                      Overflow.SAT))  # fmt: skip
    assert out.tolist() == expected.tolist() and count == overflows == 2
    assert (lo, hi) == (raw.min(), raw.max())
    assert bench.minmax_loop(raw, out, 1)[:2] == (raw.min(), raw.max())


@pytest.mark.parametrize("n", [1, 8, 13, 24])
def test_untranspose_band_is_the_transpose_of_the_band(n):
    """The tiled copy back to scan order, with and without a partial tile, for a short
    band (lanes beyond ``bw`` left untouched)."""
    src_t = np.arange(n * 16, dtype=np.int64).reshape(n, 16)
    dst = np.full((16, n), -1, dtype=np.int64)
    untranspose_band(src_t, dst, 5, n)
    assert dst[:5].tolist() == src_t[:, :5].T.tolist() and (dst[5:] == -1).all()


@pytest.mark.parametrize("plain", [False, True])
def test_bench_datapath_unit_loops_compute_what_they_claim(plain):
    """``plan_cast_loop`` sums six real casts (each against ``cast_array`` of its format,
    overflows counted; the plain body with plain modes only) and ``divide_row_loop`` is
    P1's lane divider."""
    raw = np.random.default_rng(5).integers(-(2**26), 2**26, 64)
    raw[:3] = [2**40, -(2**40), 0]  # out of every format: saturated or wrapped
    out = np.empty_like(raw)
    _, _, count = bench.plan_cast_loop(raw, out, 1, PLAIN_MODES if plain else ANY_MODES)
    q2, o3 = (Quant.RND, Overflow.SAT) if plain else (Quant.RND_CONV, Overflow.WRAP)
    plans = [(2, 12, Quant.RND, Overflow.SAT), (4, 16, Quant.RND, Overflow.SAT),
             (6, 20, q2, Overflow.SAT), (8, 24, Quant.TRN, o3),
             (10, 16, Quant.RND, Overflow.SAT), (12, 12, Quant.RND, Overflow.SAT)]  # fmt: skip
    want, overflows = np.zeros_like(raw), 0
    for shift, word, quant, overflow in plans:
        values, n = cast_array(raw, shift, FixedFormat(True, word, 0, quant, overflow))
        want, overflows = want + values, overflows + n
    assert bench.PLAN_CASTS == len(plans)
    assert out.tolist() == want.tolist() and count == overflows > 0

    config = P1Config.default()
    fm, (_, lut) = format_table(config), divider_setup(config)
    num, den = raw // 4, np.arange(-32, 32) * 37
    q = P1_SIGNALS.index("div_quot")
    dst, ov = np.zeros((fm.shape[0], 2)), np.zeros(fm.shape[0], dtype=np.int64)
    dst2, ov2 = dst.copy(), ov.copy()
    out2, flags, flags2 = np.empty_like(raw), np.empty(64, np.bool_), np.empty(64, np.bool_)
    modes = PLAIN_MODES if plain else ANY_MODES
    bench.divide_row_loop(num, 20, den, 11, q, lut, config.recip_bits, fm, dst, ov, out, flags, 3,
                          modes)  # fmt: skip
    divide_row_lanes(num, 20, den, 11, q, lut, config.recip_bits, fm, dst2, ov2, out2, flags2,
                     False, modes)  # fmt: skip
    assert out.tolist() == out2.tolist() and flags.tolist() == flags2.tolist()
    assert ov[q] == 3 * ov2[q] and flags[den == 0].all()


@pytest.mark.parametrize("pole_raw", [128, 450])
def test_calibration_kernel_is_the_bit_exact_row_column_filter(pole_raw):
    """``calib_rowcol``: the first-order row then column filter in s18.8, RND + SAT after
    each step, against exact rationals (pole 450/256 > 1 makes the states saturate)."""
    from fractions import Fraction

    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (5, 9))
    out = np.empty_like(image)
    sat = bench.calib_rowcol(image, pole_raw, out)
    c, lsb, top = Fraction(pole_raw, 256), Fraction(1, 256), Fraction(2**17 - 1, 256)

    def cast(x: Fraction) -> tuple[Fraction, int]:
        q = Fraction(math.floor(x / lsb + Fraction(1, 2))) * lsb  # round half up
        return min(max(q, -top - lsb), top), int(q > top or q < -top - lsb)

    want, count = np.empty((5, 9), dtype=object), 0
    line = [Fraction(0)] * 9
    for j in range(5):
        p = Fraction(int(image[j, 0]))
        for i in range(9):
            p, k1 = cast(p + c * (int(image[j, i]) - p))
            q = p if j == 0 else line[i]
            q, k2 = cast(q + c * (p - q))
            line[i], want[j, i], count = q, q, count + k1 + k2
    assert [[Fraction(int(v), 256) for v in row] for row in out] == want.tolist()
    assert sat == count and (count > 0) == (pole_raw > 256)


def test_bench_reports_the_cost_breakdown():
    figures = bench.bench_figures(repeats=1, size=32)
    for key in ("p1_stereo_mpix_s", "golden_p1_mpix_s", "cold_process_s", "cast_ns",
                "cast_overflowing_row_ns", "log_floor_ns", "constant_cast_floor_ns",
                "p1_paper_front_end_cpu_ns_px", "p1_consistent_range_cpu_ns_px",
                "p2_stereo_mpix_s", "p2_stereo_taps_mpix_s", "golden_p2_mpix_s",
                "calib_rowcol_mpix_s", "p1_over_calib", "p2_over_calib",
                "p1_stereo_consistent_1thread_over_calib",
                "p1_stereo_paper_logged_mpix_s", "p2_stereo_logged_1thread_over_calib",
                "p2_stereo_taps_over_calib", "calib_rowcol_2threads_mpix_s",
                "calib_two_thread_scaling", "p1_stereo_paper_two_thread_scaling",
                "p2_stereo_two_thread_scaling", "calib_simd_gelem_s",
                "calib_simd_2threads_gelem_s", "calib_simd_two_thread_scaling",
                "cast_by_plan_ns", "divide_row_lanes_ns", "p1_stereo_over_calib"):  # fmt: skip
        assert figures[key] > 0, key
    # the scaling figures are the ratios of the figures they name
    assert figures["p2_stereo_two_thread_scaling"] == pytest.approx(
        figures["p2_stereo_mpix_s"] / figures["p2_stereo_1thread_mpix_s"]
    )
    assert "p1_stereo_paper_logged_two_thread_scaling" in figures
    assert figures["calib_simd_two_thread_scaling"] == pytest.approx(
        figures["calib_simd_2threads_gelem_s"] / figures["calib_simd_gelem_s"]
    )


def test_bench_times_the_golden_after_every_kernel_figure(monkeypatch):
    """The golden's matrix products leave OpenBLAS threads spinning on the second core:
    no model or calibration figure may be timed after a golden run."""
    order: list[str] = []
    for name in ("_bench_pipeline", "_bench_golden", "_calib_mpix_s", "_simd_gelem_s"):
        real = getattr(bench, name)

        def logged(*args, _real=real, _name=name, **kw):
            order.append(_name)
            return _real(*args, **kw)

        monkeypatch.setattr(bench, name, logged)
    bench.bench_figures(repeats=1, size=32)
    first_golden = order.index("_bench_golden")
    variants = sum(len(p.variants) for p in bench.PIPELINES.values())
    assert order.count("_bench_golden") == order.count("_bench_pipeline") == variants
    assert all(name == "_bench_golden" for name in order[first_golden:])


def test_simd_calibration_loop_computes_its_update():
    a, b = np.arange(-8, 9, dtype=np.int64), 7 * np.arange(17, dtype=np.int64)
    want = a.copy()
    for _ in range(3):
        want = ((want * 3 + b) >> 2) ^ (b << 1)
    assert bench.calib_simd(a, b, 3) == want[0] and a.tolist() == want.tolist()


# -- the divider in SIMD lanes ----------------------------------------------------------


@njit
def _floor_log2_loop(x):
    out = np.empty_like(x)
    for i in range(x.shape[0]):  # the loop form the dividers use (vectorised)
        out[i] = floor_log2_lanes(x[i])
    return out


def test_floor_log2_lanes_is_the_bit_length_minus_one_up_to_2_63():
    """Every power of two, its neighbours and random values from 1 to 2**63 - 1 (both
    sides of the 2**52 switch): the float-exponent form equals ``int.bit_length() - 1``."""
    edges = {1, 2**63 - 1}
    for k in range(63):
        edges |= {2**k - 1, 2**k, 2**k + 1, 2**k + 2 ** max(k - 1, 0)}
    rng = np.random.default_rng(5)
    x = np.array(sorted(v for v in edges if 1 <= v < 2**63), dtype=np.int64)
    x = np.concatenate([x, rng.integers(1, 2**63 - 1, 4000) >> rng.integers(0, 63, 4000)])
    x = np.maximum(x, 1)
    want = np.array([int(v).bit_length() - 1 for v in x])
    np.testing.assert_array_equal(_floor_log2_loop(x), want)


@pytest.mark.parametrize("overflow", list(Overflow), ids=lambda m: m.name)
@pytest.mark.parametrize("quant", [Quant.TRN, Quant.RND, Quant.RND_MIN_INF, Quant.RND_CONV,
                                   Quant.TRN_ZERO], ids=lambda m: m.name)  # fmt: skip
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    word=st.integers(1, 40),
    frac=st.integers(-4, 24),
    signed=st.booleans(),
    fn=st.integers(0, 30),
    fd=st.integers(0, 30),
    d_word=st.integers(1, 62),
    lut_bits=st.integers(2, 10),
    r_bits=st.integers(8, 28),
    seed=st.integers(0, 2**32 - 1),
)
def test_divide_row_lanes_equals_the_scalar_divider(
    quant, overflow, word, frac, signed, fn, fd, d_word, lut_bits, r_bits, seed
):
    """The reciprocal divider in lanes (front end and range stage) against divide_row: every
    quotient, flag, overflow count and logged min/max, with D = 0, N = 0 and both signs."""
    from rangefx.rtl_model.runtime import reciprocal_lut

    fm = np.zeros((len(P1_SIGNALS), 5), dtype=np.int64)
    s = RANGE
    fm[s] = (word, frac, int(signed), int(quant), int(overflow))
    assume(divide_lanes_fit(fn, fd, d_word, s, r_bits, fm))
    rng = np.random.default_rng(seed)
    n = 67
    num = rng.integers(-(2**30), 2**30, n) >> rng.integers(0, 30, n)
    den = rng.integers(-(2 ** (d_word - 1)), 2 ** (d_word - 1), n, endpoint=True)
    den >>= rng.integers(0, d_word, n)
    num[:5], den[:5] = (0, 7, -7, 0, 3), (0, 0, 0, 5, -1)
    lut = reciprocal_lut(lut_bits, r_bits)
    # both cast bodies where the modes are plain (the kernels take the plain one then)
    bodies = [ANY_MODES] + ([PLAIN_MODES] if plain_modes(fm[s : s + 1]) else [])
    results = []
    for modes in [*bodies, "scalar"]:
        dst = np.empty((len(P1_SIGNALS), 2))
        dst[:, 0], dst[:, 1] = np.inf, -np.inf
        ov = np.zeros(len(P1_SIGNALS), dtype=np.int64)
        q, flags = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.bool_)
        if modes == "scalar":
            divide_row(num, fn, den, fd, s, DIV_RECIPROCAL, lut, r_bits, fm, dst, ov, q, flags)
        else:
            divide_row_lanes(num, fn, den, fd, s, lut, r_bits, fm, dst, ov, q, flags, True, modes)
        results.append([q, flags, ov[s], dst[s]])
    want = results[-1]
    for got in results[:-1]:
        assert np.array_equal(got[0], want[0])
        assert np.array_equal(got[1], want[1])
        assert got[2] == want[2]
        assert np.array_equal(got[3], want[3])
