"""P1: the bit-accurate, cycle-faithful derivative-based ranging pipeline (SPEC §4).

Per stream, one pixel per clock in scan order: bias → row filter → column filter (line
buffer, read before write) → x-derivative (``paper``: the divider ``s1 r2 / r1``;
``consistent``: a second column filter on ``r2``); then the range stage of the obstacle
paper's eq 28 with per-frame registers and pixel counters, the thresholds, and range +
valid. ``docs/p1_datapath.md`` defines every signal; this module is the fast
implementation of that page (numba kernels on raw int64 values), and
``tests/oracle_p1.py`` an independent slow one.

Stereo mode runs two synchronised streams (E1 left, E2 right); motion mode one stream
carrying two frames, the first frame's stream outputs held in a frame store. The values
do not depend on timing; cycle stamps come from the input beats plus declared latencies.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from rangefx.golden.geometry import MotionIncrement, PinholeCamera, k_matrix
from rangefx.golden.ranging import RangingConfig

from ..config import TimingConfig
from ..fixedpoint import cast_by_plan, cast_modes, cast_shifted
from ..kernels import (
    at_frac,
    cast_row_site,
    cast_site,
    divide_lanes_fit,
    divide_row,
    divide_row_lanes,
    log_site,
    signal_plan,
)
from ..pipeline import Case, PipelineResult, build_result
from ..runtime import (
    DIV_RESTORING,
    KERNEL_BOOL,
    KERNEL_INT,
    KERNEL_PLANE,
    KERNEL_ROW,
    RegisterFile,
    SignalStats,
    check_image_pair,
    divider_latency,
    divider_setup,
    finish_band,
    format_table,
    kernel_image,
    run_two,
    scratch,
)
from ..stream import input_cycles, line_starts
from .config import P1_SIGNALS, P1Config

__all__ = [
    "BAND",
    "FRONTEND_TAPS",
    "N_SITES",
    "RANGE_TAPS",
    "FrameRegisters",
    "buffer_bits",
    "frame_registers",
    "frame_store_word",
    "frontend_fits",
    "frontend_fused",
    "line_buffer_words",
    "range_fits",
    "range_fused",
    "run_p1",
    "stage_latencies",
    "untranspose_band",
]

_I64_MAX, _I64_MIN = np.iinfo(np.int64).max, np.iinfo(np.int64).min
# short names of the argument types of the helpers with an explicit signature (see
# rangefx.rtl_model.runtime.KERNEL_INT: one compiled copy, not one per constant index)
_I, _B, _R, _P = KERNEL_INT, KERNEL_BOOL, KERNEL_ROW, KERNEL_PLANE
_SIG = {name: k for k, name in enumerate(P1_SIGNALS)}
PIX_IN, BIAS_IN, ROW_STATE, ROW_R1, ROW_R2 = (
    _SIG[s] for s in ("pix_in", "bias_in", "row_state", "row_r1", "row_r2")
)
COL_STATE, COL_S1, COL_S2, COL2_STATE, COL2_OUT, DIV_QUOT = (
    _SIG[s] for s in ("col_state", "col_s1", "col_s2", "col2_state", "col2_out", "div_quot")
)
C1, GRAD_A, GRAD_B, COORD, K_ROT, GEOM_V, GEOM_W = (
    _SIG[s] for s in ("c1", "grad_a", "grad_b", "coord", "k_rot", "geom_v", "geom_w")
)
GV, NUM, DEN, RANGE, V_SQ, GRAD_SQ = (
    _SIG[s] for s in ("gv", "num", "den", "range", "v_sq", "grad_sq")
)
# register formats (their frac bits are read by the kernels)
POLE_COEF, BIAS_REG, F_REG, K_T_REG, K_M_REG, TG2_REG = (
    _SIG[s] for s in ("pole_coef", "bias_reg", "f_reg", "k_t_reg", "k_m_reg", "tg2_reg")
)

#: Stream taps, per stream (prefix ``e1.`` / ``e2.``), in kernel order.
FRONTEND_TAPS = (
    "bias_in",
    "row_r1",
    "row_r2",
    "row_state",
    "col_s1",
    "col_s2",
    "col_state",
    "ex",
    "col2_state",
)
#: Range-stage taps.
RANGE_TAPS = (
    "xp",
    "yp",
    "c1",
    "a1",
    "b1",
    "k0",
    "k1",
    "k2",
    "vx",
    "vy",
    "wx",
    "wy",
    "w0",
    "gv",
    "num",
    "den",
    "range_q",
    "v_sq",
    "g_sq",
    "g_thr",
    "valid",
    "range",
)


# --------------------------------------------------------------------------------------
# kernels: raw int64 arithmetic only
# --------------------------------------------------------------------------------------
# short local names for the kernels below
_cast, _cast_row, _at, _divide_row = cast_site, cast_row_site, at_frac, divide_row


@njit(cache=True, nogil=True, inline="always")
def _row_filter_loop(b, p0, pole, f_b, site, fm, st, ov, prod_out, p_prev, p_next, short):
    """The loop of :func:`_row_filter`; ``short`` (constant per call) as in
    :func:`~rangefx.rtl_model.fixedpoint.cast_shifted`."""
    f_p, f_c = fm[ROW_STATE, 1], fm[POLE_COEF, 1]
    word, frac, sgn = fm[ROW_STATE, 0], fm[ROW_STATE, 1], fm[ROW_STATE, 2] != 0
    quant, ovf = fm[ROW_STATE, 3], fm[ROW_STATE, 4]
    fe = max(f_b, f_p)
    fs = max(f_p, f_c + fe)
    lo, hi, count = st[site, 0], st[site, 1], np.int64(0)
    p = p0
    for i in range(b.shape[0]):
        prod = pole * (_at(b[i], f_b, fe) - _at(p, f_p, fe))
        pre = _at(p, f_p, fs) + _at(prod, f_c + fe, fs)
        lo = min(lo, pre)
        hi = max(hi, pre)
        p_prev[i] = p
        prod_out[i] = prod
        p, flag = cast_shifted(pre, fs - frac, word, sgn, quant, ovf, short)
        count += flag
        p_next[i] = p
    st[site, 0], st[site, 1], st[site, 2], st[site, 3] = lo, hi, fs, ROW_STATE
    ov[ROW_STATE] += count


@njit((_R, _I, _I, _I, _I, _P, _P, _R, _R, _R, _R), cache=True, nogil=True)
def _row_filter(b, p0, pole, f_b, site, fm, st, ov, prod_out, p_prev, p_next):
    """The row filter's recursion along one line (state ``p0`` at column 0).

    Only the state is serial: this loop casts ``p_next`` (logged at ``site``) and leaves
    the products ``C (b - p)`` in ``prod_out`` and the states before and after each
    column in ``p_prev``, ``p_next``, from which ``r2`` and ``r1`` are cast as rows.
    """
    f_p, f_c = fm[ROW_STATE, 1], fm[POLE_COEF, 1]
    shift = max(f_p, f_c + max(f_b, f_p)) - f_p
    # the cast's shift case is decided once per line: the common 0..62 loop carries only
    # its few instructions on the state's dependency chain (measured 8.7 vs 12.9 ns/pixel)
    if 0 <= shift <= 62:
        _row_filter_loop(b, p0, pole, f_b, site, fm, st, ov, prod_out, p_prev, p_next, True)
    else:
        _row_filter_loop(b, p0, pole, f_b, site, fm, st, ov, prod_out, p_prev, p_next, False)


@njit(cache=True, nogil=True)
def _frontend_kernel(
    img, pole, bias, consistent, init_first, kind, lut, r_bits, fm, st, dst, ov,
    out_e, out_ex, out_ey, taps, want_taps,
):  # fmt: skip
    """One stream: bias → row filter → column filter(s) → x-derivative, scan order.

    Row by row: every signal of a line is a vector and each cast one loop over it (the
    values equal a pixel-by-pixel run: only the row filter's state is serial along a
    line, and the column filters' states live in the line buffers).
    """
    m, n = img.shape
    f_pix, f_b, f_p = fm[PIX_IN, 1], fm[BIAS_IN, 1], fm[ROW_STATE, 1]
    f_r1, f_r2, f_q = fm[ROW_R1, 1], fm[ROW_R2, 1], fm[COL_STATE, 1]
    f_s1, f_q2, f_c = fm[COL_S1, 1], fm[COL2_STATE, 1], fm[POLE_COEF, 1]
    f_breg = fm[BIAS_REG, 1]
    lb1 = np.zeros(n, dtype=np.int64)  # line buffer of the column filter on r1
    lb2 = np.zeros(n, dtype=np.int64)  # consistent: line buffer of the column filter on r2
    fx = max(f_pix, f_breg)
    fe_row = max(f_b, f_p)
    fe_col = max(f_r1, f_q)
    fs_col = max(f_q, f_c + fe_col)
    fe_col2 = max(f_r2, f_q2)
    fs_col2 = max(f_q2, f_c + fe_col2)
    prod_row = np.empty(n, dtype=np.int64)
    p_prev = np.empty(n, dtype=np.int64)
    p_next = np.empty(n, dtype=np.int64)
    ex = np.empty(n, dtype=np.int64)
    ex_flags = np.empty(n, dtype=np.bool_)
    q2_next = np.zeros(n, dtype=np.int64)
    for j in range(m):
        x = _cast_row(img[j], 0, PIX_IN, 0, fm, st, ov)
        b = _cast_row(_at(x, f_pix, fx) + _at(bias, f_breg, fx), fx, BIAS_IN, 1, fm, st, ov)
        # row filter (one state register per line)
        p0 = _cast(b[0], f_b, ROW_STATE, 2, fm, st, ov) if init_first else np.int64(0)
        _row_filter(b, p0, pole, f_b, 4, fm, st, ov, prod_row, p_prev, p_next)
        r2 = _cast_row(prod_row, f_c + fe_row, ROW_R2, 3, fm, st, ov)
        if consistent:
            r1 = _cast_row(p_prev + p_next, f_p + 1, ROW_R1, 5, fm, st, ov)
        else:
            r1 = _cast_row(p_prev, f_p, ROW_R1, 6, fm, st, ov)
        # column filter on r1: read the line buffer, update, write back
        if j == 0:
            if init_first:
                lb1[:] = _cast_row(r1, f_r1, COL_STATE, 7, fm, st, ov)
        q = lb1  # the line buffer's read; the write-back below rebinds it (no copy)
        prod = pole * (_at(r1, f_r1, fe_col) - _at(q, f_q, fe_col))
        s2 = _cast_row(prod, f_c + fe_col, COL_S2, 8, fm, st, ov)
        q_next = _cast_row(_at(q, f_q, fs_col) + _at(prod, f_c + fe_col, fs_col), fs_col,
                           COL_STATE, 9, fm, st, ov)  # fmt: skip
        if consistent:
            s1 = _cast_row(q + q_next, f_q + 1, COL_S1, 10, fm, st, ov)
        else:
            s1 = _cast_row(q, f_q, COL_S1, 11, fm, st, ov)
        lb1 = q_next
        if consistent:
            if j == 0:
                if init_first:
                    lb2[:] = _cast_row(r2, f_r2, COL2_STATE, 12, fm, st, ov)
            q2 = lb2
            prod = pole * (_at(r2, f_r2, fe_col2) - _at(q2, f_q2, fe_col2))
            q2_next = _cast_row(_at(q2, f_q2, fs_col2) + _at(prod, f_c + fe_col2, fs_col2),
                                fs_col2, COL2_STATE, 13, fm, st, ov)  # fmt: skip
            lb2 = q2_next
            ex = _cast_row(q2 + q2_next, f_q2 + 1, COL2_OUT, 14, fm, st, ov)
        else:
            _divide_row(s1 * r2, f_s1 + f_r2, r1, f_r1, DIV_QUOT, kind, lut, r_bits, fm, dst,
                        ov, ex, ex_flags)  # fmt: skip
        out_e[j] = s1
        out_ex[j] = ex
        out_ey[j] = s2
        if want_taps:
            taps[0, j] = b
            taps[1, j] = r1
            taps[2, j] = r2
            taps[3, j] = p_next
            taps[4, j] = s1
            taps[5, j] = s2
            taps[6, j] = q_next
            taps[7, j] = ex
            taps[8, j] = q2_next


# --------------------------------------------------------------------------------------
# the fused front end (issue 18): the values, taps, overflow counts and min/max log of
# _frontend_kernel in less time. Every cast of a pixel of a stage is in one loop body,
# branch-free (cast_by_plan), without array temporaries; the row filter's recursion runs
# along a line, so its loop runs over a band of lines (SIMD lanes) for one column at a
# time; the column filters run along the line. Used whenever every front-end cast
# shifts by at most 62 bits (frontend_fits: every real config); _frontend_kernel is the
# path for the others. The variant and ``log`` are runtime flags of one compiled body:
# specialising the loops on them as literals (four inlined copies) cost 202 s of CPU to
# compile against 65 s for one, for 6 % of the paper variant's run time (A/B in
# docs/performance.md).
# --------------------------------------------------------------------------------------
#: Lines per band of the row filter (its SIMD lanes: two AVX-512 vectors of int64 per
#: independent recursion chain in flight, measured best of 8/16/32).
BAND = 16


@njit((_I, _I, _P), cache=True, nogil=True)
def _short(frac_in, s, fm):
    """Whether the fused kernels take a cast into ``s`` (``|shift| <= 62``)."""
    return abs(frac_in - fm[s, 1]) <= 62


@njit(cache=True, nogil=True, inline="always")
def untranspose_band(src_t, dst, bw, n):
    """``dst[k, i] = src_t[i, k]`` for lanes ``k < bw`` and columns ``i < n``: a band's
    column-major lanes back to scan order, in tiles of 8 columns (a tile reads 8 lane
    rows that stay in L1; column after column, every lane row came from L2 once per line:
    0.63 -> 0.46 ns per element, measured on a 512 x 16 band)."""
    n8 = n - n % 8
    for i0 in range(0, n8, 8):
        for k in range(bw):
            for ii in range(8):
                dst[k, i0 + ii] = src_t[i0 + ii, k]
    for k in range(bw):
        for i in range(n8, n):
            dst[k, i] = src_t[i, k]


@njit(cache=True, nogil=True, inline="always")
def _row_band(
    imgT, bw, bias_al, pole, init_first, fm, st, ov, pT, bT, pnT, r1T, r2T, log, consistent,
    t_step, modes,
):  # fmt: skip
    """Input cast, bias, row filter and ``r1``/``r2`` of lines ``0 <= k < bw`` of a band in
    column-major layout (``imgT[i, k]``): for each column one loop over the lines (the
    lanes), each carrying its own row-filter state in ``pT``. ``b`` and the state go to
    row ``i * t_step`` of ``bT`` / ``pnT`` (the taps; ``t_step = 0`` without taps: one
    row, no branch)."""
    n = imgT.shape[0]
    f_pix, f_b, f_p = fm[PIX_IN, 1], fm[BIAS_IN, 1], fm[ROW_STATE, 1]
    f_c, f_breg = fm[POLE_COEF, 1], fm[BIAS_REG, 1]
    fx = max(f_pix, f_breg)
    fe = max(f_b, f_p)
    fs = max(f_p, f_c + fe)
    pl_x, pl_b, pl_p0 = (
        signal_plan(0, PIX_IN, fm),
        signal_plan(fx, BIAS_IN, fm),
        signal_plan(f_b, ROW_STATE, fm),
    )
    pl_p, pl_r2 = signal_plan(fs, ROW_STATE, fm), signal_plan(f_c + fe, ROW_R2, fm)
    pl_r1 = signal_plan(f_p + 1, ROW_R1, fm) if consistent else signal_plan(f_p, ROW_R1, fm)
    big, small = np.int64(_I64_MAX), np.int64(_I64_MIN)
    lo0, hi0, lo1, hi1, lo2, hi2, lo3, hi3 = big, small, big, small, big, small, big, small
    lo4, hi4, lo5, hi5 = big, small, big, small
    c_x, c_b, c_p, c_r2, c_r1 = 0, 0, 0, 0, 0
    # the initial state of every line: its first b (logged at site 2), or zero
    for k in range(bw):
        raw = imgT[0, k]
        x, _ = cast_by_plan(raw, pl_x, modes)
        b, _ = cast_by_plan((x << (fx - f_pix)) + bias_al, pl_b, modes)
        p0, flag = cast_by_plan(b, pl_p0, modes)
        lo2, hi2 = min(lo2, b), max(hi2, b)
        c_p += flag
        pT[k] = p0 if init_first else np.int64(0)
    if not init_first:
        lo2, hi2 = big, small
        c_p = 0
    for i in range(n):
        for k in range(bw):
            raw = imgT[i, k]
            x, f0 = cast_by_plan(raw, pl_x, modes)
            bsum = (x << (fx - f_pix)) + bias_al
            b, f1 = cast_by_plan(bsum, pl_b, modes)
            p = pT[k]
            prod = pole * ((b << (fe - f_b)) - (p << (fe - f_p)))
            pre = (p << (fs - f_p)) + (prod << (fs - f_c - fe))
            p_new, f2 = cast_by_plan(pre, pl_p, modes)
            r2, f3 = cast_by_plan(prod, pl_r2, modes)
            r1_in = p + p_new if consistent else p
            r1, f4 = cast_by_plan(r1_in, pl_r1, modes)
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
            bT[i * t_step, k] = b
            pnT[i * t_step, k] = p_new
            r1T[i, k] = r1
            r2T[i, k] = r2
    ov[PIX_IN] += c_x
    ov[BIAS_IN] += c_b
    ov[ROW_STATE] += c_p
    ov[ROW_R2] += c_r2
    ov[ROW_R1] += c_r1
    if init_first:
        log_site(st, 2, lo2, hi2, f_b, ROW_STATE)
    if log:
        log_site(st, 0, lo0, hi0, 0, PIX_IN)
        log_site(st, 1, lo1, hi1, fx, BIAS_IN)
        log_site(st, 3, lo3, hi3, f_c + fe, ROW_R2)
        log_site(st, 4, lo4, hi4, fs, ROW_STATE)
        if consistent:
            log_site(st, 5, lo5, hi5, f_p + 1, ROW_R1)
        else:
            log_site(st, 6, lo5, hi5, f_p, ROW_R1)


@njit(cache=True, nogil=True, inline="always")
def _col_line(
    r1, r2, lb1, lb2, pole, fm, st, ov, out_e, out_ex, out_ey, num, log, consistent, modes,
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
    pl_s2, pl_q = signal_plan(f_c + fe, COL_S2, fm), signal_plan(fs, COL_STATE, fm)
    pl_s1 = signal_plan(f_q + 1, COL_S1, fm) if consistent else signal_plan(f_q, COL_S1, fm)
    pl_q2, pl_ex = signal_plan(fs2, COL2_STATE, fm), signal_plan(f_q2 + 1, COL2_OUT, fm)
    big, small = np.int64(_I64_MAX), np.int64(_I64_MIN)
    lo8, hi8, lo9, hi9, lo10, hi10 = big, small, big, small, big, small
    lo13, hi13, lo14, hi14 = big, small, big, small
    c_s2, c_q, c_s1, c_q2, c_ex = 0, 0, 0, 0, 0
    for i in range(n):
        r1v = r1[i]
        q = lb1[i]
        prod = pole * ((r1v << (fe - f_r1)) - (q << (fe - f_q)))
        s2, f0 = cast_by_plan(prod, pl_s2, modes)
        qs = (q << (fs - f_q)) + (prod << (fs - f_c - fe))
        q_next, f1 = cast_by_plan(qs, pl_q, modes)
        s1_in = q + q_next if consistent else q
        s1, f2 = cast_by_plan(s1_in, pl_s1, modes)
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
            q2n, f3 = cast_by_plan(qs2, pl_q2, modes)
            ex_in = q2 + q2n
            ex, f4 = cast_by_plan(ex_in, pl_ex, modes)
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
        log_site(st, 8, lo8, hi8, f_c + fe, COL_S2)
        log_site(st, 9, lo9, hi9, fs, COL_STATE)
        if consistent:
            log_site(st, 10, lo10, hi10, f_q + 1, COL_S1)
            log_site(st, 13, lo13, hi13, fs2, COL2_STATE)
            log_site(st, 14, lo14, hi14, f_q2 + 1, COL2_OUT)
        else:
            log_site(st, 11, lo10, hi10, f_q, COL_S1)


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
    out_e, out_ex, out_ey, taps, want_taps, log, modes,
):  # fmt: skip
    """P1's front-end kernel (the same values, taps, counts and log), fused: bands of
    :data:`BAND` lines through the row filter (lines in SIMD lanes), then each line of
    the band through the column filter(s) and the x-derivative. ``modes``: the casts'
    body (:func:`~rangefx.rtl_model.fixedpoint.cast_modes` of ``fm``)."""
    m, n = img.shape
    f_pix, f_breg, f_r1, f_r2 = fm[PIX_IN, 1], fm[BIAS_REG, 1], fm[ROW_R1, 1], fm[ROW_R2, 1]
    f_s1 = fm[COL_S1, 1]
    bias_al = _at(bias, f_breg, max(f_pix, f_breg))
    imgT = np.empty((n, BAND), dtype=np.int64)
    pT = np.empty(BAND, dtype=np.int64)
    # the row stage's b and state are only taps: without taps one row, overwritten
    t_step, nt = (1, n) if want_taps else (0, 1)
    bT, pnT = np.empty((nt, BAND), dtype=np.int64), np.empty((nt, BAND), dtype=np.int64)
    r1T, r2T = np.empty((n, BAND), dtype=np.int64), np.empty((n, BAND), dtype=np.int64)
    r1, r2 = np.empty((BAND, n), dtype=np.int64), np.empty((BAND, n), dtype=np.int64)
    lb1, lb2 = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    num = np.empty(n, dtype=np.int64)
    ex_flags = np.empty(n, dtype=np.bool_)
    div_lanes = kind != DIV_RESTORING and divide_lanes_fit(f_s1 + f_r2, f_r1, fm[ROW_R1, 0],
                                                           DIV_QUOT, r_bits, fm)  # fmt: skip
    for j0 in range(0, m, BAND):
        bw = min(BAND, m - j0)
        for k in range(bw):
            for i in range(n):
                imgT[i, k] = img[j0 + k, i]
        _row_band(imgT, bw, bias_al, pole, init_first, fm, st, ov, pT, bT, pnT, r1T, r2T, log,
                  consistent, t_step, modes)  # fmt: skip
        untranspose_band(r1T, r1, bw, n)
        untranspose_band(r2T, r2, bw, n)
        for k in range(bw):
            j = j0 + k
            if j == 0 and init_first:
                lb1[:] = _cast_row(r1[k], f_r1, COL_STATE, 7, fm, st, ov)
                if consistent:
                    lb2[:] = _cast_row(r2[k], f_r2, COL2_STATE, 12, fm, st, ov)
            _col_line(r1[k], r2[k], lb1, lb2, pole, fm, st, ov, out_e[j], out_ex[j], out_ey[j],
                      num, log, consistent, modes)  # fmt: skip
            if consistent:
                pass
            elif div_lanes:
                divide_row_lanes(num, f_s1 + f_r2, r1[k], f_r1, DIV_QUOT, lut, r_bits, fm, dst,
                                 ov, out_ex[j], ex_flags, log, modes)  # fmt: skip
            else:
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


@njit(cache=True, nogil=True, inline="always")
def _rotation_row(mreg, r, m_xp, yp, f_km, f_co):
    """``M_r0 + M_r1 xp + M_r2 yp`` exactly, at ``max(F_M, F_M + F_coord)`` fraction bits,
    from ``m_xp = M_r1 xp`` at those bits (a column term: computed once per band)."""
    f_k = max(f_km, f_km + f_co)
    return m_xp + (_at(mreg[r, 0], f_km, f_k) + _at(mreg[r, 2] * yp, f_km + f_co, f_k))


@njit(cache=True, nogil=True)
def _range_fracs(fm):
    """Fraction bits at which the range stage's exact sums are aligned (docs/p1_datapath.md):
    ``(f_k, f_gvv, f_gww, f_gvs, f_ns, f_ds, f_co0, f_w0)``."""
    f_co, f_c1, f_a, f_b = fm[COORD, 1], fm[C1, 1], fm[GRAD_A, 1], fm[GRAD_B, 1]
    f_f, f_kt, f_km, f_kr = fm[F_REG, 1], fm[K_T_REG, 1], fm[K_M_REG, 1], fm[K_ROT, 1]
    f_v, f_w, f_gv = fm[GEOM_V, 1], fm[GEOM_W, 1], fm[GV, 1]
    f_k = max(f_km, f_km + f_co)
    f_gvv = max(f_f + f_kt, f_co + f_kt)
    f_gww = max(f_f + f_kr, f_co + f_kr)
    f_gvs = max(f_a + f_v, f_b + f_v)
    f_ns = max(f_kt + f_c1, f_gv)
    f_ds = max(f_a + f_w, f_b + f_w, f_c1 + f_w)
    f_co0 = max(f_co, 0)  # pixel counters are integers: align at >= 0 fraction bits
    f_w0 = max(f_kr, 0)
    return f_k, f_gvv, f_gww, f_gvs, f_ns, f_ds, f_co0, f_w0


@njit(cache=True, nogil=True)
def _range_columns(n, regs, mreg, fm, st, ov, rows):
    """The range stage's column terms, computed once for a band of ``rows`` lines: ``xp``,
    ``vx`` (cast once, their overflows counted for every line, as a pixel-by-pixel run
    counts them), the exact rotation terms ``M_r1 xp`` (3, n) and ``vx^2``."""
    cx, fr, k3, k4 = regs[0], regs[2], regs[3], regs[4]
    f_co, f_f, f_kt, f_km = fm[COORD, 1], fm[F_REG, 1], fm[K_T_REG, 1], fm[K_M_REG, 1]
    f_k, f_gvv, _, _, _, _, f_co0, _ = _range_fracs(fm)
    cols = np.arange(n).astype(np.int64)
    ov_x, ov_v = ov[COORD], ov[GEOM_V]
    xp = _cast_row(_at(cols, 0, f_co0) - _at(cx, f_co, f_co0), f_co0, COORD, 16, fm, st, ov)
    vx = _cast_row(_at(fr * k4, f_f + f_kt, f_gvv) - _at(xp * k3, f_co + f_kt, f_gvv), f_gvv,
                   GEOM_V, 21, fm, st, ov)  # fmt: skip
    ov[COORD] += (ov[COORD] - ov_x) * (rows - 1)
    ov[GEOM_V] += (ov[GEOM_V] - ov_v) * (rows - 1)
    m_xp = np.empty((3, n), dtype=np.int64)
    for r in range(3):
        m_xp[r] = _at(mreg[r, 1] * xp, f_km + f_co, f_k)
    return xp, vx, m_xp, vx * vx


@njit(cache=True, nogil=True)
def _range_line(j, n, regs, fm, st, ov):
    """The line terms of line ``j``: ``yp`` and ``vy``, held for the line but, like ``xp``,
    cast (and counted) once per pixel."""
    cy, fr, k3, k5 = regs[1], regs[2], regs[3], regs[5]
    f_co, f_f, f_kt = fm[COORD, 1], fm[F_REG, 1], fm[K_T_REG, 1]
    _, f_gvv, _, _, _, _, f_co0, _ = _range_fracs(fm)
    ov_co = ov[COORD]
    yp = _cast(_at(np.int64(j), 0, f_co0) - _at(cy, f_co, f_co0), f_co0, COORD, 15, fm, st, ov)
    ov[COORD] += (ov[COORD] - ov_co) * (n - 1)
    ov_vy = ov[GEOM_V]
    vy = _cast(_at(fr * k5, f_f + f_kt, f_gvv) - _at(yp * k3, f_co + f_kt, f_gvv), f_gvv,
               GEOM_V, 22, fm, st, ov)  # fmt: skip
    ov[GEOM_V] += (ov[GEOM_V] - ov_vy) * (n - 1)
    return yp, vy


@njit(cache=True, nogil=True)
def _range_kernel(
    e1, ex1, ey1, e2, ex2, ey2, regs, mreg, f_ex, kind, lut, r_bits, fm, st, dst, ov,
    j0, j1, out_range, out_valid, taps, want_taps,
):  # fmt: skip
    """Eq 28 per pixel for rows ``j0 <= j < j1`` (docs/p1_datapath.md, range stage);
    every signal of a line is a vector, each cast one loop. The path with taps, and of
    configs :func:`range_fits` rejects; :func:`range_fused` is the other."""
    n = e1.shape[1]
    fr, k3, te, tg2, dmin, rmax = regs[2], regs[3], regs[6], regs[7], regs[8], regs[9]
    f_co, f_s1, f_ey = fm[COORD, 1], fm[COL_S1, 1], fm[COL_S2, 1]
    f_c1, f_a, f_b = fm[C1, 1], fm[GRAD_A, 1], fm[GRAD_B, 1]
    f_f, f_kt, f_km, f_kr = fm[F_REG, 1], fm[K_T_REG, 1], fm[K_M_REG, 1], fm[K_ROT, 1]
    f_v, f_w, f_gv, f_num, f_den = fm[GEOM_V, 1], fm[GEOM_W, 1], fm[GV, 1], fm[NUM, 1], fm[DEN, 1]
    f_vsq, f_tg2 = fm[V_SQ, 1], fm[TG2_REG, 1]
    f_k, _, f_gww, f_gvs, f_ns, f_ds, _, f_w0 = _range_fracs(fm)
    one_den = np.int64(1) << f_den
    rq = np.empty(n, dtype=np.int64)
    dovf = np.empty(n, dtype=np.bool_)
    if j1 <= j0:
        return
    xp, vx, m_xp, vx_sq = _range_columns(n, regs, mreg, fm, st, ov, j1 - j0)
    for j in range(j0, j1):
        yp, vy = _range_line(j, n, regs, fm, st, ov)
        c1 = _cast_row(e1[j] - e2[j], f_s1, C1, 17, fm, st, ov)
        a1 = _cast_row(ex1[j] + ex2[j], f_ex + 1, GRAD_A, 18, fm, st, ov)
        b1 = _cast_row(ey1[j] + ey2[j], f_ey + 1, GRAD_B, 19, fm, st, ov)
        k0 = _cast_row(_rotation_row(mreg, 0, m_xp[0], yp, f_km, f_co), f_k, K_ROT, 20, fm, st, ov)
        k1 = _cast_row(_rotation_row(mreg, 1, m_xp[1], yp, f_km, f_co), f_k, K_ROT, 20, fm, st, ov)
        k2 = _cast_row(_rotation_row(mreg, 2, m_xp[2], yp, f_km, f_co), f_k, K_ROT, 20, fm, st, ov)
        wx = _cast_row(_at(fr * k1, f_f + f_kr, f_gww) - _at(xp * k0, f_co + f_kr, f_gww), f_gww,
                       GEOM_W, 23, fm, st, ov)  # fmt: skip
        wy = _cast_row(_at(fr * k2, f_f + f_kr, f_gww) - _at(yp * k0, f_co + f_kr, f_gww), f_gww,
                       GEOM_W, 24, fm, st, ov)  # fmt: skip
        w0 = _cast_row(_at(np.int64(1), 0, f_w0) + _at(k0, f_kr, f_w0), f_w0, GEOM_W, 25, fm, st,
                       ov)  # fmt: skip
        gv = _cast_row(_at(a1 * vx, f_a + f_v, f_gvs) + _at(b1 * vy, f_b + f_v, f_gvs), f_gvs,
                       GV, 26, fm, st, ov)  # fmt: skip
        num = _cast_row(_at(k3 * c1, f_kt + f_c1, f_ns) - _at(gv, f_gv, f_ns), f_ns, NUM, 27, fm,
                        st, ov)  # fmt: skip
        den = _cast_row(_at(a1 * wx, f_a + f_w, f_ds) + _at(b1 * wy, f_b + f_w, f_ds)
                        - _at(c1 * w0, f_c1 + f_w, f_ds), f_ds, DEN, 28, fm, st, ov)  # fmt: skip
        # the divider is fed (0, 1) where |den| < DMIN: the pixel is invalid anyway, and
        # tiny denominators would only saturate the quotient
        den_ok = (np.abs(den) >= dmin) & (den != 0)
        _divide_row(np.where(den_ok, num, 0), f_num, np.where(den_ok, den, one_den), f_den, RANGE,
                    kind, lut, r_bits, fm, dst, ov, rq, dovf)  # fmt: skip
        v_sq = _cast_row(vx_sq + vy * vy, 2 * f_v, V_SQ, 29, fm, st, ov)
        g_sq = _cast_row(gv * gv, 2 * f_gv, GRAD_SQ, 30, fm, st, ov)
        g_thr = _cast_row(tg2 * v_sq, f_tg2 + f_vsq, GRAD_SQ, 31, fm, st, ov)
        ok = ((np.abs(c1) >= te) & (g_sq >= g_thr) & den_ok & ~dovf & (rq > 0)
              & (rq <= rmax))  # fmt: skip
        out_valid[j] = ok
        out_range[j] = np.where(ok, rq, rmax)
        if want_taps:
            for t, row in enumerate((xp, np.full(n, yp), c1, a1, b1, k0, k1, k2, vx,
                                     np.full(n, vy), wx, wy, w0, gv, num, den, rq)):  # fmt: skip
                taps[t, j] = row
            taps[17, j] = v_sq
            taps[18, j] = g_sq
            taps[19, j] = g_thr
            taps[20, j] = ok.astype(np.int64)
            taps[21, j] = out_range[j]


@njit(cache=True, nogil=True)
def range_fits(fm, f_ex, r_bits, kind):
    """Whether :func:`range_fused` takes a config: every cast of the range stage shifts by
    at most 62 bits (:func:`cast_by_plan`); a reciprocal divider also needs
    :func:`divide_lanes_fit` (a restoring one divides row by row, :func:`divide_row`)."""
    f_k, _, f_gww, f_gvs, f_ns, f_ds, _, f_w0 = _range_fracs(fm)
    f_v, f_gv, f_vsq, f_tg2 = fm[GEOM_V, 1], fm[GV, 1], fm[V_SQ, 1], fm[TG2_REG, 1]
    ok = _short(fm[COL_S1, 1], C1, fm) and _short(f_ex + 1, GRAD_A, fm)
    ok = ok and _short(fm[COL_S2, 1] + 1, GRAD_B, fm) and _short(f_k, K_ROT, fm)
    ok = ok and _short(f_gww, GEOM_W, fm) and _short(f_w0, GEOM_W, fm) and _short(f_gvs, GV, fm)
    ok = ok and _short(f_ns, NUM, fm) and _short(f_ds, DEN, fm) and _short(2 * f_v, V_SQ, fm)
    ok = ok and _short(2 * f_gv, GRAD_SQ, fm) and _short(f_tg2 + f_vsq, GRAD_SQ, fm)
    if kind != DIV_RESTORING:
        # the divider sees den (its word) or the 2**F_den fed where |den| < DMIN
        d_word = max(fm[DEN, 0], fm[DEN, 1] + 1)
        ok = ok and divide_lanes_fit(fm[NUM, 1], fm[DEN, 1], d_word, RANGE, r_bits, fm)
    return ok


@njit(cache=True, nogil=True)
def range_fused(
    e1, ex1, ey1, e2, ex2, ey2, regs, mreg, f_ex, kind, lut, r_bits, fm, st, dst, ov,
    j0, j1, out_range, out_valid, log, modes,
):  # fmt: skip
    """:func:`_range_kernel` without taps (the same outputs, overflow counts and, with
    ``log``, min/max), fused: every cast of a pixel up to ``num``/``den`` and the
    thresholds in one branch-free loop along the line (SIMD lanes; no array temporaries),
    then the divider's row (:func:`divide_row_lanes`), then valid and range. ``modes``:
    the casts' body (:func:`~rangefx.rtl_model.fixedpoint.cast_modes` of ``fm``)."""
    n = e1.shape[1]
    fr, k3, te, tg2, dmin, rmax = regs[2], regs[3], regs[6], regs[7], regs[8], regs[9]
    f_co, f_s1, f_ey = fm[COORD, 1], fm[COL_S1, 1], fm[COL_S2, 1]
    f_c1, f_a, f_b = fm[C1, 1], fm[GRAD_A, 1], fm[GRAD_B, 1]
    f_f, f_kt, f_km, f_kr = fm[F_REG, 1], fm[K_T_REG, 1], fm[K_M_REG, 1], fm[K_ROT, 1]
    f_v, f_w, f_gv, f_num, f_den = fm[GEOM_V, 1], fm[GEOM_W, 1], fm[GV, 1], fm[NUM, 1], fm[DEN, 1]
    f_vsq, f_tg2 = fm[V_SQ, 1], fm[TG2_REG, 1]
    f_k, _, f_gww, f_gvs, f_ns, f_ds, _, f_w0 = _range_fracs(fm)
    if j1 <= j0:
        return
    xp, vx, m_xp, vx_sq = _range_columns(n, regs, mreg, fm, st, ov, j1 - j0)
    m0, m1, m2 = m_xp[0], m_xp[1], m_xp[2]
    pl_c1, pl_a = signal_plan(f_s1, C1, fm), signal_plan(f_ex + 1, GRAD_A, fm)
    pl_b, pl_k = signal_plan(f_ey + 1, GRAD_B, fm), signal_plan(f_k, K_ROT, fm)
    pl_w, pl_w0, pl_gv = (
        signal_plan(f_gww, GEOM_W, fm),
        signal_plan(f_w0, GEOM_W, fm),
        signal_plan(f_gvs, GV, fm),
    )
    pl_num, pl_den, pl_vsq = (
        signal_plan(f_ns, NUM, fm),
        signal_plan(f_ds, DEN, fm),
        signal_plan(2 * f_v, V_SQ, fm),
    )
    pl_gsq, pl_thr = signal_plan(2 * f_gv, GRAD_SQ, fm), signal_plan(f_tg2 + f_vsq, GRAD_SQ, fm)
    # the exact sums' alignments (shifts of _at)
    s_wf, s_wx, s_w0 = f_gww - f_f - f_kr, f_gww - f_co - f_kr, f_w0 - f_kr
    s_ga, s_gb, s_nk, s_ng = f_gvs - f_a - f_v, f_gvs - f_b - f_v, f_ns - f_kt - f_c1, f_ns - f_gv
    s_da, s_db, s_dc = f_ds - f_a - f_w, f_ds - f_b - f_w, f_ds - f_c1 - f_w
    w0_one, one_den = np.int64(1) << f_w0, np.int64(1) << f_den
    lanes = kind != DIV_RESTORING
    nums, dens = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    pre = np.empty(n, dtype=np.bool_)
    rq, dovf = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.bool_)
    big, small = np.int64(_I64_MAX), np.int64(_I64_MIN)
    l17, h17, l18, h18, l19, h19, l20, h20 = big, small, big, small, big, small, big, small
    l23, h23, l24, h24, l25, h25, l26, h26 = big, small, big, small, big, small, big, small
    l27, h27, l28, h28, l29, h29 = big, small, big, small, big, small
    l30, h30, l31, h31 = big, small, big, small
    c_c1, c_a, c_b, c_k, c_w = 0, 0, 0, 0, 0
    c_gv, c_num, c_den, c_vsq, c_gsq = 0, 0, 0, 0, 0
    for j in range(j0, j1):
        yp, vy = _range_line(j, n, regs, fm, st, ov)
        kc0 = _at(mreg[0, 0], f_km, f_k) + _at(mreg[0, 2] * yp, f_km + f_co, f_k)
        kc1 = _at(mreg[1, 0], f_km, f_k) + _at(mreg[1, 2] * yp, f_km + f_co, f_k)
        kc2 = _at(mreg[2, 0], f_km, f_k) + _at(mreg[2, 2] * yp, f_km + f_co, f_k)
        vy_sq = vy * vy
        e1j, e2j, ex1j, ex2j, ey1j, ey2j = e1[j], e2[j], ex1[j], ex2[j], ey1[j], ey2[j]
        for i in range(n):
            c1_in, a_in, b_in = e1j[i] - e2j[i], ex1j[i] + ex2j[i], ey1j[i] + ey2j[i]
            c1, f0 = cast_by_plan(c1_in, pl_c1, modes)
            a1, f1 = cast_by_plan(a_in, pl_a, modes)
            b1, f2 = cast_by_plan(b_in, pl_b, modes)
            k0_in, k1_in, k2_in = m0[i] + kc0, m1[i] + kc1, m2[i] + kc2
            k0, f3 = cast_by_plan(k0_in, pl_k, modes)
            k1, f4 = cast_by_plan(k1_in, pl_k, modes)
            k2, f5 = cast_by_plan(k2_in, pl_k, modes)
            wx_in = ((fr * k1) << s_wf) - ((xp[i] * k0) << s_wx)
            wy_in = ((fr * k2) << s_wf) - ((yp * k0) << s_wx)
            w0_in = w0_one + (k0 << s_w0)
            wx, f6 = cast_by_plan(wx_in, pl_w, modes)
            wy, f7 = cast_by_plan(wy_in, pl_w, modes)
            w0, f8 = cast_by_plan(w0_in, pl_w0, modes)
            gv_in = ((a1 * vx[i]) << s_ga) + ((b1 * vy) << s_gb)
            gv, f9 = cast_by_plan(gv_in, pl_gv, modes)
            num_in = ((k3 * c1) << s_nk) - (gv << s_ng)
            num, f10 = cast_by_plan(num_in, pl_num, modes)
            den_in = ((a1 * wx) << s_da) + ((b1 * wy) << s_db) - ((c1 * w0) << s_dc)
            den, f11 = cast_by_plan(den_in, pl_den, modes)
            vsq_in = vx_sq[i] + vy_sq
            v_sq, f12 = cast_by_plan(vsq_in, pl_vsq, modes)
            gsq_in = gv * gv
            g_sq, f13 = cast_by_plan(gsq_in, pl_gsq, modes)
            thr_in = tg2 * v_sq
            g_thr, f14 = cast_by_plan(thr_in, pl_thr, modes)
            # the divider is fed (0, 1) where |den| < DMIN, as in _range_kernel
            den_ok = (abs(den) >= dmin) & (den != 0)
            nums[i] = num if den_ok else np.int64(0)
            dens[i] = den if den_ok else one_den
            pre[i] = (abs(c1) >= te) & (g_sq >= g_thr) & den_ok
            c_c1 += f0
            c_a += f1
            c_b += f2
            c_k += f3 + f4 + f5
            c_w += f6 + f7 + f8
            c_gv += f9
            c_num += f10
            c_den += f11
            c_vsq += f12
            c_gsq += f13 + f14
            if log:
                l17, h17 = min(l17, c1_in), max(h17, c1_in)
                l18, h18 = min(l18, a_in), max(h18, a_in)
                l19, h19 = min(l19, b_in), max(h19, b_in)
                l20 = min(l20, min(k0_in, min(k1_in, k2_in)))
                h20 = max(h20, max(k0_in, max(k1_in, k2_in)))
                l23, h23 = min(l23, wx_in), max(h23, wx_in)
                l24, h24 = min(l24, wy_in), max(h24, wy_in)
                l25, h25 = min(l25, w0_in), max(h25, w0_in)
                l26, h26 = min(l26, gv_in), max(h26, gv_in)
                l27, h27 = min(l27, num_in), max(h27, num_in)
                l28, h28 = min(l28, den_in), max(h28, den_in)
                l29, h29 = min(l29, vsq_in), max(h29, vsq_in)
                l30, h30 = min(l30, gsq_in), max(h30, gsq_in)
                l31, h31 = min(l31, thr_in), max(h31, thr_in)
        if lanes:
            divide_row_lanes(nums, f_num, dens, f_den, RANGE, lut, r_bits, fm, dst, ov, rq, dovf,
                             log, modes)  # fmt: skip
        else:
            _divide_row(nums, f_num, dens, f_den, RANGE, kind, lut, r_bits, fm, dst, ov, rq, dovf)
        orow, vrow = out_range[j], out_valid[j]
        for i in range(n):
            r = rq[i]
            ok = pre[i] & (not dovf[i]) & (r > 0) & (r <= rmax)
            vrow[i] = ok
            orow[i] = r if ok else rmax
    ov[C1] += c_c1
    ov[GRAD_A] += c_a
    ov[GRAD_B] += c_b
    ov[K_ROT] += c_k
    ov[GEOM_W] += c_w
    ov[GV] += c_gv
    ov[NUM] += c_num
    ov[DEN] += c_den
    ov[V_SQ] += c_vsq
    ov[GRAD_SQ] += c_gsq
    if log:
        log_site(st, 17, l17, h17, f_s1, C1)
        log_site(st, 18, l18, h18, f_ex + 1, GRAD_A)
        log_site(st, 19, l19, h19, f_ey + 1, GRAD_B)
        log_site(st, 20, l20, h20, f_k, K_ROT)
        log_site(st, 23, l23, h23, f_gww, GEOM_W)
        log_site(st, 24, l24, h24, f_gww, GEOM_W)
        log_site(st, 25, l25, h25, f_w0, GEOM_W)
        log_site(st, 26, l26, h26, f_gvs, GV)
        log_site(st, 27, l27, h27, f_ns, NUM)
        log_site(st, 28, l28, h28, f_ds, DEN)
        log_site(st, 29, l29, h29, 2 * f_v, V_SQ)
        log_site(st, 30, l30, h30, 2 * f_gv, GRAD_SQ)
        log_site(st, 31, l31, h31, f_tg2 + f_vsq, GRAD_SQ)


