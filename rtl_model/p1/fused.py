"""P1's fused kernels (issue 18): the values, taps, overflow counts and min/max log of
P1's front end in :mod:`rangefx.rtl_model.p1.model`, in less time.

Every cast of a pixel of a stage is in one loop body, branch-free (``cast_by_plan``),
without array temporaries; the row filter's recursion runs along a line, so its loop
runs over a band of lines (SIMD lanes) for one column at a time; the column filters run
along the line. Used whenever every per-pixel cast of the front end shifts by at most 62
bits (any real config: :func:`frontend_fits`); the general kernel is the path for the
others. The min/max log (``log``) and the variant are the only specialisations: no
per-config compile.

The range stage stays the general row-by-row kernel: the same fusion of its 17 casts
into one loop measured twice its time (LLVM did not vectorise that loop: too many
arrays for its runtime alias checks) and ~100 s more cold compile.

A module of its own so that editing it does not invalidate the numba cache of the
general kernels; it calls their public helpers.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..fixedpoint import cast_by_plan, cast_plan
from .model import (
    BIAS_IN,
    BIAS_REG,
    COL2_OUT,
    COL2_STATE,
    COL_S1,
    COL_S2,
    COL_STATE,
    DIV_QUOT,
    PIX_IN,
    POLE_COEF,
    ROW_R1,
    ROW_R2,
    ROW_STATE,
    at_frac,
    cast_row_site,
    divide_row,
)  # fmt: skip

__all__ = ["BAND", "frontend_fits", "frontend_fused"]

_I64_MAX, _I64_MIN = np.iinfo(np.int64).max, np.iinfo(np.int64).min
_at, _cast_row, _divide_row = at_frac, cast_row_site, divide_row


#: Lines per band of the row filter (its SIMD lanes: two AVX-512 vectors of int64 per
#: independent recursion chain in flight, measured best of 8/16/32).
BAND = 16


@njit(cache=True, nogil=True, inline="always")
def _plan(frac_in, s, fm):
    """:func:`~rangefx.rtl_model.fixedpoint.cast_plan` of a cast into signal ``s``."""
    return cast_plan(frac_in - fm[s, 1], fm[s, 0], fm[s, 2] != 0, fm[s, 3], fm[s, 4])


@njit(cache=True, nogil=True, inline="always")
def _short(frac_in, s, fm):
    """Whether the fused kernels take a cast into ``s`` (``|shift| <= 62``)."""
    return abs(frac_in - fm[s, 1]) <= 62


@njit(cache=True, nogil=True, inline="always")
def _log(st, site, lo, hi, frac_in, s):
    """Merge a site's raw (lo, hi) kept in registers into its log."""
    st[site, 0] = min(st[site, 0], lo)
    st[site, 1] = max(st[site, 1], hi)
    st[site, 2] = frac_in
    st[site, 3] = s


