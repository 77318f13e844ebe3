"""Tests of the P1 test oracle itself (``tests/oracle_p1.py``).

(a) with a wide config the oracle agrees with the float64 golden estimator and ranging to
within tolerances derived from the formats' LSBs; (b) hand-computed casts and divider
results; (c) SAT_ZERO / SAT_SYM behaviour, directly and through the datapath.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from oracle_exact import (
    cast_exact,
    divide_reciprocal,
    divide_restoring,
    reg_raw,
    restoring_loop,
)
from oracle_p1 import oracle_p1

from rangefx.golden.estimator import EstimatorConfig, estimate_derivatives
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.ranging import RangingConfig, range_g4
from rangefx.golden.scenes import render_plane, render_scene
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1 import RANGE_TAPS
from rangefx.rtl_model.p1.config import P1_SIGNALS, P1Config
from rangefx.rtl_model.p1.pipeline import FRONTEND_SIGNALS

Q, OV = Quant, Overflow

#: Widening order (earlier signals get first claim on the int64 budget of the config).
WIDEN_ORDER = (
    "bias_reg",
    "bias_in",
    "row_state",
    "col_state",
    "col2_state",
    "row_r1",
    "row_r2",
    "col_s1",
    "col_s2",
    "col2_out",
    "div_quot",
    "c1",
    "grad_a",
    "grad_b",
    "coord",
    "f_reg",
    "k_t_reg",
    "k_m_reg",
    "k_rot",
    "geom_v",
    "geom_w",
    "gv",
    "num",
    "den",
    "range",
    "v_sq",
    "grad_sq",
)
#: The front end's signals but the divider's quotient: the filters'.
FILTER_SIGNALS = tuple(s for s in FRONTEND_SIGNALS if s != "div_quot")


def wide_config(variant: str, divider: str, kmax: int = 16) -> P1Config:
    """Default config with up to ``kmax`` more fraction bits per signal (greedy, valid)."""
    cfg = P1Config.default(variant=variant).with_(divider=divider)
    for name in WIDEN_ORDER:
        f = cfg.fmt(name)
        for k in range(kmax, 0, -1):
            wider = FixedFormat(f.signed, min(f.word + k, 62), f.frac + k, f.quant, f.overflow)
            try:
                cfg = cfg.with_formats(**{name: wider})
                break
            except ValueError:
                continue
    return cfg


@pytest.fixture(scope="module")
def plane():
    scene = render_plane(depth=5.0, size=(12, 16), seed=1)
    return scene


@pytest.fixture(scope="module")
def runway_crop():
    """12x16 crop of a 96x96 runway pair (motion, rotation on), principal point moved."""
    scene = render_scene("runway", size=(96, 96))
    j0, i0, m, n = 64, 40, 12, 16
    cx, cy = scene.camera.principal_point
    cam = PinholeCamera(n, m, scene.camera.f_px, cx=cx - i0, cy=cy - j0)
    crop = (slice(j0, j0 + m), slice(i0, i0 + n))
    return scene.image1[crop], scene.image2[crop], cam, scene.motion


# ---------------------------------------------------------------------------------------
# (a) agreement with the float golden model
# ---------------------------------------------------------------------------------------
def _check_against_golden(im1, im2, camera, motion, cfg, ranging, mode):
    res = oracle_p1(im1, im2, camera, motion, cfg, ranging, mode=mode)
    assert sum(res.overflows[s] for s in P1_SIGNALS if s != "range") == 0
    # the golden filter runs with the register values of the pole and the bias
    c = cfg.fmt("pole_coef").to_float(reg_raw(cfg.pole, cfg.fmt("pole_coef")))
    bias = cfg.fmt("bias_reg").to_float(reg_raw(cfg.bias, cfg.fmt("bias_reg")))
    est = EstimatorConfig(pole=c, variant=cfg.variant, bias=bias, init=cfg.init)
    # per-cast error <= 1 LSB; a first-order section with pole c amplifies a per-step
    # error by at most 1/c and passes its input error with gain <= 1: sum over the path.
    tol = sum(cfg.fmt(s).lsb for s in FILTER_SIGNALS) * 2 / c
    assert tol < 1e-2  # the test must not be vacuous
    ders = []
    for prefix, image in (("e1", im1), ("e2", im2)):
        d = estimate_derivatives(image, est)
        ders.append(d)
        t = res.taps
        paper = cfg.variant == "paper"
        s1_key, s2_key = ("s1", "s2") if paper else ("u00", "u01")
        pairs = [
            ("row_r1", "r1", "row_r1"),
            ("row_r2", "r2", "row_r2"),
            ("col_s1", s1_key, "col_s1"),
            ("col_s2", s2_key, "col_s2"),
        ]
        if not paper:
            pairs.append(("ex", "u10", "col2_out"))
        for tap, gold, fmt_name in pairs:
            got = cfg.fmt(fmt_name).to_float(t[f"{prefix}.{tap}"])
            err = np.abs(got - d.taps[gold]).max()
            assert err <= tol, (prefix, tap, err, tol)
        # E_hat = s1 - bias; Ey = s2
        e_hat = cfg.fmt("col_s1").to_float(t[f"{prefix}.col_s1"]) - bias
        assert np.abs(e_hat - d.E).max() <= tol
        ey = cfg.fmt("col_s2").to_float(t[f"{prefix}.col_s2"])
        assert np.abs(ey - d.Ey).max() <= tol
        ex_fmt = cfg.fmt("div_quot" if paper else "col2_out")
        ex = ex_fmt.to_float(t[f"{prefix}.ex"])
        if paper:
            s1, r1, r2 = d.taps["s1"], d.taps["r1"], d.taps["r2"]
            # first-order propagation of the s1, r1, r2 errors through s1 r2 / r1
            ex_tol = tol * (np.abs(r2) + np.abs(s1)) / r1 + tol * np.abs(s1 * r2) / r1**2
            ex_tol = ex_tol + ex_fmt.lsb
            if cfg.divider == "reciprocal":  # one Newton step from an L-bit LUT
                ex_tol = ex_tol + np.abs(d.Ex) * 2.0 ** (4 - cfg.recip_bits)
            assert np.all(np.abs(ex - d.Ex) <= ex_tol)
        else:
            assert np.abs(ex - d.Ex).max() <= tol
    gold = range_g4(ders[0], ders[1], camera, motion, ranging)
    valid = res.taps["valid"].astype(bool)
    rng = cfg.fmt("range").to_float(res.taps["range"])
    assert np.mean(valid == gold.valid) >= 0.95
    both = valid & gold.valid
    assert both.sum() >= 0.2 * valid.size
    rel = np.abs(rng[both] - gold.range[both]) / gold.range[both]
    assert np.median(rel) < 1e-3
    assert np.all(rng[~valid] == ranging.range_max)
    return res


@pytest.mark.parametrize("variant", ["paper", "consistent"])
@pytest.mark.parametrize("divider", ["restoring", "reciprocal"])
def test_wide_config_matches_golden_stereo(plane, variant, divider):
    cfg = wide_config(variant, divider)
    ranging = RangingConfig(threshold_e=1.0, threshold_g=1.0, range_max=100.0, min_denominator=0.5)
    res = _check_against_golden(
        plane.image1, plane.image2, plane.camera, plane.motion, cfg, ranging, "stereo"
    )
    assert set(res.taps) == {f"e{s}.{k}" for s in (1, 2) for k in _stream_taps(variant)} | set(
        RANGE_TAPS
    )
    for v in res.taps.values():
        assert v.dtype == np.int64 and v.shape == plane.image1.shape


@pytest.mark.parametrize(
    ("variant", "divider", "pole", "bias", "init"),
    [
        ("paper", "restoring", 0.3, 5.3, "first"),  # zero init: r1 = 0 at column 0
        ("consistent", "reciprocal", 0.7, 9.1, "zero"),
    ],
)
def test_wide_config_matches_golden_odd_pole(plane, variant, divider, pole, bias, init):
    cfg = wide_config(variant, divider).with_(init=init, pole=pole, bias=bias, filter_form="direct")
    assert cfg.fmt("pole_coef").to_float(reg_raw(pole, cfg.fmt("pole_coef"))) != pole
    ranging = RangingConfig(threshold_e=1.0, threshold_g=1.0, range_max=100.0, min_denominator=0.5)
    _check_against_golden(
        plane.image1, plane.image2, plane.camera, plane.motion, cfg, ranging, "stereo"
    )


@pytest.mark.parametrize("variant", ["paper", "consistent"])
def test_wide_config_matches_golden_motion_with_rotation(runway_crop, variant):
    im1, im2, cam, motion = runway_crop
    cfg = wide_config(variant, "restoring")
    ranging = RangingConfig(threshold_e=1.0, threshold_g=1.0, range_max=1000.0, min_denominator=0.5)
    res = _check_against_golden(im1, im2, cam, motion, cfg, ranging, "motion")
    # the rotation terms are live: k0..k2 are not all zero
    assert np.any(res.taps["k1"] != 0) and np.any(res.taps["k2"] != 0)


def _stream_taps(variant: str) -> tuple[str, ...]:
    base = ("bias_in", "row_r1", "row_r2", "row_state", "col_s1", "col_s2", "col_state", "ex")
    return (*base, "col2_state") if variant == "consistent" else base


def test_minmax_and_counts_are_over_casts(plane):
    cfg = P1Config.default(variant="paper")
    ranging = RangingConfig()
    im = plane.image1[:4, :5]
    cam = PinholeCamera(5, 4, 20.0)
    res = oracle_p1(im, im, cam, MotionIncrement.stereo(0.1), cfg, ranging)
    assert res.minmax["pix_in"] == (float(im.min()), float(im.max()))
    assert res.minmax["bias_in"] == (float(im.min()) + 16, float(im.max()) + 16)
    assert res.minmax["coord"] == (-2.0, 2.0)  # xp in -2..2, yp in -1.5..1.5
    assert "pole_coef" not in res.minmax and "bias_reg" not in res.minmax  # registers
    assert set(res.overflows) == set(P1_SIGNALS)
    # identical images: c1 = 0 everywhere, so den = 0: the gate feeds the range divider
    # 0 / 1 instead of dividing by zero, and nothing overflows
    assert np.all(res.taps["c1"] == 0) and np.all(res.taps["den"] == 0)
    assert np.all(res.taps["valid"] == 0) and np.all(res.taps["range_q"] == 0)
    assert res.overflows["range"] == 0


# ---------------------------------------------------------------------------------------
# (b) hand-computed casts and dividers
# ---------------------------------------------------------------------------------------
TIES = [-5, -3, -1, 1, 3, 5]  # halves: -2.5 .. 2.5 with one fraction bit
EXPECTED_TIES = {  # docs/rounding.md
    Q.TRN: [-3, -2, -1, 0, 1, 2],
    Q.TRN_ZERO: [-2, -1, 0, 0, 1, 2],
    Q.RND: [-2, -1, 0, 1, 2, 3],
    Q.RND_ZERO: [-2, -1, 0, 0, 1, 2],
    Q.RND_INF: [-3, -2, -1, 1, 2, 3],
    Q.RND_MIN_INF: [-3, -2, -1, 0, 1, 2],
    Q.RND_CONV: [-2, -2, 0, 0, 2, 2],
}


@pytest.mark.parametrize("quant", list(Quant), ids=lambda q: q.name)
def test_cast_ties(quant):
    fmt = FixedFormat(True, 8, 0, quant, OV.SAT)
    assert [cast_exact(t, 1, fmt) for t in TIES] == [(v, False) for v in EXPECTED_TIES[quant]]


@pytest.mark.parametrize(
    ("n", "f", "fmt", "expected"),
    [
        (3, 2, FixedFormat(True, 8, 0, Q.TRN, OV.SAT), (0, False)),  # 0.75
        (3, 2, FixedFormat(True, 8, 0, Q.RND_MIN_INF, OV.SAT), (1, False)),
        (-3, 2, FixedFormat(True, 8, 0, Q.TRN_ZERO, OV.SAT), (0, False)),
        (-3, 2, FixedFormat(True, 8, 0, Q.TRN, OV.SAT), (-1, False)),
        (255, 1, FixedFormat(True, 8, 0, Q.RND, OV.SAT), (127, True)),  # 127.5: carry out
        (255, 1, FixedFormat(True, 8, 0, Q.TRN, OV.SAT), (127, False)),
        (130, 0, FixedFormat(True, 8, 0, Q.TRN, OV.WRAP), (-126, True)),
        (260, 0, FixedFormat(False, 8, 0, Q.TRN, OV.WRAP), (4, True)),
        (-1, 0, FixedFormat(False, 8, 0, Q.TRN, OV.WRAP), (255, True)),
        (-5, 0, FixedFormat(False, 8, 0, Q.TRN, OV.SAT), (0, True)),
        (-200, 0, FixedFormat(True, 8, 0, Q.TRN, OV.SAT), (-128, True)),
        (5, 0, FixedFormat(True, 8, 2, Q.TRN, OV.SAT), (20, False)),  # left shift
        (5, 0, FixedFormat(True, 8, -1, Q.RND_CONV, OV.SAT), (2, False)),  # 5 -> 4 (2 x 2)
        (7, 0, FixedFormat(True, 8, -1, Q.RND_CONV, OV.SAT), (4, False)),  # 7 -> 8
        # s2.0 value 1 into s1.63: apytypes 0.5.1 gives raw -1; the right answer is 0
        (1, 0, FixedFormat(True, 1, 63, Q.TRN, OV.SAT), (0, True)),
        (1, 0, FixedFormat(True, 62, 61, Q.TRN, OV.SAT), (2**61 - 1, True)),
        (1, 0, FixedFormat(True, 62, 60, Q.TRN, OV.SAT), (2**60, False)),
        # a 63-bit value shifted right by 100 - 40 = 60 bits: -(2**61 - 1) / 2**60
        (-(2**61) + 1, 100, FixedFormat(True, 8, 40, Q.RND, OV.SAT), (-2, False)),
        (-(2**61) + 1, 100, FixedFormat(True, 8, 40, Q.TRN_ZERO, OV.SAT), (-1, False)),
    ],
)
def test_cast_by_hand(n, f, fmt, expected):
    assert cast_exact(n, f, fmt) == expected


def test_registers_by_hand():
    assert reg_raw(0.1, FixedFormat(False, 8, 4, Q.RND, OV.SAT)) == 2  # 1.6
    assert reg_raw(0.1, FixedFormat(False, 8, 4, Q.TRN, OV.SAT)) == 1
    assert reg_raw(-0.15625, FixedFormat(True, 8, 3, Q.RND, OV.SAT)) == -1  # -1.25
    assert reg_raw(-0.1875, FixedFormat(True, 8, 3, Q.RND, OV.SAT)) == -1  # -1.5 tie
    assert reg_raw(-0.1875, FixedFormat(True, 8, 3, Q.RND_CONV, OV.SAT)) == -2
    # float64 0.1 is 3602879701896397 / 2**55 exactly, not 1/10 (2**60 / 10 = ...697.6):
    # the register takes the float's exact value, 3602879701896397 * 2**5
    assert reg_raw(0.1, FixedFormat(True, 62, 60, Q.RND, OV.SAT)) == 3602879701896397 * 32
    # at 54 fraction bits it is the tie 1801439850948198.5
    assert reg_raw(0.1, FixedFormat(True, 62, 54, Q.RND, OV.SAT)) == 1801439850948199
    assert reg_raw(0.1, FixedFormat(True, 62, 54, Q.RND_CONV, OV.SAT)) == 1801439850948198
    assert reg_raw(1000.0, FixedFormat(True, 8, 0, Q.RND, OV.SAT_ZERO)) == 0


def test_restoring_loop_is_divmod():
    rng = np.random.default_rng(7)
    for _ in range(500):
        t = int(rng.integers(0, 2**62)) >> int(rng.integers(0, 62))
        d = int(rng.integers(1, 2**40)) >> int(rng.integers(0, 40)) or 1
        assert restoring_loop(t, d) == divmod(t, d)
    assert restoring_loop(2**80 + 3, 7) == divmod(2**80 + 3, 7)


S8_0 = {q: FixedFormat(True, 8, 0, q, OV.SAT) for q in Quant}


@pytest.mark.parametrize(
    ("n", "d", "quant", "expected"),
    [
        # exact ties +-2.5: guard bit 1, sticky 0
        (5, 2, Q.RND, 3),
        (5, 2, Q.RND_CONV, 2),
        (5, 2, Q.TRN_ZERO, 2),
        (-5, 2, Q.RND, -2),
        (-5, 2, Q.RND_CONV, -2),
        (-5, 2, Q.TRN_ZERO, -2),
        (-5, 2, Q.TRN, -3),
        (5, -2, Q.RND_INF, -3),
        (7, 2, Q.RND_CONV, 4),  # 3.5
        (-7, -2, Q.RND_ZERO, 3),
        # just above the tie: guard bit 1, sticky 1 must break the tie
        (2501, 1000, Q.RND_ZERO, 3),
        (2501, 1000, Q.RND_CONV, 3),
        (2501, 1000, Q.RND_MIN_INF, 3),
        (-2501, 1000, Q.RND, -3),
        (-2501, 1000, Q.RND_ZERO, -3),
        (-2501, 1000, Q.TRN_ZERO, -2),
        # below the tie; truncation of a negative quotient (sign-magnitude, then cast)
        (-2499, 1000, Q.TRN, -3),
        (-2499, 1000, Q.RND_INF, -2),
        (1, 3, Q.TRN, 0),
        (-1, 3, Q.TRN, -1),
        (-1, 3, Q.TRN_ZERO, 0),
    ],
)
def test_restoring_rounding(n, d, quant, expected):
    assert divide_restoring(n, 0, d, 0, S8_0[quant]) == (expected, False)


def test_restoring_fraction_bits_and_saturation():
    # N = 0.75 (F=2), D = 0.5 (F=1): 1.5
    assert divide_restoring(3, 2, 1, 1, FixedFormat(True, 8, 1, Q.TRN, OV.SAT)) == (3, False)
    assert divide_restoring(3, 2, 1, 1, S8_0[Q.RND_CONV]) == (2, False)
    # 1/3 into s8.7 RND: 42.67 -> 43; the negative exponent branch (|D| shifted left)
    assert divide_restoring(1, 0, 3, 0, FixedFormat(True, 8, 7, Q.RND, OV.SAT)) == (43, False)
    assert divide_restoring(1, 10, 3, 0, FixedFormat(True, 8, 0, Q.RND, OV.SAT)) == (0, False)
    assert divide_restoring(3 << 10, 10, 1, 0, FixedFormat(True, 8, -2, Q.TRN, OV.SAT)) == (
        0,
        False,
    )
    # 1000 / 1 overflows s8.0
    assert divide_restoring(1000, 0, 1, 0, S8_0[Q.TRN]) == (127, True)
    assert divide_restoring(-1000, 0, 1, 0, FixedFormat(True, 8, 0, Q.TRN, OV.SAT_SYM)) == (
        -127,
        True,
    )
    assert divide_restoring(-1000, 0, 1, 0, FixedFormat(True, 8, 0, Q.TRN, OV.SAT_ZERO)) == (
        0,
        True,
    )
    assert divide_restoring(-1, 0, 1, 0, FixedFormat(False, 8, 0, Q.TRN, OV.SAT)) == (0, True)


@pytest.mark.parametrize("divide", [divide_restoring, divide_reciprocal])
def test_divide_by_zero(divide):
    s8 = FixedFormat(True, 8, 2, Q.RND, OV.SAT)
    assert divide(0, 0, 0, 0, s8) == (0, False)
    assert divide(5, 3, 0, 1, s8) == (127, True)
    assert divide(-5, 3, 0, 1, s8) == (-128, True)
    assert divide(-5, 3, 0, 1, FixedFormat(True, 8, 2, Q.RND, OV.SAT_SYM)) == (-127, True)
    assert divide(-5, 3, 0, 1, FixedFormat(False, 8, 2, Q.RND, OV.SAT)) == (0, True)
    assert divide(5, 3, 0, 1, FixedFormat(False, 8, 2, Q.RND, OV.SAT_ZERO)) == (0, True)


def test_reciprocal_by_hand():
    """L = 2, R = 6 worked out by hand.

    d = 3: p = 1, idx = floor(3 * 2) - 4 = 2, y0 = round(128 / 3.25 = 39.38) = 39,
    mR = floor(3 * 32) = 96, t = floor(96 * 39 / 64 = 58.5) = 58, e = 128 - 58 = 70,
    y1 = floor(39 * 70 / 64 = 42.66) = 42: 1/3 ~ 42 * 2**-7 = 0.328125.
    d = 1: p = 0, idx = 0, y0 = round(128 / 2.25 = 56.9) = 57, mR = 64, t = 57, e = 71,
    y1 = floor(57 * 71 / 64 = 63.2) = 63: 1/1 ~ 63 / 64.
    """
    s8_7 = FixedFormat(True, 8, 7, Q.TRN, OV.SAT)
    assert divide_reciprocal(1, 0, 3, 0, s8_7, 2, 6) == (42, False)
    assert divide_reciprocal(-1, 0, 3, 0, s8_7, 2, 6) == (-42, False)
    assert divide_reciprocal(1, 0, -3, 0, FixedFormat(True, 8, 7, Q.RND, OV.SAT), 2, 6) == (
        -42,
        False,
    )
    s8_6 = FixedFormat(True, 8, 6, Q.TRN, OV.SAT)
    assert divide_reciprocal(1, 0, 1, 0, s8_6, 2, 6) == (63, False)
    # N = 3.0 (6, F=1), D = 3.0 (12, F=2): d = 12, p = 3, idx = 2, same y1 = 42,
    # value = 6 * 42 * 2**-(1 - 2 + 3 + 6) = 252 / 256
    assert divide_reciprocal(6, 1, 12, 2, s8_6, 2, 6) == (63, False)
    assert divide_reciprocal(6, 1, 12, 2, FixedFormat(True, 8, 6, Q.RND, OV.SAT), 2, 6) == (
        63,
        False,
    )
    assert divide_reciprocal(6, 1, 12, 2, FixedFormat(True, 10, 8, Q.TRN, OV.SAT), 2, 6) == (
        252,
        False,
    )
    # restoring gives the correctly rounded 1/3 = 42.67 -> 43 in s8.7 RND
    assert divide_restoring(1, 0, 3, 0, FixedFormat(True, 8, 7, Q.RND, OV.SAT)) == (43, False)


def test_reciprocal_default_accuracy():
    """Default L = 8, R = 20: relative error of a few 2**-20 over many divisors."""
    fmt = FixedFormat(True, 40, 30, Q.RND, OV.SAT)
    rng = np.random.default_rng(3)
    for d in [1, 2, 3, 255, 256, 257, *map(int, rng.integers(1, 2**30, 200))]:
        raw, flag = divide_reciprocal(1 << 20, 20, d, 0, fmt)
        assert not flag
        assert math.isclose(raw * 2.0**-30, 1 / d, rel_tol=2**-17, abs_tol=2**-30)


# ---------------------------------------------------------------------------------------
# (c) SAT_ZERO / SAT_SYM
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("n", "signed", "mode", "expected"),
    [
        (200, True, OV.SAT_ZERO, (0, True)),
        (-129, True, OV.SAT_ZERO, (0, True)),
        (-128, True, OV.SAT_ZERO, (-128, False)),
        (127, True, OV.SAT_ZERO, (127, False)),
        (300, False, OV.SAT_ZERO, (0, True)),
        (-1, False, OV.SAT_ZERO, (0, True)),
        (255, False, OV.SAT_ZERO, (255, False)),
        (-200, True, OV.SAT_SYM, (-127, True)),
        (-128, True, OV.SAT_SYM, (-127, True)),  # the most negative code counts
        (-127, True, OV.SAT_SYM, (-127, False)),
        (200, True, OV.SAT_SYM, (127, True)),
        (300, False, OV.SAT_SYM, (255, True)),  # unsigned: as SAT
        (-3, False, OV.SAT_SYM, (0, True)),
        (-128, True, OV.SAT, (-128, False)),
    ],
)
def test_sat_zero_sat_sym(n, signed, mode, expected):
    assert cast_exact(n, 0, FixedFormat(signed, 8, 0, Q.TRN, mode)) == expected


def test_sat_zero_rounding_carry():
    # 127.5 rounds to 128 (RND): out of range after quantisation -> 0 under SAT_ZERO
    assert cast_exact(255, 1, FixedFormat(True, 8, 0, Q.RND, OV.SAT_ZERO)) == (0, True)
    assert cast_exact(-257, 1, FixedFormat(True, 8, 0, Q.RND, OV.SAT_SYM)) == (-127, True)
    assert cast_exact(-255, 1, FixedFormat(True, 8, 0, Q.RND, OV.SAT_SYM)) == (-127, False)


@pytest.mark.parametrize(
    ("mode", "c1_expected"),
    [(OV.SAT, -128), (OV.SAT_SYM, -127), (OV.SAT_ZERO, 0), (OV.WRAP, 1)],
)
def test_overflow_modes_through_the_datapath(mode, c1_expected):
    """Constant images 0 and 255: c1 = E1_hat - E2_hat = 16 - 271 = -255 exactly, into s8.0."""
    m, n = 3, 4
    im1 = np.zeros((m, n), dtype=np.uint8)
    im2 = np.full((m, n), 255, dtype=np.uint8)
    cam, motion = PinholeCamera(n, m, 20.0), MotionIncrement.stereo(0.1)
    base = P1Config.default(variant="consistent")
    cfg = base.with_formats(c1=FixedFormat(True, 8, 0, Q.RND, mode))
    res = oracle_p1(im1, im2, cam, motion, cfg, RangingConfig())
    assert np.all(res.taps["c1"] == c1_expected)
    assert res.overflows["c1"] == m * n
    assert res.minmax["c1"] == (-255.0, -255.0)
    # an unsigned signal: 255 + 16 = 271 into u8.0 (stream 2 only)
    cfg = base.with_formats(bias_in=FixedFormat(False, 8, 0, Q.TRN, mode))
    res = oracle_p1(im1, im2, cam, motion, cfg, RangingConfig())
    assert res.overflows["bias_in"] == m * n
    assert np.all(res.taps["e1.bias_in"] == 16)
    bias2 = {OV.SAT: 255, OV.SAT_SYM: 255, OV.SAT_ZERO: 0, OV.WRAP: 271 - 256}[mode]
    assert np.all(res.taps["e2.bias_in"] == bias2)
    assert res.minmax["bias_in"] == (16.0, 271.0)


@pytest.mark.parametrize("variant", ["paper", "consistent"])
@pytest.mark.parametrize("pole", [0.5, 0.25])
def test_shift_filter_form_equals_the_direct_form_at_its_pole(plane, variant, pole):
    """The shift form moves the binary point where the direct form multiplies by the
    register 2^-k: every tap, count and min/max is the same (docs/p1_datapath.md)."""
    cam = PinholeCamera(12, 6, 20.0)
    im1, im2 = plane.image1[:6, :12], plane.image2[:6, :12]
    motion, ranging = MotionIncrement.stereo(0.1), RangingConfig()
    shift = P1Config.default(variant=variant, pole=pole)
    direct = shift.with_(filter_form="direct")
    assert (shift.pole_shift, direct.pole_shift) == (round(-math.log2(pole)), None)
    a = oracle_p1(im1, im2, cam, motion, shift, ranging)
    b = oracle_p1(im1, im2, cam, motion, direct, ranging)
    assert a.taps.keys() == b.taps.keys()
    for tap in a.taps:
        assert np.array_equal(a.taps[tap], b.taps[tap]), tap
    assert (a.overflows, a.minmax) == (b.overflows, b.minmax)


def test_shift_filter_form_needs_a_pole_power_of_two():
    with pytest.raises(ValueError, match=r"filter_form 'shift' needs a pole 2\^-k"):
        P1Config.default(pole=0.375)
    with pytest.raises(ValueError, match="holds 1"):  # 2^-17: half of pole_coef's LSB
        P1Config.default(pole=2.0**-17)
    assert P1Config.default(pole=0.375, filter_form="direct").pole_shift is None
    assert P1Config.default(pole=1.0).pole_shift == 0