# --------------------------------------------------------------------------------------
# host side
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FrameRegisters:
    """Per-frame constants as written by the host, raw codes in their register formats."""

    pole: int
    bias: int
    scalars: np.ndarray  # cx, cy, f, k3, k4, k5, T_E, T_g^2, min_den, range_max
    rotation: np.ndarray  # (3, 3): R_i0, R_i1 / f, R_i2 / f
    values: dict[str, tuple[float, float]]  # name -> (float requested, value held)
    saturated: tuple[str, ...] = ()  # registers held at their format's limit
    codes: dict[str, tuple[str, int]] = field(default_factory=dict)  # name -> (signal, raw)


def frame_registers(
    camera: PinholeCamera,
    motion: MotionIncrement,
    ranging: RangingConfig,
    config: P1Config,
) -> FrameRegisters:
    """Quantise the host's float64 constants into their register formats (SPEC §4)."""
    R, k345 = k_matrix(motion)
    f = camera.f_px
    cx, cy = camera.principal_point
    registers = RegisterFile(config)
    reg = registers.write
    scalars = np.array(
        [
            reg("cx", cx, "coord"),
            reg("cy", cy, "coord"),
            reg("f", f, "f_reg"),
            reg("k3", k345[0], "k_t_reg"),
            reg("k4", k345[1], "k_t_reg"),
            reg("k5", k345[2], "k_t_reg"),
            reg("T_E", ranging.threshold_e, "c1"),
            reg("T_g^2", ranging.threshold_g**2, "tg2_reg"),
            reg("min_denominator", ranging.min_denominator, "den"),
            reg("range_max", ranging.range_max, "range"),
        ],
        dtype=np.int64,
    )
    rotation = np.array(
        [[reg(f"R{i}{c}", R[i, c] / (1.0 if c == 0 else f), "k_m_reg") for c in range(3)]
         for i in range(3)],
        dtype=np.int64,
    )  # fmt: skip
    pole = reg("pole", config.pole, "pole_coef")
    bias = reg("bias", config.bias, "bias_reg")
    return FrameRegisters(
        pole, bias, scalars, rotation, registers.values, tuple(registers.saturated),
        dict(registers.codes),
    )  # fmt: skip