@njit(cache=True, nogil=True, inline="always")
def _row_band(
    imgT, bw, bias_al, pole, init_first, fm, st, ov, pT, bT, pnT, r1T, r2T, log, consistent,
):  # fmt: skip
    """Input cast, bias, row filter and ``r1``/``r2`` of lines ``0 <= k < bw`` of a band in
    column-major layout (``imgT[i, k]``): for each column one loop over the lines (the
    lanes), each carrying its own row-filter state in ``pT``."""
    n = imgT.shape[0]
    f_pix, f_b, f_p = fm[PIX_IN, 1], fm[BIAS_IN, 1], fm[ROW_STATE, 1]
    f_c, f_breg = fm[POLE_COEF, 1], fm[BIAS_REG, 1]
    fx = max(f_pix, f_breg)
    fe = max(f_b, f_p)
    fs = max(f_p, f_c + fe)
    pl_x, pl_b, pl_p0 = _plan(0, PIX_IN, fm), _plan(fx, BIAS_IN, fm), _plan(f_b, ROW_STATE, fm)
    pl_p, pl_r2 = _plan(fs, ROW_STATE, fm), _plan(f_c + fe, ROW_R2, fm)
    pl_r1 = _plan(f_p + 1, ROW_R1, fm) if consistent else _plan(f_p, ROW_R1, fm)
    big, small = np.int64(_I64_MAX), np.int64(_I64_MIN)
    lo0, hi0, lo1, hi1, lo2, hi2, lo3, hi3 = big, small, big, small, big, small, big, small
    lo4, hi4, lo5, hi5 = big, small, big, small
    c_x, c_b, c_p, c_r2, c_r1 = 0, 0, 0, 0, 0
    # the initial state of every line: its first b (logged at site 2), or zero
    for k in range(bw):
        raw = imgT[0, k]
        x, _ = cast_by_plan(raw, pl_x)
        b, _ = cast_by_plan((x << (fx - f_pix)) + bias_al, pl_b)
        p0, flag = cast_by_plan(b, pl_p0)
        lo2, hi2 = min(lo2, b), max(hi2, b)
        c_p += flag
        pT[k] = p0 if init_first else np.int64(0)
    if not init_first:
        lo2, hi2 = big, small
        c_p = 0
    for i in range(n):
        for k in range(bw):
            raw = imgT[i, k]
            x, f0 = cast_by_plan(raw, pl_x)
            bsum = (x << (fx - f_pix)) + bias_al
            b, f1 = cast_by_plan(bsum, pl_b)
            p = pT[k]
            prod = pole * ((b << (fe - f_b)) - (p << (fe - f_p)))
            pre = (p << (fs - f_p)) + (prod << (fs - f_c - fe))
            p_new, f2 = cast_by_plan(pre, pl_p)
            r2, f3 = cast_by_plan(prod, pl_r2)
            r1_in = p + p_new if consistent else p
            r1, f4 = cast_by_plan(r1_in, pl_r1)
            if log:
                lo0, hi0 = min(lo0, raw), max(hi0, raw)
                lo1, hi1 = min(lo1, bsum), max(hi1, bsum)
                lo3, hi3 = min(lo3, prod), max(hi3, prod)
                lo4, hi4 = min(lo4, pre), max(hi4, pre)
                lo5, hi5 = min(lo5, r1_in), max(hi5, r1_in)
            c_x += f0
            c_b += f1
            c_p += f2
            c_r2 += f3
            c_r1 += f4
            pT[k] = p_new
            bT[i, k] = b
            pnT[i, k] = p_new
            r1T[i, k] = r1
            r2T[i, k] = r2
    ov[PIX_IN] += c_x
    ov[BIAS_IN] += c_b
    ov[ROW_STATE] += c_p
    ov[ROW_R2] += c_r2
    ov[ROW_R1] += c_r1
    if init_first:
        _log(st, 2, lo2, hi2, f_b, ROW_STATE)
    if log:
        _log(st, 0, lo0, hi0, 0, PIX_IN)
        _log(st, 1, lo1, hi1, fx, BIAS_IN)
        _log(st, 3, lo3, hi3, f_c + fe, ROW_R2)
        _log(st, 4, lo4, hi4, fs, ROW_STATE)
        if consistent:
            _log(st, 5, lo5, hi5, f_p + 1, ROW_R1)
        else:
            _log(st, 6, lo5, hi5, f_p, ROW_R1)


