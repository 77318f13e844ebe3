"""The divider on SIMD lanes (issue 18: the lane helpers of ``rtl_model/kernels.py`` as a
band kernel composes them, with ``divide_lanes_scalar`` as the fallback) against the
scalar divider they replace (``divide_scalar``): value, overflow flag and logged value,
element by element, over formats, modes, both divider kinds, ``D = 0``, negative
operands and operands large enough to take the scalar fallback."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from rangefx.rtl_model.fixedpoint import ANY_MODES, Overflow, Quant
from rangefx.rtl_model.kernels import (
    bit_length,
    divide_lanes_scalar,
    divide_scalar,
    lane_log_values,
    lane_overflows,
    ldexp2,
    reciprocal_lane,
    reciprocal_seed_index,
    restoring_lane,
    restoring_lane_setup,
)
from rangefx.rtl_model.runtime import DIV_RECIPROCAL, DIV_RESTORING, reciprocal_lut


@njit(error_model="numpy")
def _lanes(num, fn, den, fd, word, frac, signed, quant, ovf, kind, lut, r_bits):
    k = num.shape[0]
    out, flags = np.empty(k, np.int64), np.empty(k, np.bool_)
    lo, hi = np.full(k, np.inf), np.full(k, -np.inf)
    # the lane loops of a band kernel (P2's backward step): branch-free helpers, and the
    # scalar fallback for the whole call when a lane is beyond them
    ov_pos, ov_neg = lane_overflows(word, signed, ovf)
    far = not -1022 <= fd - fn <= 1022
    if kind == DIV_RESTORING:
        sh, plan, cap = restoring_lane_setup(fn, fd, word, frac, signed, quant, ovf)
        for i in range(k):
            out[i], flags[i], beyond = restoring_lane(num[i], den[i], sh, plan, cap, ov_pos,
                                                      ov_neg, ANY_MODES)  # fmt: skip
            far |= beyond
    else:
        lut_bits, mask = bit_length(lut.shape[0]) - 1, lut.shape[0] - 1
        for i in range(k):
            out[i] = lut[reciprocal_seed_index(den[i], lut_bits, mask)]
        for i in range(k):
            out[i], flags[i], beyond = reciprocal_lane(num[i], den[i], out[i], fn, fd, r_bits,
                                                       word, frac, signed, quant, ovf, ov_pos,
                                                       ov_neg, ANY_MODES)  # fmt: skip
            far |= beyond
    if far:
        count = divide_lanes_scalar(num, fn, den, fd, k, word, frac, signed, quant, ovf, kind,
                                    lut, r_bits, out, flags, lo, hi, True)  # fmt: skip
        return out, flags, lo, hi, count, True
    scale = ldexp2(1.0, fd - fn)
    for i in range(k):
        lo[i], hi[i] = lane_log_values(num[i], den[i], scale)
    return out, flags, lo, hi, flags.sum(), False


@njit
def _scalar(num, fn, den, fd, word, frac, signed, quant, ovf, kind, lut, r_bits):
    k = num.shape[0]
    out, flags = np.empty(k, np.int64), np.empty(k, np.bool_)
    lo, hi = np.empty(k), np.empty(k)
    for i in range(k):
        out[i], flags[i], lo[i], hi[i] = divide_scalar(num[i], fn, den[i], fd, word, frac, signed,
                                                       quant, ovf, kind, lut, r_bits)  # fmt: skip
    return out, flags, lo, hi


def _draws(seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        kind = DIV_RESTORING if rng.random() < 0.5 else DIV_RECIPROCAL
        word, frac = int(rng.integers(2, 40)), int(rng.integers(-8, 40))
        fn, fd = int(rng.integers(-20, 30)), int(rng.integers(-20, 30))
        lut_bits, r_bits = int(rng.integers(3, 11)), int(rng.integers(8, 29))
        # operand bits the divider's exact intermediates allow (as the configs check them)
        sh = frac + 1 + fd - fn
        n_bits = int(rng.integers(1, 20))
        d_bits = int(rng.integers(1, 62))  # past 2**52: both forms of the normalisation
        if kind == DIV_RESTORING:
            n_bits = min(n_bits, 61 - max(sh, 0))
            d_bits = min(d_bits, 61 - max(-sh, 0))
        else:
            n_bits = min(n_bits, 58 - r_bits)
        if n_bits < 1 or d_bits < 1:
            continue
        k = int(rng.integers(1, 40))
        num = rng.integers(-(1 << n_bits), 1 << n_bits, k).astype(np.int64)
        den = rng.integers(-(1 << d_bits), 1 << d_bits, k).astype(np.int64)
        num[rng.random(k) < 0.15] = 0
        den[rng.random(k) < 0.15] = 0
        signed, quant = bool(rng.random() < 0.5), int(rng.choice(list(Quant)))
        ovf, lut = int(rng.choice(list(Overflow))), reciprocal_lut(lut_bits, r_bits)
        yield num, fn, den, fd, word, frac, signed, quant, ovf, kind, lut, r_bits


@pytest.mark.parametrize("seed", range(8))
def test_lane_divider_equals_divide_scalar(seed):
    for args in _draws(seed):
        out, flags, lo, hi, count, _ = _lanes(*args)
        want_out, want_flags, want_lo, want_hi = _scalar(*args)
        np.testing.assert_array_equal(out, want_out)
        np.testing.assert_array_equal(flags, want_flags)
        np.testing.assert_array_equal(lo, want_lo)
        np.testing.assert_array_equal(hi, want_hi)
        assert count == want_flags.sum()


def test_lane_divider_covers_its_fallback_and_zero_denominators():
    """Operands of 2**53 and more (the restoring divider's float quotient is not exact
    there) take the scalar fallback; D = 0 gives the scalar divider's saturated code."""
    lut = reciprocal_lut(8, 20)
    num = np.array([1, -3, 0, 5, 7], np.int64)
    for den in (np.array([1 << 54, 3, 0, 0, -5], np.int64), np.array([9, 3, 0, 0, -5], np.int64)):
        for kind in (DIV_RESTORING, DIV_RECIPROCAL):
            args = (num, 0, den, 0, 20, 10, True, int(Quant.RND), int(Overflow.SAT), kind, lut, 20)
            got, want = _lanes(*args), _scalar(*args)
            assert got[5] == (den[0] == 1 << 54)  # the fallback, for both kinds
            for g, w in zip(got[:4], want, strict=True):
                np.testing.assert_array_equal(g, w)
            assert got[1][3] and got[0][3] == (1 << 19) - 1  # 5 / 0 saturates