#: Register stages of a pipelined product in the RTL (``hdl/fx_pipe.v`` fx_mul_pipe with
#: ``IREG``: the operands' 18-bit chunks and the 18 x 18 partial products, both in the
#: MULT18X18D's own registers, then the partial products' sums in pairs, the final sum).
MUL_LATENCY = 4

#: Register stages of a cast in the range stage (``hdl/fx_cast_sized.v`` fx_cast_reg: the
#: rounded value registered before the overflow mode, then the cast's output register).
CAST_LATENCY = 2

#: Register stages of a three-term sum in the range stage (``k_r``, ``den``: one carry
#: chain a cycle, the first two terms then the third).
SUM3_LATENCY = 2

#: Stages the P1 RTL adds to a divider (``hdl/fx_divide.v`` ``PIPE = 2`` / ``FRONT``):
#: the reciprocal divider registers |N| |D|, the leading one and the seed index before its
#: ROM read (3), computes its three products in 4 stages each (9) and registers its
#: cast's shift and its rounded value (2); the restoring divider registers |N| |D| before
#: its first bit (1).
DIVIDER_FRONT = {"reciprocal": 14, "restoring": 1}

#: Cycles by which the column filter issues its line-buffer read ahead of its pixel
#: (``hdl/p1_colfilt.v``: the block RAM's data out is registered before the filter uses
#: it, at no cost in latency). A column's next read is issued ``width + hblank`` cycles
#: later and must come after its write-back (``column_filter`` - 1 cycles after the
#: pixel): lines of ``width + hblank <= column_filter - 1 + LINE_BUFFER_READ_AHEAD``
#: cycles are rejected.
LINE_BUFFER_READ_AHEAD = 1