@njit(cache=True, nogil=True, inline="always")
def _col_line(
    r1, r2, lb1, lb2, pole, fm, st, ov, out_e, out_ex, out_ey, num, log, consistent,
):  # fmt: skip
    """Column filter(s) of one line, read before write of the line buffers ``lb1`` (and
    ``lb2``), one loop along the line; the ``paper`` variant leaves the divider's
    numerator ``s1 r2`` in ``num`` (the caller divides the row)."""
    n = r1.shape[0]
    f_r1, f_r2, f_q = fm[ROW_R1, 1], fm[ROW_R2, 1], fm[COL_STATE, 1]
    f_q2, f_c = fm[COL2_STATE, 1], fm[POLE_COEF, 1]
    fe = max(f_r1, f_q)
    fs = max(f_q, f_c + fe)
    fe2 = max(f_r2, f_q2)
    fs2 = max(f_q2, f_c + fe2)
    pl_s2, pl_q = _plan(f_c + fe, COL_S2, fm), _plan(fs, COL_STATE, fm)
    pl_s1 = _plan(f_q + 1, COL_S1, fm) if consistent else _plan(f_q, COL_S1, fm)
    pl_q2, pl_ex = _plan(fs2, COL2_STATE, fm), _plan(f_q2 + 1, COL2_OUT, fm)
    big, small = np.int64(_I64_MAX), np.int64(_I64_MIN)
    lo8, hi8, lo9, hi9, lo10, hi10 = big, small, big, small, big, small
    lo13, hi13, lo14, hi14 = big, small, big, small
    c_s2, c_q, c_s1, c_q2, c_ex = 0, 0, 0, 0, 0
    for i in range(n):
        r1v = r1[i]
        q = lb1[i]
        prod = pole * ((r1v << (fe - f_r1)) - (q << (fe - f_q)))
        s2, f0 = cast_by_plan(prod, pl_s2)
        qs = (q << (fs - f_q)) + (prod << (fs - f_c - fe))
        q_next, f1 = cast_by_plan(qs, pl_q)
        s1_in = q + q_next if consistent else q
        s1, f2 = cast_by_plan(s1_in, pl_s1)
        lb1[i] = q_next
        out_e[i] = s1
        out_ey[i] = s2
        c_s2 += f0
        c_q += f1
        c_s1 += f2
        if log:
            lo8, hi8 = min(lo8, prod), max(hi8, prod)
            lo9, hi9 = min(lo9, qs), max(hi9, qs)
            lo10, hi10 = min(lo10, s1_in), max(hi10, s1_in)
        if consistent:
            r2v = r2[i]
            q2 = lb2[i]
            prod2 = pole * ((r2v << (fe2 - f_r2)) - (q2 << (fe2 - f_q2)))
            qs2 = (q2 << (fs2 - f_q2)) + (prod2 << (fs2 - f_c - fe2))
            q2n, f3 = cast_by_plan(qs2, pl_q2)
            ex_in = q2 + q2n
            ex, f4 = cast_by_plan(ex_in, pl_ex)
            lb2[i] = q2n
            out_ex[i] = ex
            c_q2 += f3
            c_ex += f4
            if log:
                lo13, hi13 = min(lo13, qs2), max(hi13, qs2)
                lo14, hi14 = min(lo14, ex_in), max(hi14, ex_in)
        else:
            num[i] = s1 * r2[i]
    ov[COL_S2] += c_s2
    ov[COL_STATE] += c_q
    ov[COL_S1] += c_s1
    ov[COL2_STATE] += c_q2
    ov[COL2_OUT] += c_ex
    if log:
        _log(st, 8, lo8, hi8, f_c + fe, COL_S2)
        _log(st, 9, lo9, hi9, fs, COL_STATE)
        if consistent:
            _log(st, 10, lo10, hi10, f_q + 1, COL_S1)
            _log(st, 13, lo13, hi13, fs2, COL2_STATE)
            _log(st, 14, lo14, hi14, f_q2 + 1, COL2_OUT)
        else:
            _log(st, 11, lo10, hi10, f_q, COL_S1)


@njit(cache=True, nogil=True)
def frontend_fits(fm, consistent):
    """Whether every cast of the front end shifts by at most 62 bits (the fused path)."""
    f_pix, f_b, f_p = fm[PIX_IN, 1], fm[BIAS_IN, 1], fm[ROW_STATE, 1]
    f_c, f_breg = fm[POLE_COEF, 1], fm[BIAS_REG, 1]
    f_r1, f_r2, f_q, f_q2 = fm[ROW_R1, 1], fm[ROW_R2, 1], fm[COL_STATE, 1], fm[COL2_STATE, 1]
    fe, fe_c, fe_c2 = max(f_b, f_p), max(f_r1, f_q), max(f_r2, f_q2)
    ok = _short(0, PIX_IN, fm) and _short(max(f_pix, f_breg), BIAS_IN, fm)
    ok = ok and _short(f_b, ROW_STATE, fm) and _short(max(f_p, f_c + fe), ROW_STATE, fm)
    ok = ok and _short(f_c + fe, ROW_R2, fm) and _short(f_p + int(consistent), ROW_R1, fm)
    ok = ok and _short(f_c + fe_c, COL_S2, fm) and _short(max(f_q, f_c + fe_c), COL_STATE, fm)
    ok = ok and _short(f_q + int(consistent), COL_S1, fm) and _short(f_r1, COL_STATE, fm)
    if consistent:
        ok = ok and _short(max(f_q2, f_c + fe_c2), COL2_STATE, fm)
        ok = ok and _short(f_q2 + 1, COL2_OUT, fm) and _short(f_r2, COL2_STATE, fm)
    return ok


