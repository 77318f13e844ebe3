"""P2: the bit-accurate, cycle-faithful line-buffered Riccati sweep (SPEC §4, ch. 5).

Per pixel, one clock each, ``d = E1 - E2`` and ``Ĝ = E1 + E2`` (eq 34) go into a line
buffer; a backward sweep over the stored line runs the discrete LQ Riccati recurrence of
golden G5 (``golden/riccati.py``, ``form="lq"``, ``A`` at the pixel edge) in the
normalised fixed-point form of ``docs/p2_datapath.md`` (``S~ = S/β``, ``Q~ = (K + SĜ)/β``,
one divider ``r = 1/(1 + A² S~)`` per pixel, eqs 27-28 as δ → 0); a forward pass yields
``λ/β``, the range ``z = -A λ/β`` (eqs 19, 38) and ``e = G - Ĝ`` (eq 37). The sweep
engine interleaves ``lanes`` lines so that its loop-carried recurrence (through the
divider) issues one step per clock; ping-pong line buffers let group ``g + 1`` arrive while
group ``g`` is swept, and one sweep buffer, filled in alternating column order, lets the
sweep of group ``g + 1`` write each entry right after the forward pass of group ``g`` has
read it (:func:`sweep_address`). Values do not depend on timing; cycle stamps do.

The model runs bands of :data:`BAND` lines in SIMD lanes (``_p2_bands``: every stage's
recurrence runs along a line, lines are independent); configs with a cast shifting by
more than 62 bits take the line-by-line kernel ``_p2_kernel`` (docs/performance.md, "How the
kernels are built").

``tests/oracle_p2.py`` is the independent slow implementation of the same page.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit, types

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.riccati import RiccatiConfig, stereo_baseline

from .. import runtime
from ..config import TimingConfig
from ..fixedpoint import cast_by_plan, cast_modes
from ..kernels import (
    bit_length,
    divide_lanes_scalar,
    lane_log_values,
    lane_overflows,
    ldexp2,
    log_site,
    reciprocal_lane,
    reciprocal_seed_index,
    restoring_lane,
    restoring_lane_setup,
    signal_plan,
)
from ..kernels import cast_site as _cast
from ..kernels import divide_into as _divide_into
from ..pipeline import Case, PipelineResult, build_result
from ..stream import input_cycles, line_starts
from .config import (
    ADD_LATENCY,
    BRAM_READ,
    CAST_LATENCY,
    FWD_LOOP,
    MUL_LATENCY,
    P2_SIGNALS,
    ROUND_LATENCY,
    SWEEP_READ,
    P2Config,
    divider_latency_p2,
    loop_latency,
)

__all__ = [
    "BANK_MARGIN",
    "FWD_LOOP",
    "FWD_READ",
    "IN_LATENCY",
    "LAM_OFFSET",
    "N_SITES",
    "OUT_LATENCY",
    "P2_TAPS",
    "SWEEP_READ",
    "W_OFFSET",
    "Z_OFFSET",
    "P2Registers",
    "buffer_bits",
    "frame_period",
    "group_starts",
    "output_line_starts",
    "p2_registers",
    "p2_schedule",
    "run_p2",
    "schedule_rows",
    "stage_latencies",
    "sweep_address",
    "sweep_entry_bits",
    "sweep_hold",
]

_SIG = {name: k for k, name in enumerate(P2_SIGNALS)}
PIX, DD, GH, KA, AA, CC, MR, ST, DEN, RR, HH, QQ, WW, LAM, ZZ, EE = (_SIG[s] for s in P2_SIGNALS)

#: Taps (int64 raw codes, shape (m, n)); backward-sweep signals of step k (pixel k to
#: k+1) at column k, ``s``/``q`` at column k are S~_k / Q~_k (column n-1: the start values),
#: ``e`` at column k is e_k; the last column has no step (z, w, lam, ... = 0, invalid).
P2_TAPS = (
    "d", "g_hat", "a", "c", "den", "r", "s", "h", "q", "w", "lam", "z", "e", "valid", "range",
)  # fmt: skip
#: Cast sites in the kernel (each logs its own raw min/max).
N_SITES = 16
IN_LATENCY = 2  # input cast + d/Ĝ adder, then the line-buffer write
FWD_READ = BRAM_READ  # a forward slot's sweep-buffer read: with it, the e operand register
#: Cycles after a forward slot's sweep-buffer read at which its taps leave (Hardware):
#: ``e`` with the read; ``w`` after ``u``, ``S~ u``, ``+ Q~``, the cast; ``lam`` and ``z``
#: after a product and a cast each (the casts' rounded values registered first);
#: ``valid``/``range`` after the threshold compare and the output register.
W_OFFSET = FWD_READ + ADD_LATENCY + MUL_LATENCY + ADD_LATENCY + CAST_LATENCY
LAM_OFFSET = W_OFFSET + MUL_LATENCY + ROUND_LATENCY + CAST_LATENCY
Z_OFFSET = LAM_OFFSET + MUL_LATENCY + ROUND_LATENCY + CAST_LATENCY
OUT_LATENCY = Z_OFFSET + ADD_LATENCY + 1
#: Cycles a sweep-buffer write must come after the read of the same address: ``p2_ram``
#: registers a write's and a read's address alike, so a write at cycle ``w`` lands in the
#: block RAM at the clock edge that ends ``w + 1`` and a read at ``t`` samples it at the
#: edge that ends ``t + 1``; the write's edge must come strictly later (the two ports of
#: a DP16KD on one address at one edge collide): ``w >= t + BANK_MARGIN``.
BANK_MARGIN = 1


@njit(cache=True, nogil=True)
def _p2_kernel(
    im1, im2, regs, kind, lut, r_bits, fm, st, dst, ov, j0, j1,
    out_range, out_valid, taps, want_taps,
):  # fmt: skip
    """Lines ``j0 <= j < j1``: input stage, backward sweep, forward pass (docs/p2_datapath.md)."""
    n = im1.shape[1]
    ka, m_reg, cmin, s_end, td, rmax = regs[0], regs[1], regs[2], regs[3], regs[4], regs[5]
    f_pix, f_d, f_g, f_ka, f_a = fm[PIX, 1], fm[DD, 1], fm[GH, 1], fm[KA, 1], fm[AA, 1]
    f_c, f_m, f_s, f_den, f_r = fm[CC, 1], fm[MR, 1], fm[ST, 1], fm[DEN, 1], fm[RR, 1]
    f_h, f_q, f_w, f_lam = fm[HH, 1], fm[QQ, 1], fm[WW, 1], fm[LAM, 1]
    f_z, f_e = fm[ZZ, 1], fm[EE, 1]
    f_den_in, f_s_in, f_h_in, f_u, f_w_in, f_e_in = _fracs(fm)
    d = np.zeros(n, dtype=np.int64)  # line buffer: d = E1 - E2
    g = np.zeros(n, dtype=np.int64)  # line buffer: Ĝ = E1 + E2
    sa = np.zeros(n, dtype=np.int64)  # sweep buffer: A, r, S~_k+1, Q~_k+1 of step k
    sr = np.zeros(n, dtype=np.int64)
    ss = np.zeros(n, dtype=np.int64)
    sq = np.zeros(n, dtype=np.int64)
    for j in range(j0, j1):
        for i in range(n):
            x1 = _cast(im1[j, i], 0, PIX, 0, fm, st, ov)
            x2 = _cast(im2[j, i], 0, PIX, 1, fm, st, ov)
            d[i] = _cast(x1 - x2, f_pix, DD, 2, fm, st, ov)
            g[i] = _cast(x1 + x2, f_pix, GH, 3, fm, st, ov)
        # backward sweep, right edge to left edge
        s1 = s_end
        q1 = np.int64(0)
        if want_taps:
            taps[6, j, n - 1] = s1
            taps[0, j, n - 1] = d[n - 1]
            taps[1, j, n - 1] = g[n - 1]
        for k in range(n - 2, -1, -1):
            dsum = d[k] + d[k + 1]
            dg = g[k + 1] - g[k]
            a = _cast(ka * dsum, f_ka + f_d, AA, 4, fm, st, ov)
            c = max(_cast(a * a, 2 * f_a, CC, 5, fm, st, ov), cmin)
            den = _cast((np.int64(1) << f_den_in) + (c * s1 << (f_den_in - f_c - f_s)),
                        f_den_in, DEN, 6, fm, st, ov)  # fmt: skip
            r, _ = _divide_into(np.int64(1), 0, den, f_den, RR, kind, lut, r_bits, fm, dst,
                                ov)  # fmt: skip
            s0 = _cast((m_reg << (f_s_in - f_m)) + (r * s1 << (f_s_in - f_r - f_s)), f_s_in,
                       ST, 7, fm, st, ov)  # fmt: skip
            h = _cast((q1 << (f_h_in - f_q)) - (s1 * dg << (f_h_in - f_s - f_g)), f_h_in,
                      HH, 8, fm, st, ov)  # fmt: skip
            q0 = _cast(r * h, f_r + f_h, QQ, 9, fm, st, ov)
            sa[k] = a
            sr[k] = r
            ss[k] = s1
            sq[k] = q1
            if want_taps:
                taps[0, j, k] = d[k]
                taps[1, j, k] = g[k]
                taps[2, j, k] = a
                taps[3, j, k] = c
                taps[4, j, k] = den
                taps[5, j, k] = r
                taps[6, j, k] = s0
                taps[7, j, k] = h
                taps[8, j, k] = q0
            s1 = s0
            q1 = q0
        # forward pass, left edge to right edge
        e = np.int64(0)
        for k in range(n - 1):
            dg = g[k + 1] - g[k]
            u = (e << (f_u - f_e)) - (dg << (f_u - f_g))
            w = _cast((ss[k] * u << (f_w_in - f_s - f_u)) + (sq[k] << (f_w_in - f_q)), f_w_in,
                      WW, 10, fm, st, ov)  # fmt: skip
            lam = _cast(sr[k] * w, f_r + f_w, LAM, 11, fm, st, ov)
            z = _cast(-(sa[k] * lam), f_a + f_lam, ZZ, 12, fm, st, ov)
            e = _cast((u << (f_e_in - f_u)) + (sa[k] * z << (f_e_in - f_a - f_z)), f_e_in,
                      EE, 13, fm, st, ov)  # fmt: skip
            ok = abs(d[k] + d[k + 1]) >= td and z > 0 and z <= rmax
            out_valid[j, k] = ok
            out_range[j, k] = z if ok else rmax
            if want_taps:
                taps[9, j, k] = w
                taps[10, j, k] = lam
                taps[11, j, k] = z
                taps[12, j, k + 1] = e
                taps[13, j, k] = ok
                taps[14, j, k] = out_range[j, k]
        out_valid[j, n - 1] = False
        out_range[j, n - 1] = rmax
        if want_taps:
            taps[14, j, n - 1] = rmax


# --------------------------------------------------------------------------------------
# the band kernel (issue 18): the values, taps, overflow counts and min/max log of
# _p2_kernel in less time. Lines are independent and every recurrence runs along a line,
# so a band of BAND lines is processed in SIMD lanes: the band's buffers are
# column-major (``dT[i, k]``: column ``i`` of line ``k`` of the band), each loop over the
# lanes of one column is contiguous and branch-free (cast_by_plan, the plans hoisted out
# of the loops), each lane carries its own recurrence state, and the min/max log and the
# overflow counts are kept in local scalars and merged once per call. The divider runs
# on the lanes between the two halves of a backward step (the lane helpers of
# rangefx.rtl_model.kernels). ``log`` and
# ``want_taps`` are runtime flags of one compiled body. Configs with a cast shifting by
# more than 62 bits (band_fits False) take _p2_kernel.
# --------------------------------------------------------------------------------------
#: Lines per band (the SIMD lanes of the band kernel: four AVX-512 vectors of int64 per
#: column; measured 21 ns/pixel against 25 for 16 lanes and 72 for 8, 512x512 lab).
BAND = 32
#: Whether to run the band kernel where it applies (False: _p2_kernel everywhere, for
#: A/B measurements and the test of the general path).
BANDED = True
_BIG, _SMALL = np.iinfo(np.int64).max, np.iinfo(np.int64).min


@njit((runtime.KERNEL_PLANE,), cache=True, nogil=True)
def _fracs(fm):
    """The aligned fraction bits of the sums in the datapath (docs/p2_datapath.md):
    ``(den, s, h, u, w, e)``."""
    f_g, f_a, f_c, f_m = fm[GH, 1], fm[AA, 1], fm[CC, 1], fm[MR, 1]
    f_s, f_r, f_q, f_e, f_z = fm[ST, 1], fm[RR, 1], fm[QQ, 1], fm[EE, 1], fm[ZZ, 1]
    f_u = max(f_e, f_g)
    return (max(0, f_c + f_s), max(f_m, f_r + f_s), max(f_q, f_s + f_g), f_u,
            max(f_s + f_u, f_q), max(f_u, f_a + f_z))  # fmt: skip


@njit(cache=True, nogil=True)
def band_fits(fm):
    """Whether every cast of P2 shifts by at most 62 bits (the band kernel's casts)."""
    f_pix, f_d, f_ka, f_a = fm[PIX, 1], fm[DD, 1], fm[KA, 1], fm[AA, 1]
    f_r, f_h, f_w, f_lam = fm[RR, 1], fm[HH, 1], fm[WW, 1], fm[LAM, 1]
    f_den, f_s, f_h_in, _, f_w_in, f_e = _fracs(fm)
    ins = ((0, PIX), (f_pix, DD), (f_pix, GH), (f_ka + f_d, AA), (2 * f_a, CC),
           (f_den, DEN), (f_s, ST), (f_h_in, HH), (f_r + f_h, QQ), (f_w_in, WW),
           (f_r + f_w, LAM), (f_a + f_lam, ZZ), (f_e, EE))  # fmt: skip
    ok = True
    for frac_in, s in ins:
        ok = ok and abs(frac_in - fm[s, 1]) <= 62
    return ok


@njit(cache=True, nogil=True, error_model="numpy")
def _p2_bands(
    im1, im2, regs, kind, lut, r_bits, fm, st, dst, ov, j0, j1,
    out_range, out_valid, taps, want_taps, log, modes,
):  # fmt: skip
    """Lines ``j0 <= j < j1`` of :func:`_p2_kernel` in bands of :data:`BAND` lines;
    ``modes``: the casts' body (:func:`~rangefx.rtl_model.fixedpoint.cast_modes` of
    ``fm``)."""
    n = im1.shape[1]
    ka, m_reg, cmin, s_end, td, rmax = regs[0], regs[1], regs[2], regs[3], regs[4], regs[5]
    f_pix, f_d, f_g, f_ka, f_a = fm[PIX, 1], fm[DD, 1], fm[GH, 1], fm[KA, 1], fm[AA, 1]
    f_c, f_m, f_s, f_den, f_r = fm[CC, 1], fm[MR, 1], fm[ST, 1], fm[DEN, 1], fm[RR, 1]
    f_h, f_q, f_w, f_lam = fm[HH, 1], fm[QQ, 1], fm[WW, 1], fm[LAM, 1]
    f_z, f_e = fm[ZZ, 1], fm[EE, 1]
    f_den_in, f_s_in, f_h_in, f_u, f_w_in, f_e_in = _fracs(fm)
    pl_x, pl_d, pl_g = (
        signal_plan(0, PIX, fm),
        signal_plan(f_pix, DD, fm),
        signal_plan(f_pix, GH, fm),
    )
    pl_a, pl_c = signal_plan(f_ka + f_d, AA, fm), signal_plan(2 * f_a, CC, fm)
    pl_den, pl_s = signal_plan(f_den_in, DEN, fm), signal_plan(f_s_in, ST, fm)
    pl_h, pl_q = signal_plan(f_h_in, HH, fm), signal_plan(f_r + f_h, QQ, fm)
    pl_w, pl_lam = signal_plan(f_w_in, WW, fm), signal_plan(f_r + f_w, LAM, fm)
    pl_z, pl_e = signal_plan(f_a + f_lam, ZZ, fm), signal_plan(f_e_in, EE, fm)
    w_r, sg_r, qn_r, of_r = fm[RR, 0], fm[RR, 2] != 0, fm[RR, 3], fm[RR, 4]
    one = np.int64(1)
    # the lane divider's per-frame constants; r = 1 / den, the numerator at frac 0
    r_direct = -1022 <= f_den <= 1022  # else every column takes divide_lanes_scalar
    r_scale = ldexp2(1.0, min(max(f_den, -1022), 1022))
    ov_pos, ov_neg = lane_overflows(w_r, sg_r, of_r)
    r_sh, r_plan, r_cap = restoring_lane_setup(0, f_den, w_r, f_r, sg_r, qn_r, of_r)
    lut_bits, lut_mask = bit_length(lut.shape[0]) - 1, lut.shape[0] - 1
    # the band's buffers, column-major; those only taps read are allocated with taps
    nt = n if want_taps else 1
    t_step = 1 if want_taps else 0  # without taps, their stores go to row 0 (no branch)
    dT, gT = np.empty((n, BAND), np.int64), np.empty((n, BAND), np.int64)
    aT, rT = np.empty((n, BAND), np.int64), np.empty((n, BAND), np.int64)
    sT, qT = np.empty((n, BAND), np.int64), np.empty((n, BAND), np.int64)
    rgT, okT = np.empty((n, BAND), np.int64), np.empty((n, BAND), np.bool_)
    cT, denT, hT = np.zeros((nt, BAND), np.int64), np.zeros((nt, BAND), np.int64), np.zeros(
        (nt, BAND), np.int64)  # fmt: skip
    zT, wT, lamT = np.zeros((nt, BAND), np.int64), np.zeros((nt, BAND), np.int64), np.zeros(
        (nt, BAND), np.int64)  # fmt: skip
    eT = np.zeros((nt, BAND), np.int64)
    s1v, q1v, ev = np.empty(BAND, np.int64), np.empty(BAND, np.int64), np.empty(BAND, np.int64)
    denv, rv = np.empty(BAND, np.int64), np.empty(BAND, np.int64)
    onev, rflags, real = np.ones(BAND, np.int64), np.empty(BAND, np.bool_), np.empty(BAND, np.bool_)
    rlo, rhi = np.full(BAND, np.inf), np.full(BAND, -np.inf)
    lo0, hi0, lo1, hi1, lo2, hi2, lo3, hi3 = _BIG, _SMALL, _BIG, _SMALL, _BIG, _SMALL, _BIG, _SMALL
    lo4, hi4, lo5, hi5, lo6, hi6, lo7, hi7 = _BIG, _SMALL, _BIG, _SMALL, _BIG, _SMALL, _BIG, _SMALL
    lo8, hi8, lo9, hi9, lo10, hi10 = _BIG, _SMALL, _BIG, _SMALL, _BIG, _SMALL
    lo11, hi11, lo12, hi12, lo13, hi13 = _BIG, _SMALL, _BIG, _SMALL, _BIG, _SMALL
    c_x, c_d, c_g, c_a, c_c, c_den, c_r, c_s = 0, 0, 0, 0, 0, 0, 0, 0
    c_h, c_q, c_w, c_lam, c_z, c_e = 0, 0, 0, 0, 0, 0
    for jb in range(j0, j1, BAND):
        bw = min(BAND, j1 - jb)
        # input stage: d = E1 - E2 and Ĝ = E1 + E2 into the band's line buffers
        for k in range(bw):
            for i in range(n):
                raw1, raw2 = im1[jb + k, i], im2[jb + k, i]
                x1, f0 = cast_by_plan(raw1, pl_x, modes)
                x2, f1 = cast_by_plan(raw2, pl_x, modes)
                d, f2 = cast_by_plan(x1 - x2, pl_d, modes)
                g, f3 = cast_by_plan(x1 + x2, pl_g, modes)
                c_x += f0 + f1
                c_d += f2
                c_g += f3
                if log:
                    lo0, hi0 = min(lo0, raw1), max(hi0, raw1)
                    lo1, hi1 = min(lo1, raw2), max(hi1, raw2)
                    lo2, hi2 = min(lo2, x1 - x2), max(hi2, x1 - x2)
                    lo3, hi3 = min(lo3, x1 + x2), max(hi3, x1 + x2)
                dT[i, k] = d
                gT[i, k] = g
        # a short band's spare lanes repeat its last line: their values change no log
        # (min/max), and ``real`` keeps them out of the overflow counts
        for k in range(BAND):
            real[k] = k < bw
        for i in range(n):
            for k in range(bw, BAND):
                dT[i, k] = dT[i, bw - 1]
                gT[i, k] = gT[i, bw - 1]
        # backward sweep, right edge to left edge; per column: A, c and the divider's
        # denominator on the lanes, the divider, then S~, h and Q~
        for k in range(BAND):
            s1v[k] = s_end
            q1v[k] = 0
        for step in range(n - 1):  # (a negative-step range measured 2x slower: no SIMD)
            i = n - 2 - step
            it = i * t_step
            for k in range(BAND):
                asum = ka * (dT[i, k] + dT[i + 1, k])
                a, f0 = cast_by_plan(asum, pl_a, modes)
                c, f1 = cast_by_plan(a * a, pl_c, modes)
                c = max(c, cmin)
                den_in = (one << f_den_in) + (c * s1v[k] << (f_den_in - f_c - f_s))
                den, f2 = cast_by_plan(den_in, pl_den, modes)
                c_a += f0 & real[k]
                c_c += f1 & real[k]
                c_den += f2 & real[k]
                if log:
                    lo4, hi4 = min(lo4, asum), max(hi4, asum)
                    lo5, hi5 = min(lo5, a * a), max(hi5, a * a)
                    lo6, hi6 = min(lo6, den_in), max(hi6, den_in)
                aT[i, k] = a
                denv[k] = den
                cT[it, k] = c
                denT[it, k] = den
            # the divider's lane loops written out, so that no array is handed to an
            # inlined function once per column (its reference counts: rtl_model/kernels.py)
            far = not r_direct
            if kind == runtime.DIV_RESTORING:
                for k in range(BAND):
                    rv[k], rflags[k], beyond = restoring_lane(one, denv[k], r_sh, r_plan, r_cap,
                                                              ov_pos, ov_neg, modes)  # fmt: skip
                    far |= beyond
            else:
                for k in range(BAND):
                    rv[k] = reciprocal_seed_index(denv[k], lut_bits, lut_mask)
                for k in range(BAND):
                    rv[k] = lut[rv[k]]
                for k in range(BAND):
                    rv[k], rflags[k], beyond = reciprocal_lane(
                        one, denv[k], rv[k], 0, f_den, r_bits, w_r, f_r, sg_r, qn_r, of_r,
                        ov_pos, ov_neg, modes)  # fmt: skip
                    far |= beyond
            if far:
                divide_lanes_scalar(onev, 0, denv, f_den, BAND, w_r, f_r, sg_r, qn_r, of_r, kind,
                                    lut, r_bits, rv, rflags, rlo, rhi, log)  # fmt: skip
            elif log:
                for k in range(BAND):
                    v_lo, v_hi = lane_log_values(one, denv[k], r_scale)
                    rlo[k] = min(rlo[k], v_lo)
                    rhi[k] = max(rhi[k], v_hi)
            for k in range(BAND):
                s1, q1, r = s1v[k], q1v[k], rv[k]
                c_r += rflags[k] & real[k]
                dg = gT[i + 1, k] - gT[i, k]
                s_in = (m_reg << (f_s_in - f_m)) + (r * s1 << (f_s_in - f_r - f_s))
                s0, f0 = cast_by_plan(s_in, pl_s, modes)
                h_in = (q1 << (f_h_in - f_q)) - (s1 * dg << (f_h_in - f_s - f_g))
                h, f1 = cast_by_plan(h_in, pl_h, modes)
                q0, f2 = cast_by_plan(r * h, pl_q, modes)
                c_s += f0 & real[k]
                c_h += f1 & real[k]
                c_q += f2 & real[k]
                if log:
                    lo7, hi7 = min(lo7, s_in), max(hi7, s_in)
                    lo8, hi8 = min(lo8, h_in), max(hi8, h_in)
                    lo9, hi9 = min(lo9, r * h), max(hi9, r * h)
                rT[i, k] = r
                sT[i, k] = s1
                qT[i, k] = q1
                hT[it, k] = h
                s1v[k] = s0
                q1v[k] = q0
        # forward pass, left edge to right edge
        for k in range(BAND):
            ev[k] = 0
        for i in range(n - 1):
            it, it1 = i * t_step, (i + 1) * t_step
            for k in range(BAND):
                a, e = aT[i, k], ev[k]
                dg = gT[i + 1, k] - gT[i, k]
                u = (e << (f_u - f_e)) - (dg << (f_u - f_g))
                w_in = (sT[i, k] * u << (f_w_in - f_s - f_u)) + (qT[i, k] << (f_w_in - f_q))
                w, f0 = cast_by_plan(w_in, pl_w, modes)
                lam_in = rT[i, k] * w
                lam, f1 = cast_by_plan(lam_in, pl_lam, modes)
                z_in = -(a * lam)
                z, f2 = cast_by_plan(z_in, pl_z, modes)
                e_in = (u << (f_e_in - f_u)) + (a * z << (f_e_in - f_a - f_z))
                e, f3 = cast_by_plan(e_in, pl_e, modes)
                c_w += f0 & real[k]
                c_lam += f1 & real[k]
                c_z += f2 & real[k]
                c_e += f3 & real[k]
                if log:
                    lo10, hi10 = min(lo10, w_in), max(hi10, w_in)
                    lo11, hi11 = min(lo11, lam_in), max(hi11, lam_in)
                    lo12, hi12 = min(lo12, z_in), max(hi12, z_in)
                    lo13, hi13 = min(lo13, e_in), max(hi13, e_in)
                ok = (abs(dT[i, k] + dT[i + 1, k]) >= td) & (z > 0) & (z <= rmax)
                rgT[i, k] = z if ok else rmax
                okT[i, k] = ok
                ev[k] = e
                wT[it, k] = w
                lamT[it, k] = lam
                zT[it, k] = z
                eT[it1, k] = e
        # the band's outputs (and taps) back to scan order
        for k in range(bw):
            j = jb + k
            for i in range(n - 1):
                out_range[j, i] = rgT[i, k]
                out_valid[j, i] = okT[i, k]
            out_range[j, n - 1] = rmax
            out_valid[j, n - 1] = False
            if want_taps:
                for i in range(n):
                    taps[0, j, i] = dT[i, k]
                    taps[1, j, i] = gT[i, k]
                for i in range(n - 1):
                    taps[2, j, i] = aT[i, k]
                    taps[3, j, i] = cT[i, k]
                    taps[4, j, i] = denT[i, k]
                    taps[5, j, i] = rT[i, k]
                    taps[6, j, i + 1] = sT[i, k]
                    taps[7, j, i] = hT[i, k]
                    taps[8, j, i + 1] = qT[i, k]
                    taps[9, j, i] = wT[i, k]
                    taps[10, j, i] = lamT[i, k]
                    taps[11, j, i] = zT[i, k]
                    taps[12, j, i + 1] = eT[i + 1, k]
                    taps[13, j, i] = okT[i, k]
                    taps[14, j, i] = rgT[i, k]
                taps[6, j, 0] = s1v[k]
                taps[8, j, 0] = q1v[k]
                taps[14, j, n - 1] = rmax
    for s, count in ((PIX, c_x), (DD, c_d), (GH, c_g), (AA, c_a), (CC, c_c), (DEN, c_den),
                     (RR, c_r), (ST, c_s), (HH, c_h), (QQ, c_q), (WW, c_w), (LAM, c_lam),
                     (ZZ, c_z), (EE, c_e)):  # fmt: skip
        ov[s] += count
    if log and j1 > j0:
        log_site(st, 0, lo0, hi0, 0, PIX)
        log_site(st, 1, lo1, hi1, 0, PIX)
        log_site(st, 2, lo2, hi2, f_pix, DD)
        log_site(st, 3, lo3, hi3, f_pix, GH)
        log_site(st, 4, lo4, hi4, f_ka + f_d, AA)
        log_site(st, 5, lo5, hi5, 2 * f_a, CC)
        log_site(st, 6, lo6, hi6, f_den_in, DEN)
        log_site(st, 7, lo7, hi7, f_s_in, ST)
        log_site(st, 8, lo8, hi8, f_h_in, HH)
        log_site(st, 9, lo9, hi9, f_r + f_h, QQ)
        log_site(st, 10, lo10, hi10, f_w_in, WW)
        log_site(st, 11, lo11, hi11, f_r + f_w, LAM)
        log_site(st, 12, lo12, hi12, f_a + f_lam, ZZ)
        log_site(st, 13, lo13, hi13, f_e_in, EE)
        dst[RR, 0] = min(dst[RR, 0], rlo.min())
        dst[RR, 1] = max(dst[RR, 1], rhi.max())


# --------------------------------------------------------------------------------------
# host side
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class P2Registers:
    """Per-frame constants written by the host (raw codes) and their float values."""

    raw: np.ndarray  # KA, M, c_min, S~_end (gamma_eff), T_D, range_max
    values: dict[str, tuple[float, float]]  # name -> (float requested, value held)
    saturated: tuple[str, ...] = ()  # registers held at their format's limit
    codes: dict[str, tuple[str, int]] = field(default_factory=dict)  # name -> (signal, raw)


def p2_registers(
    camera: PinholeCamera, motion: MotionIncrement, riccati: RiccatiConfig, config: P2Config
) -> P2Registers:
    """Quantise the host's constants (docs/p2_datapath.md, "Registers").

    Pixel units: ``KA = 1/(f_px Δx)`` with ``Δx = -b`` (SPEC §9, camera 2 at ``+b``),
    ``M = α/β``, ``c_min = κ_min / M``, ``S~_end = min(γ/(β s), max of p2_st)`` (the γ clamp;
    ``s`` = pixel pitch), ``T_D = ceil(2 T_E 2^F_d)`` and ``range_max``.
    """
    registers = runtime.RegisterFile(config)
    reg, values = registers.write, registers.values
    dx = -stereo_baseline(motion)
    beta_px = riccati.beta * riccati.pixel_pitch
    m_ratio = riccati.alpha / riccati.beta
    st = config.formats["p2_st"]
    s_end = min(riccati.gamma / beta_px, float(st.to_float(st.raw_max)))
    td = math.ceil(2.0 * riccati.threshold_e * 2.0 ** config.formats["p2_d"].frac)
    # every |d| code is below 2**W: a larger threshold compares the same and must fit int64
    td = min(td, 1 << config.formats["p2_d"].word)
    registers.hold("T_D", td, "p2_d", 2.0 * riccati.threshold_e)
    raw = np.array(
        [
            reg("KA", 1.0 / (camera.f_px * dx), "p2_ka_reg"),
            reg("M", m_ratio, "p2_m_reg"),
            reg("c_min", config.kappa_min / m_ratio, "p2_c"),
            reg("S_end", s_end, "p2_st"),
            td,
            reg("range_max", riccati.range_max, "p2_z"),
        ],
        dtype=np.int64,
    )
    values["gamma"] = (riccati.gamma / beta_px, values["S_end"][1])
    return P2Registers(raw, values, tuple(registers.saturated), dict(registers.codes))


def stage_latencies(config: P2Config) -> dict[str, int]:
    """Declared latencies (cycles) of the P2 stages (docs/p2_datapath.md, Timing)."""
    return {
        "input": IN_LATENCY,
        "sweep_read": SWEEP_READ,
        "divider": divider_latency_p2(config.divider, config.formats["p2_r"].word),
        "backward_loop": loop_latency(config),
        "forward_loop": FWD_LOOP,
        "forward_read": FWD_READ,
        "output": OUT_LATENCY,
    }


def p2_schedule(
    in_cycles: np.ndarray, config: P2Config, hblank: int
) -> tuple[np.ndarray, dict[str, int], dict[str, np.ndarray]]:
    """Output cycle of every pixel from the input cycles (docs/p2_datapath.md, Timing).

    Lines are taken in groups of ``L`` lanes; a group's backward sweep issues one slot per
    clock round-robin over its lanes (``P_b = max(L, T_b)`` cycles per column, ``n``
    columns: the first slot of a lane loads ``S~_end``, ``Q~ = 0``) and starts when its
    last pixel is in the line buffer and the previous group's sweep is done; the forward
    pass of a group (``n`` slots per lane, ``P_f = max(L, T_f)`` cycles per column) follows
    its sweep likewise. Raises ``ValueError`` when the
    sweep or the forward pass of a group needs more cycles than the group's lines take to
    arrive, or when group ``g + 2`` would overwrite the ping-pong line buffer before group
    ``g``'s sweep has read it: one pixel per clock could not be sustained. The sweep of
    group ``g`` writes the one sweep buffer where the forward pass of group ``g - 1`` reads
    (:func:`sweep_address`): it starts no earlier than :func:`sweep_hold` cycles after that
    forward pass (a bound that does not bind while ``T_f <= T_b``).
    """
    m, n = in_cycles.shape
    starts, info = group_starts(in_cycles[:, 0], in_cycles[:, n - 1], n, config, hblank)
    out = np.empty((m, n), dtype=np.int64)
    sweep_start = np.empty(m, dtype=np.int64)
    forward_start = np.empty(m, dtype=np.int64)
    schedule_rows(starts, info, 0, m, out, sweep_start, forward_start)
    return out, info, {"sweep_start": sweep_start, "forward_start": forward_start}


def group_starts(
    line_first: np.ndarray, line_last: np.ndarray, n: int, config: P2Config, hblank: int
) -> tuple[np.ndarray, dict[str, int]]:
    """The recurrence of :func:`p2_schedule` over the groups of lines: each group's
    backward-sweep and forward-pass start cycles, shape (groups, 2), from the input cycle
    of every line's first and last pixel; and the schedule's periods (``info``). Raises
    the same ``ValueError`` as :func:`p2_schedule`."""
    lanes = config.effective_lanes()
    tb, tf = loop_latency(config), FWD_LOOP
    pb, pf = max(lanes, tb), max(lanes, tf)
    period = lanes * (n + hblank)
    back, fwd = n * pb, n * pf
    if back > period or fwd > period:
        raise ValueError(
            f"P2 cannot sustain one pixel per clock: a group of {lanes} lines arrives in "
            f"{period} cycles but its backward sweep needs {back} (loop latency {tb}) and its "
            f"forward pass {fwd} (loop latency {tf}); use lanes >= {max(tb, tf)} or more "
            "horizontal blanking"
        )
    firsts = np.ascontiguousarray(line_first, dtype=np.int64)
    lasts = np.ascontiguousarray(line_last, dtype=np.int64)
    # the sweep's last line-buffer read (lane L - 1, column 0) must come before the
    # write of the first pixel of group g + 2 into the same bank
    reads = (n - 1) * pb + lanes
    hold = sweep_hold(n, pb, pf, tb)
    starts, bad = _group_recurrence(firsts, lasts, lanes, back, fwd, tb, reads, hold)
    if bad >= 0:
        raise ValueError(
            f"P2 cannot sustain one pixel per clock: group {bad} (lines {bad * lanes}..) "
            f"would overwrite the line buffer still read by group {bad - 2}'s sweep"
        )
    info = {
        "lanes": lanes,
        "backward_period": pb,
        "forward_period": pf,
        "backward_cycles": back,
        "forward_cycles": fwd,
        "group_period": period,
    }
    return starts, info


@njit(
    types.Tuple((runtime.KERNEL_PLANE, types.int64))(
        runtime.KERNEL_ROW, runtime.KERNEL_ROW, types.int64, types.int64, types.int64,
        types.int64, types.int64, types.int64),
    cache=True, nogil=True,
)  # fmt: skip
def _group_recurrence(firsts, lasts, lanes, back, fwd, tb, reads, hold):
    """:func:`group_starts`' serial recurrence over the groups (the input cycles of each
    line's first and last pixel in, each group's sweep and forward start out), and the
    first group that would overwrite the line buffer a sweep still reads (-1: none):
    ``reads`` cycles after its start a sweep has read its bank, whose next group's first
    pixel is written ``IN_LATENCY`` cycles after its beat; a sweep starts no earlier than
    ``hold`` cycles after the forward start of group g - 1 (:func:`sweep_hold`). In
    Python, P2's host work around no-op kernels took 0.377 ms a run against 0.338 with
    this (one thread, 47 groups, measured)."""
    m = firsts.shape[0]
    groups = -(-m // lanes)
    starts = np.zeros((groups, 2), dtype=np.int64)
    for gi in range(groups):
        first, last = gi * lanes, min(m, (gi + 1) * lanes) - 1
        ready = lasts[last] + 1 + IN_LATENCY
        b0 = ready if gi == 0 else max(ready, starts[gi - 1, 0] + back)
        if gi >= 1:  # each entry it writes is read by group gi - 1's forward pass first
            b0 = max(b0, starts[gi - 1, 1] + hold)
        # lane l writes its sweep-buffer column 0 at b0 + l + (n - 1) P_b + SWEEP_READ + T_b
        # and reads it at f0 + l >= b0 + l + n P_b + T_b: later by P_b - SWEEP_READ >=
        # BANK_MARGIN, as P_b >= T_b > SWEEP_READ (T_b = 13 + T_div)
        f0 = b0 + back + tb
        f0 = f0 if gi == 0 else max(f0, starts[gi - 1, 1] + fwd)
        if gi >= 2 and starts[gi - 2, 0] + reads > firsts[first] + IN_LATENCY:
            return starts, gi
        starts[gi, 0] = b0
        starts[gi, 1] = f0
    return starts, np.int64(-1)


def schedule_rows(
    starts: np.ndarray,
    info: dict[str, int],
    j0: int,
    j1: int,
    out: np.ndarray,
    sweep_start: np.ndarray | None = None,
    forward_start: np.ndarray | None = None,
) -> None:
    """Lines ``j0 <= j < j1`` of :func:`p2_schedule` from :func:`group_starts`: each
    pixel's output cycle into ``out`` (shape (j1 - j0, n)), each line's sweep and forward
    start into the optional ``sweep_start`` / ``forward_start`` (length j1 - j0); a model
    fills its result's rows band by band."""
    kk_pf = np.arange(out.shape[1], dtype=np.int64) * info["forward_period"]
    np.add(output_line_starts(starts, info, j0, j1)[:, None], kk_pf, out=out)
    lanes = info["lanes"]
    lines = np.arange(j0, j1, dtype=np.int64)
    group, lane = lines // lanes, lines % lanes
    if sweep_start is not None:
        sweep_start[:] = starts[group, 0] + lane
    if forward_start is not None:
        forward_start[:] = starts[group, 1] + lane


def sweep_address(lane: int, column: int, group: int, n: int) -> int:
    """Word of the sweep buffer (``lanes * n`` entries, one bank) holding entry (``lane``,
    ``column``) of ``group``: ``lane n + column`` for an even group, ``lane n + n - 1 -
    column`` for an odd one.

    Why one bank suffices: slot ``i`` of a lane's sweep (read at ``b_g + lane + i P_b``)
    handles column ``n - 1 - i`` and writes its entry at the write-back, ``SWEEP_READ + T_b``
    cycles later (slot 0, column ``n - 1``, only loads the start values: no entry); slot
    ``i`` of the lane's forward pass reads column ``i`` at ``f_g + lane + i P_f``. With the
    column order alternating between groups, slot ``i`` of group ``g``'s sweep writes the
    very word slot ``i`` of group ``g - 1``'s forward pass reads, and every word is written
    (group g), read (group g), written (group g + 1), ... in that order as long as each
    write comes :data:`BANK_MARGIN` after the read before it: :func:`sweep_hold` for
    the sweep of ``g + 1``, ``P_b - SWEEP_READ`` for the forward pass of ``g`` (its read of
    column 0, the last written, comes ``n P_b + T_b`` after its sweep's start at least)."""
    return lane * n + column + (group % 2) * (n - 1 - 2 * column)  # numpy arrays too


def sweep_hold(n: int, pb: int, pf: int, tb: int) -> int:
    """The earliest start of group ``g``'s sweep after the forward start of group ``g - 1``
    (:func:`sweep_address`): slot ``i`` (``1 <= i <= n - 1``, the written ones; the
    forward's slot ``n - 1`` reads a word whose output it zeroes) writes at ``b_g + lane +
    i P_b + SWEEP_READ + T_b``, the forward pass of ``g - 1`` reads the same word at
    ``f_g-1 + lane + i P_f``, and the write comes :data:`BANK_MARGIN` after the read:
    ``b_g >= f_g-1 + max over i of i (P_f - P_b) - SWEEP_READ - T_b + BANK_MARGIN``. With
    ``P_f <= P_b`` (``T_f <= T_b``) the maximum is at ``i = 1`` and is below ``-T_b``: it
    never binds, as ``f_g-1 <= b_g + T_b`` then."""
    return max(pf - pb, (n - 1) * (pf - pb)) - SWEEP_READ - tb + BANK_MARGIN


def frame_period(
    line_first: np.ndarray, line_last: np.ndarray, n: int, config: P2Config, hblank: int
) -> int:
    """The least number of cycles from a frame's first beat to the next frame's, in a
    stream of frames whose beats come as this frame's (the input cycle of every line's
    first and last pixel), for which the next frame's schedule is that of a frame alone
    and no line buffer is overwritten early (``hdl/p2_top.v``: the bank parity continues
    across frames, so the groups of a stream follow :func:`group_starts`' recurrence
    over the frame boundary). The next frame's first group waits for nothing of this
    frame's last group: its sweep starts after that sweep's end and :func:`sweep_hold`
    after its forward start, its forward pass after that forward pass's end; and its
    first two groups' first pixels come after the last reads of the banks they write
    (this frame's groups ``G - 2``, ``G - 1``). A short last group costs a whole sweep:
    at ``P_b = P_f = L`` and no gaps the period is ``G n P_b`` (``G`` groups), so the
    vertical blanking is at least ``G n P_b - m (n + hblank)``."""
    starts, info = group_starts(line_first, line_last, n, config, hblank)
    firsts = np.asarray(line_first, dtype=np.int64)
    lanes, back, fwd = info["lanes"], info["backward_cycles"], info["forward_cycles"]
    tb = loop_latency(config)
    hold = sweep_hold(n, info["backward_period"], info["forward_period"], tb)
    reads = (n - 1) * info["backward_period"] + lanes
    (s_last, f_last), groups = starts[-1], starts.shape[0]
    need = [s_last + back - starts[0, 0], f_last + hold - starts[0, 0], f_last + fwd - starts[0, 1]]
    for gi in range(min(2, groups)):  # the next frame's group gi writes group G - 2 + gi's bank
        if groups - 2 + gi >= 0:
            need.append(starts[groups - 2 + gi, 0] + reads - firsts[gi * lanes] - IN_LATENCY)
    return int(max(need))


def output_line_starts(starts: np.ndarray, info: dict[str, int], j0: int, j1: int) -> np.ndarray:
    """The output cycle of the first pixel of lines ``j0 <= j < j1`` (:func:`schedule_rows`:
    pixel ``i`` of a line leaves ``i * info["forward_period"]`` cycles later): the line's
    forward-pass start, its lane's offset in the group, plus the output latency."""
    lanes = info["lanes"]
    lines = np.arange(j0, j1, dtype=np.int64)
    return starts[lines // lanes, 1] + lines % lanes + OUT_LATENCY


def sweep_entry_bits(config: P2Config) -> int:
    """Bits of one sweep-buffer entry: ``D = d_k + d_k+1`` and ``ΔĜ`` (each one bit wider
    than ``d``, ``Ĝ``), ``r``, ``S~_k+1``, ``Q~_k+1``; the forward pass recomputes ``a``
    and ``|D| >= T_D`` from ``D``."""
    f = config.formats
    return (
        (f["p2_d"].word + 1 + f["p2_r"].word + f["p2_st"].word + f["p2_q"].word)
        + f["p2_ghat"].word
        + 1
    )


def buffer_bits(config: P2Config, width: int) -> dict[str, int]:
    """Ping-pong input line buffers (d, Ĝ), two banks of ``lanes`` lines, and one sweep
    buffer of ``lanes`` lines (:func:`sweep_entry_bits`; :func:`sweep_address`)."""
    f = config.formats
    lanes = config.effective_lanes()
    lb = f["p2_d"].word + f["p2_ghat"].word
    sweep = sweep_entry_bits(config)
    return {
        "line_buffer_bits": 2 * lanes * width * lb,
        "sweep_buffer_bits": lanes * width * sweep,
    }


def run_p2(
    case: Case,
    config: P2Config,
    riccati: RiccatiConfig,
    timing: TimingConfig,
    *,
    taps: bool,
    threads: int,
    log: bool,
    lines: tuple[int, int] | None = None,
) -> PipelineResult:
    """P2 on ``case``'s registered stereo pair (E1 = ``case.image1`` left, E2 =
    ``case.image2``, camera 2 displaced ``b`` to the right), integer grey levels, on
    arguments :meth:`~rangefx.rtl_model.pipeline.Pipeline.run` has checked (the public
    entry: ``PIPELINES["p2"].run(case, ...)``); ``riccati`` gives the weights
    (α, β, γ, pixel pitch), ``threshold_e`` and ``range_max`` of golden G5 (its ``form``
    must be ``"lq"`` and ``a_sampling`` ``"edge"``, the discretisation P2 implements).

    ``threads`` (1 or 2): the two halves of the lines run concurrently (the kernels
    release the GIL). ``log`` (as ``fipref``'s LoggingMode): keep the pre-quantisation
    min/max of every signal (``minmax``); off, ``minmax`` is empty and the band kernel
    skips the log. Every output, tap and overflow count is the same either way.
    ``kernel_cpu_s["sweep"]``: CPU seconds of the kernel calls, summed over threads.

    ``lines=(j0, j1)``: only the frame's lines ``j0 <= j < j1`` (the lines are independent:
    a band of a large frame; :func:`rangefx.tools.studies.banded.run_in_bands`). Every
    output has ``j1 - j0`` rows, equal to those rows of the whole frame's run; the cycle
    stamps, latency and ``total_cycles`` are the frame's, for those lines (the schedule
    is the whole frame's); overflows and ``minmax`` count those lines only."""
    if riccati.form != "lq" or riccati.a_sampling != "edge":
        raise ValueError("P2 implements the lq sweep with A at the pixel edge only")
    im1, im2 = runtime.check_image_pair(case.image1, case.image2, case.camera, pipeline="p2",
                                        min_shape=(1, 2), convert=False)  # fmt: skip
    m, n = frame = im1.shape
    r0, r1 = (0, m) if lines is None else lines
    if not 0 <= r0 < r1 <= m:
        raise ValueError(f"lines must be (j0, j1) with 0 <= j0 < j1 <= {m}, not {lines!r}")
    regs = p2_registers(case.camera, case.motion, riccati, config)
    # timing first: an impossible schedule is rejected before any work. Without input
    # gaps the input cycles have a closed form and the bands fill their rows of both
    # cycle maps (serially they took ~0.7 ms of a 5 ms two-thread run); with gaps, the
    # beats of make_stream(im2, timing) are summed here.
    closed_cycles = timing.gap_prob == 0
    if closed_cycles:
        in_cycles = np.empty((r1 - r0, n), dtype=np.int64)
        first = line_starts((m, n), timing)
        starts, sched = group_starts(first, first + (n - 1), n, config, timing.hblank)
    else:
        in_cycles = input_cycles((m, n), timing)[-1]
        starts, sched = group_starts(in_cycles[:, 0], in_cycles[:, -1], n, config, timing.hblank)
        in_cycles = np.ascontiguousarray(in_cycles[r0:r1])
    # from here on, the band's lines only: row j of every array is the frame's line r0 + j
    im1, im2, m = im1[r0:r1], im2[r0:r1], r1 - r0
    out_cycles = np.empty((m, n), dtype=np.int64)
    band_ends: list[tuple[int, int]] = []  # each band's (latency, last output cycle)
    fm = runtime.format_table(config)
    kind, lut = runtime.divider_setup(config)
    out_range = np.empty((m, n), dtype=np.int64)
    out_valid = np.empty((m, n), dtype=np.bool_)
    tp = np.zeros((len(P2_TAPS), m, n) if taps else (len(P2_TAPS), 0, 0), dtype=np.int64)

    banded = BANDED and band_fits(fm)
    modes = cast_modes(fm)  # the band kernel's cast body (plain modes: the short one)
    zf = config.formats["p2_z"]
    range_f = np.empty((m, n), dtype=np.float64)

    cpu: list[float] = []  # CPU seconds of each thread's kernel call (append is atomic)

    def band(j0: int, j1: int):
        stats = runtime.SignalStats(N_SITES, len(P2_SIGNALS))
        st, dst, ov = stats.arrays
        e1 = runtime.kernel_image(im1, "p2.image1", (j0, j1))  # its own lines, on its thread
        e2 = runtime.kernel_image(im2, "p2.image2", (j0, j1))
        t0 = time.thread_time()
        args = (e1, e2, regs.raw, kind, lut, config.recip_bits, fm, st, dst, ov, j0, j1,
                out_range, out_valid, tp, taps)  # fmt: skip
        if banded:
            _p2_bands(*args, log, modes)
        else:
            _p2_kernel(*args)
        cpu.append(time.thread_time() - t0)
        # the band's rows of the float range map and the cycle maps, on the same thread
        band_ends.append(runtime.finish_band(
            out_range[j0:j1], zf.frac, range_f[j0:j1], in_cycles[j0:j1], out_cycles[j0:j1],
            in_starts=line_starts(frame, timing, 0, r0 + j0, r0 + j1) if closed_cycles else None,
            out_starts=output_line_starts(starts, sched, r0 + j0, r0 + j1),
            out_step=sched["forward_period"]))  # fmt: skip
        return stats

    if threads == 2 and m >= 2:
        parts = runtime.run_two(band, (0, m // 2), (m // 2, m))
    else:
        parts = [band(0, m)]
    return build_result(
        "p2", config, timing, "stereo", range_raw=out_range, range_float=range_f,
        valid=out_valid, taps={name: tp[k] for k, name in enumerate(P2_TAPS)} if taps else {},
        stats=runtime.SignalStats.merge(parts, P2_SIGNALS), log=log,
        cycles=(in_cycles, out_cycles), stage_latency=stage_latencies(config), registers=regs,
        buffers=buffer_bits(config, n), band_ends=band_ends, schedule=sched,
        kernel_cpu_s={"sweep": sum(cpu)},
    )  # fmt: skip