def stage_latencies(config: P1Config) -> dict[str, int]:
    """Latency in clock cycles of every stage, as the RTL has them (``hdl/p1_frontend.v``,
    ``hdl/p1_range.v``; docs/p1_datapath.md, Timing). The consistent variant's second
    column filter runs beside the first (its ``ex`` leaves with ``s1``): its x-derivative
    adds no cycle; the paper variant's adds the product ``s1 r2`` and the divider.

    The range stage, one carry chain or one product per cycle (every cast in two
    stages, ``CAST_LATENCY``; three-term sums in two, ``SUM3_LATENCY``): ``range_coords``
    = input register, exact ``xp yp c1 a1 b1``, their casts, ``M xp`` (product), the sum
    and cast of ``k``, the products of ``v`` and ``w``, their sums and casts;
    ``range_products`` = the products of ``gv den v_sq``, their sums (``den``'s three
    terms) and casts, the product ``gv^2`` and its cast (``num`` beside it);
    ``range_divider`` = the operand select register and the divider."""
    front = DIVIDER_FRONT[config.divider]
    div = divider_latency(config.divider, config.formats["div_quot"].word) + front
    rdiv = divider_latency(config.divider, config.formats["range"].word) + front
    x_derivative = 0 if config.variant == "consistent" else MUL_LATENCY + div
    return {
        "input": 1,
        "bias": 1,
        "row_filter": 2,
        "column_filter": 3,
        "x_derivative": x_derivative,
        # input, sums; casts; products; k's sum; its cast; products; sums; casts: 19
        "range_coords": 2 + 2 * MUL_LATENCY + SUM3_LATENCY + 1 + 3 * CAST_LATENCY,
        # products; den's sum; casts; products (num beside them); casts: 14
        "range_products": 2 * MUL_LATENCY + SUM3_LATENCY + 2 * CAST_LATENCY,
        "range_divider": 1 + rdiv,
        "threshold": 1,
    }