@njit(cache=True, nogil=True)
def frontend_fused(
    img, pole, bias, consistent, init_first, kind, lut, r_bits, fm, st, dst, ov,
    out_e, out_ex, out_ey, taps, want_taps, log,
):  # fmt: skip
    """P1's front-end kernel (the same values, taps, counts and log), fused: bands of
    :data:`BAND` lines through the row filter (lines in SIMD lanes), then each line of
    the band through the column filter(s) and the x-derivative."""
    m, n = img.shape
    f_pix, f_breg, f_r1, f_r2 = fm[PIX_IN, 1], fm[BIAS_REG, 1], fm[ROW_R1, 1], fm[ROW_R2, 1]
    f_s1 = fm[COL_S1, 1]
    bias_al = _at(bias, f_breg, max(f_pix, f_breg))
    imgT = np.empty((n, BAND), dtype=np.int64)
    pT = np.empty(BAND, dtype=np.int64)
    bT, pnT = np.empty((n, BAND), dtype=np.int64), np.empty((n, BAND), dtype=np.int64)
    r1T, r2T = np.empty((n, BAND), dtype=np.int64), np.empty((n, BAND), dtype=np.int64)
    r1, r2 = np.empty((BAND, n), dtype=np.int64), np.empty((BAND, n), dtype=np.int64)
    lb1, lb2 = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    num = np.empty(n, dtype=np.int64)
    ex_flags = np.empty(n, dtype=np.bool_)
    for j0 in range(0, m, BAND):
        bw = min(BAND, m - j0)
        for k in range(bw):
            for i in range(n):
                imgT[i, k] = img[j0 + k, i]
        if log:
            if consistent:
                _row_band(imgT, bw, bias_al, pole, init_first, fm, st, ov, pT, bT, pnT, r1T,
                          r2T, True, True)  # fmt: skip
            else:
                _row_band(imgT, bw, bias_al, pole, init_first, fm, st, ov, pT, bT, pnT, r1T,
                          r2T, True, False)  # fmt: skip
        elif consistent:
            _row_band(imgT, bw, bias_al, pole, init_first, fm, st, ov, pT, bT, pnT, r1T, r2T,
                      False, True)  # fmt: skip
        else:
            _row_band(imgT, bw, bias_al, pole, init_first, fm, st, ov, pT, bT, pnT, r1T, r2T,
                      False, False)  # fmt: skip
        for k in range(bw):
            for i in range(n):
                r1[k, i] = r1T[i, k]
                r2[k, i] = r2T[i, k]
        for k in range(bw):
            j = j0 + k
            if j == 0 and init_first:
                lb1[:] = _cast_row(r1[k], f_r1, COL_STATE, 7, fm, st, ov)
                if consistent:
                    lb2[:] = _cast_row(r2[k], f_r2, COL2_STATE, 12, fm, st, ov)
            if log:
                if consistent:
                    _col_line(r1[k], r2[k], lb1, lb2, pole, fm, st, ov, out_e[j], out_ex[j],
                              out_ey[j], num, True, True)  # fmt: skip
                else:
                    _col_line(r1[k], r2[k], lb1, lb2, pole, fm, st, ov, out_e[j], out_ex[j],
                              out_ey[j], num, True, False)  # fmt: skip
            elif consistent:
                _col_line(r1[k], r2[k], lb1, lb2, pole, fm, st, ov, out_e[j], out_ex[j],
                          out_ey[j], num, False, True)  # fmt: skip
            else:
                _col_line(r1[k], r2[k], lb1, lb2, pole, fm, st, ov, out_e[j], out_ex[j],
                          out_ey[j], num, False, False)  # fmt: skip
            if not consistent:
                _divide_row(num, f_s1 + f_r2, r1[k], f_r1, DIV_QUOT, kind, lut, r_bits, fm,
                            dst, ov, out_ex[j], ex_flags)  # fmt: skip
            if want_taps:
                for i in range(n):
                    taps[0, j, i] = bT[i, k]
                    taps[3, j, i] = pnT[i, k]
                taps[1, j] = r1[k]
                taps[2, j] = r2[k]
                taps[4, j] = out_e[j]
                taps[5, j] = out_ey[j]
                taps[6, j] = lb1
                taps[7, j] = out_ex[j]
                if consistent:
                    taps[8, j] = lb2