#: Whether to run the fused front end (:func:`frontend_fused`) where it applies (False:
#: the general kernel everywhere, for A/B measurements).
FUSED = True

#: Cast sites in the kernels (each logs its own raw min/max).
N_SITES = 32


def buffer_bits(config: P1Config, shape: tuple[int, int], mode: str) -> dict[str, int]:
    """Line buffers (per stream: width x the column-filter state word, plus
    ``col2_state`` in the consistent variant) and, in motion mode, the frame store of
    ``col_s1 + ex + col_s2`` per pixel (docs/p1_datapath.md)."""
    m, n = shape
    words = line_buffer_words(config)
    streams = 2 if mode == "stereo" else 1
    store = m * n * frame_store_word(config) if mode == "motion" else 0
    return {"line_buffer_bits": streams * n * sum(words), "frame_store_bits": store}


def line_buffer_words(config: P1Config) -> tuple[int, ...]:
    """Word of each line buffer of one stream (LB1, and LB2 in the consistent variant)."""
    f = config.formats
    if config.variant == "consistent":
        return (f["col_state"].word, f["col2_state"].word)
    return (f["col_state"].word,)


def frame_store_word(config: P1Config) -> int:
    """Bits per pixel of the motion-mode frame store: ``col_s1``, ``ex``, ``col_s2``."""
    f = config.formats
    return f["col_s1"].word + f[config.ex_signal].word + f["col_s2"].word


def run_p1(
    case: Case,
    config: P1Config,
    ranging: RangingConfig,
    timing: TimingConfig,
    *,
    taps: bool,
    threads: int,
    log: bool,
) -> PipelineResult:
    """P1 on ``case``'s pair, on arguments :meth:`~rangefx.rtl_model.pipeline.Pipeline.run`
    has checked (the public entry: ``PIPELINES["p1"].run(case, ...)``): E1 =
    ``case.image1`` (left, or the previous frame in motion mode), E2 = ``case.image2``;
    integer grey levels.

    ``threads`` (1 or 2): the two streams' front ends, then two row bands of the range
    stage, run concurrently (the kernels release the GIL). ``log`` (as ``fipref``'s
    LoggingMode): keep the pre-quantisation min/max of every signal (``minmax``); off,
    ``minmax`` is empty and the front end skips its log. Every output, tap and overflow
    count is the same either way.
    """
    camera, motion, mode = case.camera, case.motion, case.mode
    im1, im2 = check_image_pair(case.image1, case.image2, camera, pipeline="p1", min_shape=(2, 2),
                                convert=False)  # fmt: skip
    m, n = im1.shape
    lat = stage_latencies(config)
    if n + timing.hblank <= lat["column_filter"] - 1 + LINE_BUFFER_READ_AHEAD:
        raise ValueError(
            f"line period {n + timing.hblank} cycles is too short for the column filter's "
            f"read-modify-write latency ({lat['column_filter']} cycles, its read issued "
            f"{LINE_BUFFER_READ_AHEAD} ahead): line-buffer hazard"
        )
    regs = frame_registers(camera, motion, ranging, config)
    fm = format_table(config)
    kind, lut = divider_setup(config)
    consistent = config.variant == "consistent"
    init_first = config.init == "first"
    n_ft = len(FRONTEND_TAPS)
    fused_frontend = FUSED and frontend_fits(fm, consistent)
    modes = cast_modes(fm)  # the fused kernels' cast body (plain modes: the short one)
    shape_t = (n_ft, m, n) if taps else (n_ft, 1, 1)

    cpu: list[tuple[str, float]] = []  # (kernel, CPU seconds of its thread); append is atomic

    # the streams' s1, ex, s2 (consumed by the range stage): internal, reused across runs
    stream_outs = [[scratch(f"p1.e{s}.{k}", (m, n)) for k in range(3)] for s in (1, 2)]

    def frontend(img: np.ndarray, outs: list[np.ndarray]):
        stats = SignalStats(N_SITES, len(P1_SIGNALS))
        st, dst, ov = stats.arrays
        tp = np.zeros(shape_t, dtype=np.int64)
        # converted on the stream's own thread; one buffer a thread: read by this call only
        img = kernel_image(img, "p1.image")
        t0 = time.thread_time()
        args = (img, np.int64(regs.pole), np.int64(regs.bias), consistent, init_first, kind,
                lut, config.recip_bits, fm, st, dst, ov, *outs, tp, taps)  # fmt: skip
        if fused_frontend:
            frontend_fused(*args, log, modes)
        else:
            _frontend_kernel(*args)
        cpu.append(("front_end", time.thread_time() - t0))
        return outs, tp, stats

    out_range = np.empty((m, n), dtype=np.int64)
    out_valid = np.empty((m, n), dtype=np.bool_)
    rfmt = config.formats["range"]
    range_f = np.empty((m, n), dtype=np.float64)
    # each pixel's input cycle in the stream(s), from the same offsets as the beats: the
    # closed form without gaps (filled by the range bands), else the running sum
    closed_cycles = timing.gap_prob == 0
    frames = 2 if mode == "motion" else 1
    in_cycles = (np.empty((m, n), dtype=np.int64) if closed_cycles
                 else input_cycles((m, n), timing, frames)[-1])  # fmt: skip
    latency = int(sum(lat.values()))
    out_cycles = np.empty((m, n), dtype=np.int64)
    band_ends: list[tuple[int, int]] = []  # each band's (latency, last output cycle)
    rtaps = np.zeros((len(RANGE_TAPS), m, n) if taps else (len(RANGE_TAPS), 1, 1), np.int64)
    f_ex = config.formats[config.ex_signal].frac
    # the fused range stage has no taps: with taps, the row-by-row kernel
    fused_range = FUSED and not taps and range_fits(fm, f_ex, config.recip_bits, kind)

    def range_band(j0: int, j1: int, s1, s2):
        stats = SignalStats(N_SITES, len(P1_SIGNALS))
        st, dst, ov = stats.arrays
        t0 = time.thread_time()
        args = (s1[0][0], s1[0][1], s1[0][2], s2[0][0], s2[0][1], s2[0][2], regs.scalars,
                regs.rotation, f_ex, kind, lut, config.recip_bits, fm, st, dst, ov, j0, j1,
                out_range, out_valid)  # fmt: skip
        if fused_range:
            range_fused(*args, log, modes)
        else:
            _range_kernel(*args, rtaps, taps)
        cpu.append(("range", time.thread_time() - t0))
        # the band's share of the result's host-side arrays, on the same thread (run
        # serially after the kernels they took ~2 ms of a 9 ms two-thread run)
        band_ends.append(finish_band(
            out_range[j0:j1], rfmt.frac, range_f[j0:j1], in_cycles[j0:j1], out_cycles[j0:j1],
            in_starts=line_starts((m, n), timing, frames - 1, j0, j1) if closed_cycles else None,
            latency=latency))  # fmt: skip
        return stats

    if threads == 2:
        r1, r2 = run_two(frontend, (im1, stream_outs[0]), (im2, stream_outs[1]))
        half = m // 2
        parts = run_two(range_band, (0, half, r1, r2), (half, m, r1, r2))
    else:
        r1, r2 = frontend(im1, stream_outs[0]), frontend(im2, stream_outs[1])
        parts = [range_band(0, m, r1, r2)]

    tap_dict: dict[str, np.ndarray] = {}
    if taps:
        for prefix, r in (("e1", r1), ("e2", r2)):
            for k, name in enumerate(FRONTEND_TAPS):
                if name == "col2_state" and not consistent:
                    continue
                tap_dict[f"{prefix}.{name}"] = r[1][k]
        for k, name in enumerate(RANGE_TAPS):
            tap_dict[name] = rtaps[k]

    return build_result(
        "p1", config, timing, mode, range_raw=out_range, range_float=range_f, valid=out_valid,
        taps=tap_dict, stats=SignalStats.merge([r1[2], r2[2], *parts], P1_SIGNALS), log=log,
        cycles=(in_cycles, out_cycles), stage_latency=lat, registers=regs,
        buffers=buffer_bits(config, (m, n), mode), band_ends=band_ends, latency=latency,
        kernel_cpu_s={k: sum(t for name, t in cpu if name == k) for k in ("front_end", "range")},
    )  # fmt: skip
