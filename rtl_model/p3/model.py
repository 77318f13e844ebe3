"""P3: the bit-accurate, cycle-faithful multi-scale G6 datapath (SPEC §12).

``docs/multiscale.md`` ("P3: the fixed-point datapath") defines every signal; this module
is the fast implementation of that page (numba kernels on raw int64 values) and
``tests/oracle_p3.py`` an independent slow one. Per level, coarsest first: the pyramid
by the 5-tap binomial reduce, the start estimate expanded (bilinear, doubled) from the
coarser level, then ``warps`` stages of Keys cubic warp of E2, central differences,
the window sums of ``g²``, ``g e``, ``e²`` (separable: row pass, column pass), the
divider ``du = -Σge / Σgg`` and the clipped update — with ``vertical`` (eq 6's vertical
term kept) also ``gy`` from the central differences down the columns, the window sums
of ``gy²``, ``g gy``, ``gy e``, the 2x2 system's ``det`` and ``nu`` and ``du = -nu /
det`` where ``det > 0`` —; at level 0 the residual test (1-D or the 2x2 fit's), the
gradient test and the range divider ``z = f B / u``. Every filter replicates its
borders, as the streaming schedule (:func:`rangefx.golden.multiscale.streaming_schedule`)
does at the frame edges; the values do not depend on timing, the cycle stamps follow
the schedule (:func:`tap_cycles`).

A warp stage runs as line work (:func:`_stage_rows`; the window form then
:func:`_stage_rows_vertical`) then column work (:func:`_stage_columns`), each over every
line of the level; with taps the box form's line work then :func:`_stage_box` (the box's
line and column work interleaved through a ring of its row sums) and
:func:`_stage_rows_corrected` and :func:`_stage_columns` (the correction and the column
work); without taps, the box form as one pass down the lines that interleaves its line
work, box, correction and column work (:func:`_stage_box_fused`), and the 1-D fit as one
pass that interleaves its line and column work through a ring of row sums
(:func:`_stage_fused`). On two threads each runs in two bands of lines with their own
logs (:func:`_in_bands`), merged after.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from fractions import Fraction

import numpy as np
from numba import njit

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.multiscale import MultiscaleConfig, pyramid_levels, streaming_schedule
from rangefx.golden.ranging import RangingConfig

from .. import runtime
from ..config import TimingConfig
from ..fixedpoint import (
    PLAIN_MODES,
    PLAIN_OVERFLOWS,
    PLAIN_QUANTS,
    FixedFormat,
    cast_by_plan,
    cast_modes,
    cast_plan,
    cast_raw,
    cast_row,
)
from ..kernels import at_frac as _at
from ..kernels import divide_lanes_fit, divide_row_lanes, log_site, signal_plan
from ..kernels import divide_row as _divide_row
from ..pipeline import Case, PipelineResult, build_result
from ..runtime import DIV_RECIPROCAL, KERNEL_INT, KERNEL_PLANE, KERNEL_ROW
from ..stream import input_cycles, line_cycles
from .config import P3_SIGNALS, P3Config

# argument types of the window helpers: an explicit signature, so that the constant signal
# and site indices they are called with do not compile one copy each
_I, _R, _P = KERNEL_INT, KERNEL_ROW, KERNEL_PLANE

__all__ = [
    "BAND_PIXELS",
    "BOX_TAPS",
    "N_SITES",
    "UNROLLED_RADIUS",
    "VERTICAL_TAPS",
    "WARP_TAPS",
    "P3Registers",
    "box_row_bits",
    "buffer_bits",
    "keys_exact",
    "keys_rom",
    "keys_rom_casts",
    "keys_weights",
    "level_shapes",
    "p3_registers",
    "p3_schedule",
    "run_p3",
    "stage_latencies",
    "stereo_baseline",
    "tap_cycles",
    "tap_names",
    "tap_offsets",
]

_SIG = {name: k for k, name in enumerate(P3_SIGNALS)}
PIX, NBOX, NORM, PYR, GRAD, KEYS, WARP, G, GY, E, WIN = (
    _SIG[s] for s in ("p3_pix", "p3_nbox", "p3_norm", "p3_pyr", "p3_grad", "p3_keys",
                      "p3_warp", "p3_g", "p3_gy", "p3_e", "p3_win")
)  # fmt: skip
RYY, RGY, RYE, SYY, SGY, SYE, DET, NU, NV = (
    _SIG[s] for s in ("p3_ryy", "p3_rgy", "p3_rye", "p3_syy", "p3_sgy", "p3_sye", "p3_det",
                      "p3_nu", "p3_nv")
)  # fmt: skip
BGG, BGE, BYY, BGY, BYE, BDET, BNV, V, EV = (
    _SIG[s] for s in ("p3_bgg", "p3_bge", "p3_byy", "p3_bgy", "p3_bye", "p3_bdet", "p3_bnv",
                      "p3_v", "p3_ev")
)  # fmt: skip
RGG, RGE, REE, SGG, SGE, SEE, DU, U, RES, TR2, FB, RANGE = (
    _SIG[s] for s in ("p3_rgg", "p3_rge", "p3_ree", "p3_sgg", "p3_sge", "p3_see", "p3_du",
                      "p3_u", "p3_res", "p3_tr2", "p3_fb", "p3_range")
)  # fmt: skip

# cast sites (each logs its own raw min/max at one frac_in)
S_PIX1, S_PIX2, S_PYR0, S_PYR1, S_EXPAND, S_RES, S_RTHR = range(7)
#: Normalisation sites, per stream: level 0 (from ``p3_pix``), the coarser levels (from
#: ``p3_pyr``).
S_NORM = ((7, 8), (9, 10))
#: Per-level sites: base + offset, base ``S_LEVEL`` at level 0, ``S_LEVEL + N_LEVEL_SITES``
#: at the coarser levels (the pixels the warps read at ``p3_pix``'s / ``p3_pyr``'s
#: fraction bits, or at ``p3_norm``'s at every level when normalising); ``L_AY`` on are
#: the vertical term's, ``L_BGG`` on its box form's.
S_LEVEL = 11
L_AX, L_WARP, L_WX, L_G, L_E, L_RGG, L_RGE, L_REE, L_SGG, L_SGE, L_SEE, L_U = range(12)
L_AY, L_WY, L_GY, L_RYY, L_RGY, L_RYE, L_SYY, L_SGY, L_SYE, L_DET, L_NU = range(12, 23)
L_BGG, L_BGE, L_BYY, L_BGY, L_BYE, L_BDET, L_BNV, L_EV = range(23, 31)
N_LEVEL_SITES = 31
#: The vertical residual's ``nv`` (level 0, once).
S_NV = S_LEVEL + 2 * N_LEVEL_SITES
N_SITES = S_NV + 1

#: Taps of one warp stage at level 0 (tap name = base + warp index, e.g. ``warp0``).
WARP_TAPS = ("warp", "wx", "g", "err", "rgg", "rge", "ree", "sgg", "sge", "see", "du", "u")
#: The vertical term's taps of one warp stage (after :data:`WARP_TAPS`).
VERTICAL_TAPS = ("wy", "gy", "ryy", "rgy", "rye", "syy", "sgy", "sye", "det", "nu")
#: The box form's taps of one warp stage (after :data:`WARP_TAPS`); the box's (sums,
#: ``bdet``, ``bnv``, ``v``) of line ``y`` are those line ``y`` uses, of the box centred
#: ``vertical_radius`` lines up (top lines: line 0's).
BOX_TAPS = ("wy", "gy", "bgg", "bge", "byy", "bgy", "bye", "bdet", "bnv", "v", "ev")
N_STAGE_TAPS = len(WARP_TAPS)
#: The five box sums, in the order of :data:`BOX_TAPS` (signals, cast sites).
_BOX_SIGNALS = np.array([BGG, BGE, BYY, BGY, BYE], dtype=np.int64)
_BOX_SITES = np.array([L_BGG, L_BGE, L_BYY, L_BGY, L_BYE], dtype=np.int64)
#: Window sums a level leaves for the output stage (:func:`_final_kernel`), in this order.
N_SUMS = 8
#: The 5-tap binomial of the reduce (weights / 16 per pass).
_BINOM = np.array([1, 4, 6, 4, 1], dtype=np.int64)
_KEYS_A = -0.5


def _stage_taps(config: P3Config) -> tuple[str, ...]:
    """The tap base names of one warp stage."""
    form = config.vertical_form
    return WARP_TAPS + {"off": (), "window": VERTICAL_TAPS, "box": BOX_TAPS}[form]


def tap_names(config: P3Config) -> tuple[str, ...]:
    """Every tap of a run with taps, in pipeline order (all at level 0)."""
    v = bool(config.vertical)
    warps = tuple(f"{t}{k}" for k in range(config.warps) for t in _stage_taps(config))
    head = ("ax", "u_start", "ay") if v else ("ax", "u_start")
    tail = ("res", "rthr", "valid", "range")
    return (*head, *warps, *(("nv", *tail) if config.vertical_form == "window" else tail))


# --------------------------------------------------------------------------------------
# kernels: raw int64 arithmetic only
# --------------------------------------------------------------------------------------
@njit((_R, _I, _I, _I, _P, _P, _R, _R), cache=True, nogil=True)
def _cast_logged_row(acc, f_in, s, site, fm, st, ov, out):
    """``cast(acc[x], s)`` for a whole row with :func:`cast_row`, logged at ``site`` as
    :func:`cast_site` logs each element (the same min/max, ``frac_in`` and counts), once
    per row: the per-element log stores kept the window loops from vectorising. An
    explicit signature: the constant signal, site and ``frac_in`` it is called with would
    otherwise compile a copy of ``cast_row`` per constant (tests/test_compile.py)."""
    lo, hi, flags = cast_row(acc, f_in, fm[s, 0], fm[s, 1], fm[s, 2] != 0, fm[s, 3], fm[s, 4], out)
    st[site, 0] = min(st[site, 0], lo)
    st[site, 1] = max(st[site, 1], hi)
    st[site, 2] = f_in
    st[site, 3] = s
    ov[s] += flags


_PQ0, _PQ1, _PQ2 = PLAIN_QUANTS
_PO0, _PO1 = PLAIN_OVERFLOWS
_I64_MAX, _I64_MIN = np.iinfo(np.int64).max, np.iinfo(np.int64).min


@njit(cache=True, nogil=True, inline="always")
def _fused_cast(f_in, s, fm):
    """``(fuse, plan)`` of a cast of values at ``f_in`` fraction bits into signal ``s``:
    ``fuse`` when its modes are plain (:data:`~rangefx.rtl_model.fixedpoint.PLAIN_QUANTS`,
    :data:`~rangefx.rtl_model.fixedpoint.PLAIN_OVERFLOWS`) and ``|shift| <= 62``, so that
    the loop that produces the values casts each with
    :func:`~rangefx.rtl_model.fixedpoint.cast_by_plan` (the plain body, selects only),
    keeping the log's min/max and the overflow count in registers (:func:`_fused_log`),
    instead of writing the row and casting it in a pass of its own
    (:func:`_cast_logged_row`): the same values, log and count. A window column pass
    and its cast took 0.98 against 1.36 ns a pixel, the box form's correction and
    column work (:func:`_stage_box_tail_lines`) 12.6 against 15.3 ns a pixel and stage
    (512 x 512 ``lab``, one thread, AMD EPYC Zen 4); any other cast (a mode that is not
    plain, a shift beyond 62 bits) keeps the row cast."""
    sh = f_in - fm[s, 1]
    q, o = fm[s, 3], fm[s, 4]
    fuse = (abs(sh) <= 62 and (q == _PQ0 or q == _PQ1 or q == _PQ2)
            and (o == _PO0 or o == _PO1))  # fmt: skip
    plan = cast_plan(min(max(sh, np.int64(-62)), np.int64(62)), fm[s, 0], fm[s, 2] != 0, q, o)
    return fuse, plan


@njit(cache=True, nogil=True, inline="always")
def _fused_log(lo, hi, count, f_in, s, site, st, ov):
    """The log and overflow count of a cast made in the loop that forms its values
    (:func:`_logged_cast`; :func:`_fused_cast`), as :func:`_cast_logged_row` keeps them."""
    log_site(st, site, lo, hi, f_in, s)
    ov[s] += count


@njit(cache=True, nogil=True, inline="always")
def _logged_cast(raw, plan, modes, lo, hi, count):
    """``raw`` cast by ``plan`` (:func:`~rangefx.rtl_model.kernels.signal_plan`,
    ``|shift| <= 62``; :func:`cast_by_plan`), and the running raw min, max and overflow
    count of a loop that casts a line an element at a time (as ``cast_row`` logs the
    line): ``(value, lo, hi, count)``."""
    value, flag = cast_by_plan(raw, plan, modes)
    return value, min(lo, raw), max(hi, raw), count + flag


@njit(cache=True, nogil=True)
def _input_kernel(img, site, fm, st, ov, out):
    """The input cast of one stream (an integer image of any dtype, each grey level as
    an int64) into ``p3_pix``, in the loop that reads the image (:func:`_fused_cast`)."""
    m, n = img.shape
    row = np.empty(n, dtype=np.int64)
    fuse, plan = _fused_cast(np.int64(0), PIX, fm)
    for y in range(m):
        src, dst = img[y], out[y]
        if fuse:
            lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
            for x in range(n):
                t = np.int64(src[x])
                dst[x], lo, hi, count = _logged_cast(t, plan, PLAIN_MODES, lo, hi, count)
            _fused_log(lo, hi, count, np.int64(0), PIX, site, st, ov)
            continue
        for x in range(n):
            row[x] = src[x]
        _cast_logged_row(row, 0, PIX, site, fm, st, ov, dst)


@njit(cache=True, nogil=True)
def _normalise_kernel(p, f_p, c, f_c, radius, site, fm, st, ov, out):
    """Local mean removal over the ``(2 R + 1)²`` box (replicated borders):
    ``N = E - c Σ_box E`` with ``c`` the ``p3_nbox`` register (``1 / (2R + 1)²``), exact
    (``E 2^f_c - c Σ``), cast once into ``p3_norm``. The box sum runs down the columns
    first (one line in, one out: a loop that vectorises), then along the line of column
    sums (with ``R`` replicated sums either side: a running sum without a clamp); no
    plane of row sums is written, and the cast runs in the loop that forms ``N``
    (:func:`_fused_cast`): the same integer sums as rows then columns (exact); 0.61
    against 0.70 ms for a 512 x 512 stream's five levels with a plane of clamped row
    sums (one thread, AMD EPYC Zen 4; prefix sums along the line instead of the running
    sum measured no faster)."""
    m, n = p.shape
    col = np.zeros(n, dtype=np.int64)
    for k in range(-radius, radius + 1):
        col += p[min(max(k, 0), m - 1)]
    pad = np.empty(n + 2 * radius, dtype=np.int64)
    body = pad[radius : radius + n]
    box = np.empty(n, dtype=np.int64)
    acc = np.empty(n, dtype=np.int64)
    f_in = f_p + f_c
    fuse, plan = _fused_cast(f_in, NORM, fm)
    width = 2 * radius + 1
    for y in range(m):
        if y:  # the column sums run down the lines
            add, drop = p[min(y + radius, m - 1)], p[max(y - radius - 1, 0)]
            for x in range(n):
                col[x] += add[x] - drop[x]
        for x in range(n):
            body[x] = col[x]
        for k in range(radius):  # the replicated column sums
            pad[k] = col[0]
            pad[n + radius + k] = col[n - 1]
        s = np.int64(0)
        for k in range(width):
            s += pad[k]
        box[0] = s
        for x in range(1, n):  # pixel x's box: pixel x - 1's, one column in, one out
            s += pad[x + width - 1] - pad[x - 1]
            box[x] = s
        pl, ol = p[y], out[y]
        if fuse:
            lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
            for x in range(n):
                t = (pl[x] << f_c) - c * box[x]
                ol[x], lo, hi, count = _logged_cast(t, plan, PLAIN_MODES, lo, hi, count)
            _fused_log(lo, hi, count, f_in, NORM, site, st, ov)
            continue
        for x in range(n):
            acc[x] = (pl[x] << f_c) - c * box[x]
        _cast_logged_row(acc, f_in, NORM, site, fm, st, ov, ol)


@njit(cache=True, nogil=True)
def _reduce_kernel(p, f_p, site, fm, st, ov):
    """One pyramid step: the 5-tap binomial along the rows at even columns, then down the
    columns at even rows (replicated borders), exact, cast once into ``p3_pyr``. Each
    line is copied with two replicated pixels either side, so that the taps need no
    clamp, and the five taps are one unrolled sum (the symmetric ones paired); the cast
    runs in the column pass's loop (:func:`_fused_cast`): 0.24 against 0.42 ms for a
    512 x 512 stream's four steps with a clamp per tap (one thread, AMD EPYC Zen 4)."""
    m, n = p.shape
    mc, nc = (m + 1) // 2, (n + 1) // 2
    b0, b1, b2 = _BINOM[0], _BINOM[1], _BINOM[2]  # symmetric: b3 = b1, b4 = b0
    row = np.empty((m, nc), dtype=np.int64)
    pad = np.empty(n + 4, dtype=np.int64)
    body = pad[2 : n + 2]
    for y in range(m):
        src, dst = p[y], row[y]
        for x in range(n):
            body[x] = src[x]
        pad[0] = pad[1] = src[0]
        pad[n + 2] = pad[n + 3] = src[n - 1]
        for xc in range(nc):  # taps 2 xc - 2 .. 2 xc + 2: pad[2 xc .. 2 xc + 4]
            x = 2 * xc
            dst[xc] = b0 * (pad[x] + pad[x + 4]) + b1 * (pad[x + 1] + pad[x + 3]) + b2 * pad[x + 2]
    out = np.empty((mc, nc), dtype=np.int64)
    acc = np.empty(nc, dtype=np.int64)
    f_in = f_p + 8
    fuse, plan = _fused_cast(f_in, PYR, fm)
    for yc in range(mc):
        r0, r1, r2 = row[max(2 * yc - 2, 0)], row[max(2 * yc - 1, 0)], row[min(2 * yc, m - 1)]
        r3, r4 = row[min(2 * yc + 1, m - 1)], row[min(2 * yc + 2, m - 1)]
        if fuse:
            lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
            ol = out[yc]
            for xc in range(nc):
                t = b0 * (r0[xc] + r4[xc]) + b1 * (r1[xc] + r3[xc]) + b2 * r2[xc]
                ol[xc], lo, hi, count = _logged_cast(t, plan, PLAIN_MODES, lo, hi, count)
            _fused_log(lo, hi, count, f_in, PYR, site, st, ov)
            continue
        for xc in range(nc):
            acc[xc] = b0 * (r0[xc] + r4[xc]) + b1 * (r1[xc] + r3[xc]) + b2 * r2[xc]
        _cast_logged_row(acc, f_in, PYR, site, fm, st, ov, out[yc])
    return out


@njit(cache=True, nogil=True)
def _expand_kernel(uc, m, n, fm, st, ov):
    """The coarse estimate at the finer level: bilinear at (y/2, x/2), doubled, exact
    (``2 Σ w u`` with weights 1 or ½ per axis), cast into ``p3_u``."""
    mc, nc = uc.shape
    f_u = fm[U, 1]
    out = np.empty((m, n), dtype=np.int64)
    acc = np.empty(n, dtype=np.int64)
    for y in range(m):
        y0 = y // 2
        y1 = min(y0 + 1, mc - 1)
        for x in range(n):
            x0 = x // 2
            x1 = min(x0 + 1, nc - 1)
            if y & 1:
                if x & 1:
                    s = uc[y0, x0] + uc[y0, x1] + uc[y1, x0] + uc[y1, x1]
                else:
                    s = 2 * (uc[y0, x0] + uc[y1, x0])
            elif x & 1:
                s = 2 * (uc[y0, x0] + uc[y0, x1])
            else:
                s = 4 * uc[y0, x0]
            acc[x] = s
        _cast_logged_row(acc, f_u + 1, U, S_EXPAND, fm, st, ov, out[y])
    return out


#: Window radius up to which the row and column passes run every tap in one unrolled
#: expression per pixel (the taps beyond the radius weighted 0: the same integer sum).
UNROLLED_RADIUS = 4


@njit((_R,), cache=True, nogil=True)
def _window_taps(win):
    """The window's weights ``w_1 .. w_4`` (of ``w_0 .. w_r``, ``r <= 4``), 0 beyond ``r``."""
    r = win.shape[0] - 1
    zero = np.int64(0)
    return (win[1] if r >= 1 else zero, win[2] if r >= 2 else zero,
            win[3] if r >= 3 else zero, win[4] if r >= 4 else zero)  # fmt: skip


@njit(cache=True, nogil=True, inline="always")
def _pad_product(p, q, rp, pad):
    """The product ``p q`` of a line into ``pad`` with ``rp`` replicated pixels either
    side (:func:`_window_row`)."""
    n = p.shape[0]
    body = pad[rp : rp + n]  # a slice: pad[x + rp] did not vectorise (_box_rows_line)
    for x in range(n):
        body[x] = p[x] * q[x]
    for k in range(rp):  # the replicated borders
        pad[k] = pad[rp]
        pad[n + rp + k] = pad[n + rp - 1]


@njit(cache=True, nogil=True, inline="always")
def _unrolled_sum(pad, x, w0, w1, w2, w3, w4):
    """The window's row sum at pixel ``x`` of a line padded by :data:`UNROLLED_RADIUS`
    (:func:`_window_row`): every tap one term, the symmetric ones paired."""
    return (w0 * pad[x + 4] + w1 * (pad[x + 3] + pad[x + 5]) + w2 * (pad[x + 2] + pad[x + 6])
            + w3 * (pad[x + 1] + pad[x + 7]) + w4 * (pad[x] + pad[x + 8]))  # fmt: skip


@njit((_R, _R, _I, _R, _I, _I, _P, _P, _R, _R, _R, _R), cache=True, nogil=True)
def _window_row(p, q, f_in, win, s, site, fm, st, ov, pad, acc, out):
    """Row pass of the window on one line of the product ``p q`` (``f_in`` fraction bits:
    the product's plus the window's): ``Σ_k w_|k| (p q)[x + k]``, replicated borders,
    cast into ``s``. The product is formed as the line is copied with its replicated
    borders (``pad``, ``n + 2 max(r, UNROLLED_RADIUS)`` long), so no product plane is
    written, the taps need no clamp, and the symmetric taps are paired. Up to
    :data:`UNROLLED_RADIUS` every tap is one term of an unrolled sum per pixel (the taps
    beyond the radius weighted 0); a wider window accumulates a tap at a time over the
    whole line, reading two slices of ``pad``. Either is the same integer sum (int64,
    wrapping), in a loop LLVM vectorises (the unrolled sum 2x faster than a tap at a
    time, itself 6x faster than a pixel at a time with an inner loop over the taps,
    measured on a 512-pixel line)."""
    n = p.shape[0]
    r = win.shape[0] - 1
    rp = max(r, UNROLLED_RADIUS)
    _pad_product(p, q, rp, pad)
    w0 = win[0]
    fuse, plan = _fused_cast(f_in, s, fm)
    if r <= UNROLLED_RADIUS and fuse:  # the cast in the sum's loop
        w1, w2, w3, w4 = _window_taps(win)
        lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
        for x in range(n):
            t = _unrolled_sum(pad, x, w0, w1, w2, w3, w4)
            out[x], lo, hi, count = _logged_cast(t, plan, PLAIN_MODES, lo, hi, count)
        _fused_log(lo, hi, count, f_in, s, site, st, ov)
        return
    if r <= UNROLLED_RADIUS:
        w1, w2, w3, w4 = _window_taps(win)
        for x in range(n):
            acc[x] = _unrolled_sum(pad, x, w0, w1, w2, w3, w4)
    else:
        mid = pad[r : r + n]
        for x in range(n):
            acc[x] = w0 * mid[x]
        for k in range(1, r + 1):
            wk = win[k]
            before, after = pad[r - k : r - k + n], pad[r + k : r + k + n]
            for x in range(n):
                acc[x] += wk * (before[x] + after[x])
    _cast_logged_row(acc, f_in, s, site, fm, st, ov, out)


@njit((_R, _R), cache=True, nogil=True)
def _row_difference(p, out):
    """Central difference along a line (replicated borders), exact: ``p[x + 1] - p[x -
    1]``; the two border pixels apart, so that the loop over the others has no clamp
    and vectorises."""
    n = p.shape[0]
    for x in range(1, n - 1):
        out[x] = p[x + 1] - p[x - 1]
    out[0] = p[min(1, n - 1)] - p[0]
    out[n - 1] = p[n - 1] - p[max(n - 2, 0)]


@njit((_I, _I, _I, _I), cache=True, nogil=True)
def _ring_line(y, k, m, rows):
    """Slot of line ``y + k`` of an ``m``-line level (replicated borders: clamped) in a
    buffer of ``rows`` lines holding line ``l`` at ``l % rows`` (a whole plane: ``rows =
    m``, the line itself)."""
    return min(max(y + k, 0), m - 1) % rows


@njit((_P, _R, _I, _I, _I, _I, _I, _P, _P, _R, _R, _R), cache=True, nogil=True)
def _window_col_line(p, win, y, m, s_in, s, site, fm, st, ov, acc, out):
    """Column pass of the window at line ``y`` of an ``m``-line level on the row sums
    ``p`` of signal ``s_in`` (replicated borders), cast into ``s`` (``out``); accumulated
    a whole row at a time (the clamped line index once per tap), every line in one
    unrolled sum up to :data:`UNROLLED_RADIUS`. ``p`` is the level's plane or a ring of
    its lines (:func:`_ring_line`)."""
    rows, n = p.shape
    r = win.shape[0] - 1
    f_in = fm[WIN, 1] + fm[s_in, 1]
    mid = p[_ring_line(y, 0, m, rows)]
    w0 = win[0]
    if r <= UNROLLED_RADIUS:  # as _window_row: the lines beyond the radius weighted 0
        w1, w2, w3, w4 = _window_taps(win)
        a1, b1 = p[_ring_line(y, -1, m, rows)], p[_ring_line(y, 1, m, rows)]
        a2, b2 = p[_ring_line(y, -2, m, rows)], p[_ring_line(y, 2, m, rows)]
        a3, b3 = p[_ring_line(y, -3, m, rows)], p[_ring_line(y, 3, m, rows)]
        a4, b4 = p[_ring_line(y, -4, m, rows)], p[_ring_line(y, 4, m, rows)]
        fuse, plan = _fused_cast(f_in, s, fm)
        if fuse:  # the cast in the sum's loop, as _window_row
            lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
            for x in range(n):
                t = (w0 * mid[x] + w1 * (a1[x] + b1[x]) + w2 * (a2[x] + b2[x])
                     + w3 * (a3[x] + b3[x]) + w4 * (a4[x] + b4[x]))  # fmt: skip
                out[x], lo, hi, count = _logged_cast(t, plan, PLAIN_MODES, lo, hi, count)
            _fused_log(lo, hi, count, f_in, s, site, st, ov)
            return
        for x in range(n):
            acc[x] = (w0 * mid[x] + w1 * (a1[x] + b1[x]) + w2 * (a2[x] + b2[x])
                      + w3 * (a3[x] + b3[x]) + w4 * (a4[x] + b4[x]))  # fmt: skip
    else:
        for x in range(n):
            acc[x] = w0 * mid[x]
        for k in range(1, r + 1):
            above, below = p[_ring_line(y, -k, m, rows)], p[_ring_line(y, k, m, rows)]
            w = win[k]
            for x in range(n):
                acc[x] += w * (above[x] + below[x])
    _cast_logged_row(acc, f_in, s, site, fm, st, ov, out)


@njit((_P, _I, _I, _I, _I, _P, _P, _R, _R, _R), cache=True, nogil=True)
def _column_difference_line(p, y, f_p, s, site, fm, st, ov, row, out):
    """Central difference down the columns at line ``y`` (replicated borders), cast into
    ``s`` (``out``): the line below minus the line above, exact at ``f_p + 1`` fraction
    bits (the ½)."""
    m, n = p.shape
    below, above = p[min(y + 1, m - 1)], p[max(y - 1, 0)]
    for x in range(n):
        row[x] = below[x] - above[x]
    _cast_logged_row(row, f_p + 1, s, site, fm, st, ov, out)


@njit(cache=True, nogil=True)
def _difference_lines(a, f_l, site, fm, st, ov, ax, y0, y1):
    """Lines ``y0 <= y < y1`` of E1's central difference along the rows ``ax`` (a level's
    first stage), cast into ``p3_grad`` at ``site``."""
    row = np.empty(a.shape[1], dtype=np.int64)
    for y in range(y0, y1):
        _row_difference(a[y], row)
        _cast_logged_row(row, f_l + 1, GRAD, site, fm, st, ov, ax[y])


@njit(cache=True, nogil=True, inline="always")
def _wx_g_e(d, axv, av, wv, plans, sa, sw, modes):
    """One pixel of :func:`_wx_g_e_line` from W's central difference ``d``: the raw
    values and casts of ``Wx``, ``g = ax + Wx`` and ``e = E1 - W`` (aligned by the left
    shifts ``sa``, ``sw``)."""
    wx, f0 = cast_by_plan(d, plans[0], modes)
    graw = axv + wx
    g, f1 = cast_by_plan(graw, plans[1], modes)
    eraw = (av << sa) - (wv << sw)
    e, f2 = cast_by_plan(eraw, plans[2], modes)
    return wx, g, graw, e, eraw, f0, f1, f2


@njit(cache=True, nogil=True)
def _wx_g_e_line(wl, axl, al, plans, sa, sw, modes, wxl, gl, el, logs):
    """A line's ``Wx`` (W's central difference, replicated borders), ``g = ax + Wx``,
    ``e = E1 - W``, each cast by its plan (``plans``: Wx's, g's, e's; ``|shift| <= 62``)
    into ``wxl``, ``gl``, ``el`` in one loop over the line's inner pixels (the two border
    pixels apart, so that the loop has no clamp); each cast's raw min, max and overflow
    count into ``logs`` (3 x 3), as ``cast_row`` gives them. One pass, not five or six
    (a difference, three casts, the sums): :func:`_stage_rows` over a 512 x 512 level
    took 11.4 against 12.9 ns a pixel (one thread, AMD EPYC Zen 4, shared)."""
    n = wl.shape[0]
    big, small, zero = np.int64(_I64_MAX), np.int64(_I64_MIN), np.int64(0)
    lo0, hi0, lo1, hi1, lo2, hi2, k0, k1, k2 = big, small, big, small, big, small, zero, zero, zero
    # the borders first: x = 0 and x = n - 1 (one pixel when n = 1)
    for x in range(0, n, max(n - 1, 1)):
        d = wl[min(x + 1, n - 1)] - wl[max(x - 1, 0)]
        wx, g, graw, e, eraw, f0, f1, f2 = _wx_g_e(d, axl[x], al[x], wl[x], plans, sa, sw, modes)
        wxl[x], gl[x], el[x] = wx, g, e
        lo0, hi0, k0 = min(lo0, d), max(hi0, d), k0 + f0
        lo1, hi1, k1 = min(lo1, graw), max(hi1, graw), k1 + f1
        lo2, hi2, k2 = min(lo2, eraw), max(hi2, eraw), k2 + f2
    # the inner pixels, x = i + 1: every index a loop index plus a constant
    for i in range(n - 2):
        d = wl[i + 2] - wl[i]
        wx, g, graw, e, eraw, f0, f1, f2 = _wx_g_e(d, axl[i + 1], al[i + 1], wl[i + 1], plans,
                                                   sa, sw, modes)  # fmt: skip
        wxl[i + 1] = wx
        gl[i + 1] = g
        el[i + 1] = e
        lo0, hi0, k0 = min(lo0, d), max(hi0, d), k0 + f0
        lo1, hi1, k1 = min(lo1, graw), max(hi1, graw), k1 + f1
        lo2, hi2, k2 = min(lo2, eraw), max(hi2, eraw), k2 + f2
    logs[0, 0], logs[0, 1], logs[0, 2] = lo0, hi0, k0
    logs[1, 0], logs[1, 1], logs[1, 2] = lo1, hi1, k1
    logs[2, 0], logs[2, 1], logs[2, 2] = lo2, hi2, k2


@njit(cache=True, nogil=True)
def _stage_rows(
    a, b, u, u_off, ax, f_l, rom, keys_bits, win, base, modes, fm, st, ov, w, wx, g, e, rgg,
    rge, ree, y0, y1, fit_e,
):  # fmt: skip
    """Lines ``y0 <= y < y1`` of one warp stage's line work on E1 ``a``, E2 ``b`` (``f_l``
    fraction bits) with E1's central difference ``ax`` (:func:`_difference_lines`) at the
    estimate ``u`` (line ``y`` at ``u[y - u_off]``): the warp ``W(x) = E2(x - u)`` from
    the row buffer (Keys weights from the ROM), ``Wx``, ``g`` and ``e``, and the window's
    row pass on the three products (formed as the row pass reads them: no product
    plane), line ``y`` of each into its line ``y % rows`` (a plane, or a ring of lines:
    :func:`_ring_line`). Each line needs only its own line of every input: two bands of
    lines run on two threads. ``w``, ``g``, ``e`` are planes to keep (taps, the vertical
    term) or, with no lines, not kept: each line then lives in a line buffer (four planes
    fewer written per stage); ``wx`` the same, kept for the taps only. Without ``fit_e``
    (the box form) the row passes on ``g e`` and ``e²`` are left to
    :func:`_stage_rows_corrected`."""
    n = a.shape[1]
    f_u, f_grad, f_warp, f_keys = fm[U, 1], fm[GRAD, 1], fm[WARP, 1], fm[KEYS, 1]
    f_g, f_e = fm[G, 1], fm[E, 1]
    fe = max(f_l, f_warp)
    mask = (np.int64(1) << f_u) - 1
    # the position x - u rounded to keys_bits fraction bits (half an index step added)
    half = np.int64(1) << (f_u - keys_bits - 1) if f_u > keys_bits else np.int64(0)
    row = np.empty(n, dtype=np.int64)
    row2 = np.empty(n, dtype=np.int64)
    lines = np.empty((4, n), dtype=np.int64)  # w, wx, g, e of a line when not kept
    keep, keep_wx = w.shape[0] > 0, wx.shape[0] > 0
    r = win.shape[0] - 1
    pad = np.empty(n + 2 * max(r, UNROLLED_RADIUS), dtype=np.int64)
    f_wgg, f_wge, f_wee = fm[WIN, 1] + 2 * f_g, fm[WIN, 1] + f_g + f_e, fm[WIN, 1] + 2 * f_e
    # the ROM (its four weights of a fraction side by side), and E2's line with three
    # replicated pixels either side: the four taps at i0 - 1 .. i0 + 2 are then bp[i0 + 2
    # .. i0 + 5] once i0 is clamped to -2 .. n (beyond, every tap reads the border pixel
    # anyway): one clamp a pixel instead of four, and a loop without a branch. The
    # positions and ROM rows of a line first, in a loop of their own (it vectorises),
    # then the gather: 3.05 against 3.75 ns a pixel with the two in one loop reading the
    # ROM's four columns (a 512-pixel line, one thread)
    rom4 = rom.copy()
    bp = np.empty(n + 6, dtype=np.int64)
    body = bp[3 : n + 3]
    taps = np.empty(n, dtype=np.int64)  # i0 + 2: the first tap's index in bp
    frac = np.empty(n, dtype=np.int64)  # the ROM row
    lo, hi = np.int64(-2), np.int64(n)
    down = f_u >= keys_bits
    sh = f_u - keys_bits if down else keys_bits - f_u
    # Wx, g and e of a line in one loop (_wx_g_e_line) where every shift is within
    # |shift| <= 62, else a loop per difference and per cast
    sa, sw = fe - f_l, fe - f_warp
    short = max(abs(f_warp + 1 - f_grad), abs(f_grad + 1 - f_g), abs(fe - f_e)) <= 62
    plans = (signal_plan(f_warp + 1, GRAD, fm), signal_plan(f_grad + 1, G, fm),
             signal_plan(fe, E, fm))  # fmt: skip
    logs = np.empty((3, 3), dtype=np.int64)
    rows = rgg.shape[0]
    for y in range(y0, y1):
        al, bl, ul = a[y], b[y], u[y - u_off]
        for k in range(3):
            bp[k] = bl[0]
            bp[n + 3 + k] = bl[n - 1]
        for x in range(n):
            body[x] = bl[x]
        if down:
            for x in range(n):
                src = (np.int64(x) << f_u) - ul[x] + half
                taps[x] = min(max(src >> f_u, lo), hi) + 2
                frac[x] = (src & mask) >> sh
        else:
            for x in range(n):
                src = (np.int64(x) << f_u) - ul[x] + half
                taps[x] = min(max(src >> f_u, lo), hi) + 2
                frac[x] = (src & mask) << sh
        for x in range(n):
            i0, k = taps[x], rom4[frac[x]]
            row[x] = k[0] * bp[i0] + k[1] * bp[i0 + 1] + k[2] * bp[i0 + 2] + k[3] * bp[i0 + 3]
        wl = w[y] if keep else lines[0]
        wxl = wx[y] if keep_wx else lines[1]
        gl, el = (g[y], e[y]) if keep else (lines[2], lines[3])
        _cast_logged_row(row, f_keys + f_l, WARP, base + L_WARP, fm, st, ov, wl)
        axl = ax[y]
        if short:
            _wx_g_e_line(wl, axl, al, plans, sa, sw, modes, wxl, gl, el, logs)
            _fused_log(logs[0, 0], logs[0, 1], logs[0, 2], f_warp + 1, GRAD, base + L_WX, st, ov)
            _fused_log(logs[1, 0], logs[1, 1], logs[1, 2], f_grad + 1, G, base + L_G, st, ov)
            _fused_log(logs[2, 0], logs[2, 1], logs[2, 2], fe, E, base + L_E, st, ov)
        else:
            _row_difference(wl, row)
            _cast_logged_row(row, f_warp + 1, GRAD, base + L_WX, fm, st, ov, wxl)
            for x in range(n):
                row[x] = axl[x] + wxl[x]
                row2[x] = _at(al[x], f_l, fe) - _at(wl[x], f_warp, fe)
            _cast_logged_row(row, f_grad + 1, G, base + L_G, fm, st, ov, gl)
            _cast_logged_row(row2, fe, E, base + L_E, fm, st, ov, el)
        j = y % rows
        _window_row(gl, gl, f_wgg, win, RGG, base + L_RGG, fm, st, ov, pad, row, rgg[j])
        if fit_e:
            _window_row(gl, el, f_wge, win, RGE, base + L_RGE, fm, st, ov, pad, row, rge[j])
            _window_row(el, el, f_wee, win, REE, base + L_REE, fm, st, ov, pad, row, ree[j])


@njit(cache=True, nogil=True)
def _combine_cast(p, q, neg, plan, modes, out):
    """``p + q`` (``neg = 0``) or ``p - q`` (``neg = -1``) cast by ``plan``
    (:func:`~rangefx.rtl_model.kernels.signal_plan`, ``|shift| <= 62``) into ``out`` in
    one loop; returns the raw min, max and overflow count (as ``cast_row`` gives them)."""
    lo, hi, count = np.int64(_I64_MAX), np.int64(_I64_MIN), np.int64(0)
    for x in range(out.shape[0]):
        s = p[x] + ((q[x] ^ neg) - neg)
        out[x], lo, hi, count = _logged_cast(s, plan, modes, lo, hi, count)
    return lo, hi, count


@njit(cache=True, nogil=True)
def _gy_line(a, w, ayl, y, f_l, base, first, modes, fm, st, ov, row, wyl, gyl):
    """Line ``y`` of ``gy = (E1y + Wy) / 2`` into ``gyl``, ``Wy`` into ``wyl``: the column
    differences read lines ``y ± 1`` of E1 ``a`` and W ``w``; E1's (``ayl``) is taken in
    the level's ``first`` stage, read after. Each cast in the loop that forms its value
    (:func:`_combine_cast`) where every shift is within ``|shift|
    <= 62``, else a loop per difference and per cast: three passes over the line, not
    seven (1.60 against 1.95 ns a pixel in a level's first stage, 1.22 against 1.25 in
    the others, 16 lines in cache, plain modes, AMD EPYC Zen 4; the passes saved count
    most over a level's planes, out of cache)."""
    m, n = a.shape
    f_grad, f_warp = fm[GRAD, 1], fm[WARP, 1]
    sh_a, sh_w, sh_g = f_l + 1 - f_grad, f_warp + 1 - f_grad, f_grad + 1 - fm[GY, 1]
    if max(abs(sh_a), abs(sh_w), abs(sh_g)) <= 62:
        pa, pw = signal_plan(f_l + 1, GRAD, fm), signal_plan(f_warp + 1, GRAD, fm)
        pg = signal_plan(f_grad + 1, GY, fm)
        below, above = min(y + 1, m - 1), max(y - 1, 0)
        sub, add = np.int64(-1), np.int64(0)
        if first:
            lo, hi, count = _combine_cast(a[below], a[above], sub, pa, modes, ayl)
            _fused_log(lo, hi, count, f_l + 1, GRAD, base + L_AY, st, ov)
        lo, hi, count = _combine_cast(w[below], w[above], sub, pw, modes, wyl)
        _fused_log(lo, hi, count, f_warp + 1, GRAD, base + L_WY, st, ov)
        lo, hi, count = _combine_cast(ayl, wyl, add, pg, modes, gyl)
        _fused_log(lo, hi, count, f_grad + 1, GY, base + L_GY, st, ov)
        return
    if first:
        _column_difference_line(a, y, f_l, GRAD, base + L_AY, fm, st, ov, row, ayl)
    _column_difference_line(w, y, f_warp, GRAD, base + L_WY, fm, st, ov, row, wyl)
    for x in range(n):
        row[x] = ayl[x] + wyl[x]
    _cast_logged_row(row, f_grad + 1, GY, base + L_GY, fm, st, ov, gyl)


@njit((_R, _R, _R, _I, _P, _P), cache=True, nogil=True)
def _box_rows_line(g, e, gy, rv, pad, out):
    """The box's row pass on one line: the five products ``g²``, ``g e``, ``gy²``, ``g
    gy``, ``gy e``, each summed over ``2 rv + 1`` taps (replicated borders), exact (no
    cast: the line buffers hold the exact sums), into ``out`` (5 rows). Each product is
    formed into its row of ``pad`` (``rv`` replicated pixels either side), then the five
    are summed as running sums along it without a clamp, one product at a time: the
    five chains of adds in one loop took 3.6 against 2.1 ns a pixel (one 512-pixel line,
    ``rv = 8``, AMD EPYC Zen 4). Every index is a loop index plus a constant, into slices of
    ``pad``: ``pad[x + rv]`` with ``rv`` a variable kept the product loops from
    vectorising (numba's negative-index wrap of a variable offset; 0.55 against 0.10 ns
    an element, one 512-pixel line). Summing by doubling (2, 4, 8, 16 taps over the
    whole line) was slower at ``rv = 8`` (4.7 against 3.9 ns a pixel for the five, then
    in one loop)."""
    n = g.shape[0]
    width = 2 * rv + 1
    p0, p1, p2, p3, p4 = pad[0], pad[1], pad[2], pad[3], pad[4]
    b0, b1, b2 = p0[rv : rv + n], p1[rv : rv + n], p2[rv : rv + n]
    b3, b4 = p3[rv : rv + n], p4[rv : rv + n]
    for x in range(n):
        b0[x] = g[x] * g[x]
    for x in range(n):
        b1[x] = g[x] * e[x]
    for x in range(n):
        b2[x] = gy[x] * gy[x]
    for x in range(n):
        b3[x] = g[x] * gy[x]
    for x in range(n):
        b4[x] = gy[x] * e[x]
    for j in range(5):
        pj = pad[j]
        for k in range(rv):
            pj[k] = pj[rv]
            pj[n + rv + k] = pj[n + rv - 1]
    for j in range(5):  # a running sum a product at a time
        pj, oj = pad[j], out[j]
        s = np.int64(0)
        for k in range(width):
            s += pj[k]
        oj[0] = s
        # line x + 1's sum: line x's, plus the tap x + width in, the tap x out
        ahead = pj[width : width + n - 1]
        for x in range(n - 1):
            s += ahead[x] - pj[x]
            oj[x + 1] = s


@njit(cache=True, nogil=True)
def _column_cast(col, add, drop, plan, modes, out):
    """One line of a running column sum, ``col += add - drop``, cast by ``plan``
    (:func:`~rangefx.rtl_model.kernels.signal_plan`, ``|shift| <= 62``) into ``out`` in
    the same loop; returns the raw min, max and the overflow count, as ``cast_row``
    gives them (0.33 against 0.41 ns an element with the cast a loop of its own, a
    512-pixel line, AMD EPYC Zen 4). Four arrays a loop: the five sums in one loop
    (twenty arrays) did not vectorise (LLVM's runtime alias checks) and took 4x as long."""
    lo, hi, count = np.int64(_I64_MAX), np.int64(_I64_MIN), np.int64(0)
    for x in range(col.shape[0]):
        s = col[x] + (add[x] - drop[x])
        col[x] = s
        out[x], lo, hi, count = _logged_cast(s, plan, modes, lo, hi, count)
    return lo, hi, count


@njit(cache=True, nogil=True)
def _box_solve_line(gg, ge, yy, gy2, ye, plans, shifts, modes, num, den, logs):
    """A line's ``bdet = gg yy - gy2²`` and ``bnv = gg ye - gy2 ge`` (exact, aligned by
    the left ``shifts``) cast by ``plans`` (bdet's, bnv's; ``|shift| <= 62``) and the
    divider's operands (``-bnv / bdet`` where ``bdet > 0``, else 0 / 1) into ``num``,
    ``den``, in one loop, the casts not kept (no taps); their raw min, max and overflow
    counts into ``logs`` (2 x 3), as ``cast_row`` gives them. 0.8 against 1.1 ns a
    pixel with a loop per cast (one 512-pixel line, plain modes, AMD EPYC Zen 4)."""
    sd0, sd1, sn0, sn1 = shifts
    big, small, zero = np.int64(_I64_MAX), np.int64(_I64_MIN), np.int64(0)
    lod, hid, kd, lon, hin, kn = big, small, zero, big, small, zero
    for x in range(num.shape[0]):
        det = ((gg[x] * yy[x]) << sd0) - ((gy2[x] * gy2[x]) << sd1)
        nv = ((gg[x] * ye[x]) << sn0) - ((gy2[x] * ge[x]) << sn1)
        qd, lod, hid, kd = _logged_cast(det, plans[0], modes, lod, hid, kd)
        qn, lon, hin, kn = _logged_cast(nv, plans[1], modes, lon, hin, kn)
        solved = qd > 0  # a singular box: the divider is fed 0 / 1, v = 0
        num[x] = -qn if solved else np.int64(0)
        den[x] = qd if solved else np.int64(1)
    logs[0, 0], logs[0, 1], logs[0, 2] = lod, hid, kd
    logs[1, 0], logs[1, 1], logs[1, 2] = lon, hin, kn


@njit(cache=True, nogil=True)
def _stage_box(
    a, w, g, e, ay, f_l, rv, base, first, kind, lanes, lut, r_bits, log, modes, fm, st, dst,
    ov, wy, gy, ring, bsums, bdet, bnv, v, y0, y1,
):  # fmt: skip
    """Lines ``y0 <= y < y1`` of the box form, once :func:`_stage_rows` has written every
    line of ``w``, ``g``, ``e``, in one pass down the lines: the line work (``Wy``,
    ``gy``: :func:`_gy_line`; the box's five row sums: :func:`_box_rows_line`) ``rv``
    lines ahead into ``ring`` (``2 rv + 2`` lines of the five sums, this band's own), then the
    column work of line ``y``: the five box sums (``2 rv + 1`` lines, replicated
    borders; running down the band's lines, one line in, one out: the same exact sums)
    cast into ``p3_bgg`` .. ``p3_bye``, ``bdet = bgg byy - bgy²`` and ``bnv = bgg bye -
    bgy bge`` exact then cast, and the divider ``v = -bnv / bdet`` where ``bdet > 0``
    (else fed 0 / 1) into ``v``. The box of a band's first and last ``rv`` lines reaches
    into the other band: those lines' row sums are taken here too (their ``ay`` into a
    line of this band's, when the stage is the level's first) and logged nowhere (the
    other band logs them). ``bsums``, ``bdet``, ``bnv`` with no lines are not kept."""
    cols = np.zeros((5, a.shape[1]), dtype=np.int64)  # the running column sums (exact)
    # the next line whose box row sums are due; whether cols hold a line's sums yet
    state = np.array([max(y0 - rv, 0), 0], dtype=np.int64)
    _stage_box_lines(a, w, g, e, ay, f_l, rv, base, first, kind, lanes, lut, r_bits, log, modes,
                     fm, st, dst, ov, wy, gy, ring, bsums, bdet, bnv, v, y0, y1, y0, y1, cols,
                     state, np.bool_(False))  # fmt: skip


@njit(cache=True, nogil=True)
def _stage_box_lines(
    a, w, g, e, ay, f_l, rv, base, first, kind, lanes, lut, r_bits, log, modes, fm, st, dst,
    ov, wy, gy, ring, bsums, bdet, bnv, v, y0, y1, ya, yb, cols, state, private,
):  # fmt: skip
    """Lines ``ya <= y < yb`` of :func:`_stage_box` for the band ``y0 <= y < y1``,
    resumable: ``cols`` (the five running column sums), ``state[0]`` (the next line whose
    box row sums are due) and ``state[1]`` (whether ``cols`` hold the line before's sums)
    carry from one call to the next, so that consecutive calls give one call's sums and
    log (:func:`_stage_box_fused`). Lines outside the band (their ``gy`` and box row
    sums, and ``ya .. yb`` may reach outside it too: their column work and ``v``) are
    logged nowhere (the other band logs them); with ``private`` (planes of this band's
    own) their ``Wy`` and ``gy`` go into the planes, else into line buffers. ``wy`` with
    no lines is not kept (a line buffer: the fused stage's, which reads no ``Wy`` after)."""
    m, n = a.shape
    rows = ring.shape[0]
    f_g, f_gy, f_e = fm[G, 1], fm[GY, 1], fm[E, 1]
    f_in = (2 * f_g, f_g + f_e, 2 * f_gy, f_g + f_gy, f_gy + f_e)
    f_gg, f_ge, f_yy, f_gy2, f_ye = fm[BGG, 1], fm[BGE, 1], fm[BYY, 1], fm[BGY, 1], fm[BYE, 1]
    fd = max(f_gg + f_yy, 2 * f_gy2)
    fn = max(f_gg + f_ye, f_gy2 + f_ge)
    acc = np.empty(n, dtype=np.int64)
    # the column sums' casts in the loop that forms them (_column_cast) where every
    # shift is within cast_by_plan's |shift| <= 62, else a loop per cast (cast_row)
    sig = (BGG, BGE, BYY, BGY, BYE)
    short = True
    for j in range(5):
        short = short and abs(f_in[j] - fm[sig[j], 1]) <= 62
    plans = (signal_plan(f_in[0], BGG, fm), signal_plan(f_in[1], BGE, fm),
             signal_plan(f_in[2], BYY, fm), signal_plan(f_in[3], BGY, fm),
             signal_plan(f_in[4], BYE, fm))  # fmt: skip
    # bdet, bnv and the divider's operands in one loop (_box_solve_line) when bdet and
    # bnv are not kept (no taps) and their shifts are within |shift| <= 62
    solve_short = max(abs(fd - fm[BDET, 1]), abs(fn - fm[BNV, 1])) <= 62
    solve_plans = (signal_plan(fd, BDET, fm), signal_plan(fn, BNV, fm))
    solve_shifts = (fd - f_gg - f_yy, fd - 2 * f_gy2, fn - f_gg - f_ye, fn - f_gy2 - f_ge)
    logs = np.empty((2, 3), dtype=np.int64)
    row = np.empty(n, dtype=np.int64)
    num = np.empty(n, dtype=np.int64)
    den = np.empty(n, dtype=np.int64)
    flags = np.empty(n, dtype=np.bool_)
    pad = np.empty((5, n + 2 * rv), dtype=np.int64)
    halo = np.empty((3, n), dtype=np.int64)  # ay, Wy, gy of the other band's lines
    sth, ovh = st.copy(), ov.copy()  # the halo's log, discarded
    lines = np.empty((7, n), dtype=np.int64)  # the sums, bdet, bnv when not kept
    keep = bsums.shape[1] > 0
    dsth = dst.copy()  # the halo's divider log, discarded
    done = state[0]  # the next line whose box row sums are due
    keep_wy = wy.shape[0] > 0
    for y in range(ya, yb):
        need = min(y + rv + 1, m)
        for yl in range(done, need):
            wyl = wy[yl] if keep_wy else halo[1]
            if y0 <= yl < y1:
                _gy_line(a, w, ay[yl], yl, f_l, base, first, modes, fm, st, ov, row, wyl, gy[yl])
                gyl = gy[yl]
            elif private:
                ayl = halo[0] if first else ay[yl]
                _gy_line(a, w, ayl, yl, f_l, base, first, modes, fm, sth, ovh, row, wyl, gy[yl])
                gyl = gy[yl]
            else:
                ayl = halo[0] if first else ay[yl]
                _gy_line(
                    a, w, ayl, yl, f_l, base, first, modes, fm, sth, ovh, row, halo[1], halo[2]
                )
                gyl = halo[2]
            _box_rows_line(g[yl], e[yl], gyl, rv, pad, ring[yl % rows])
        done = max(done, need)
        own = y0 <= y < y1
        sl, dl_, ol = (st, dst, ov) if own else (sth, dsth, ovh)
        add = ring[min(y + rv, m - 1) % rows]
        drop = ring[max(y - rv - 1, 0) % rows]
        if state[1] == 0:  # the first line: the whole box, less the line the loop adds
            for j in range(5):
                col, aj, dj = cols[j], add[j], drop[j]
                for k in range(-rv, rv + 1):
                    src = ring[min(max(y + k, 0), m - 1) % rows, j]
                    for x in range(n):
                        col[x] += src[x]
                for x in range(n):
                    col[x] += dj[x] - aj[x]
            state[1] = 1
        for j in range(5):  # then one line in, one out
            col, aj, dj = cols[j], add[j], drop[j]
            out = bsums[j, y] if keep else lines[j]
            s, site = _BOX_SIGNALS[j], base + _BOX_SITES[j]
            if short:
                lo, hi, count = _column_cast(col, aj, dj, plans[j], modes, out)
                _fused_log(lo, hi, count, f_in[j], s, site, sl, ol)
            else:
                for x in range(n):
                    col[x] += aj[x] - dj[x]
                _cast_logged_row(col, f_in[j], s, site, fm, sl, ol, out)
        if keep:
            gg, ge, yy, gy2, ye = bsums[0, y], bsums[1, y], bsums[2, y], bsums[3, y], bsums[4, y]
            dl, nl = bdet[y], bnv[y]
        else:
            gg, ge, yy, gy2, ye = lines[0], lines[1], lines[2], lines[3], lines[4]
            dl, nl = lines[5], lines[6]
        if solve_short and not keep:
            _box_solve_line(gg, ge, yy, gy2, ye, solve_plans, solve_shifts, modes, num, den, logs)
            _fused_log(logs[0, 0], logs[0, 1], logs[0, 2], fd, BDET, base + L_BDET, sl, ol)
            _fused_log(logs[1, 0], logs[1, 1], logs[1, 2], fn, BNV, base + L_BNV, sl, ol)
        else:
            for x in range(n):
                acc[x] = (_at(gg[x] * yy[x], f_gg + f_yy, fd)
                          - _at(gy2[x] * gy2[x], 2 * f_gy2, fd))  # fmt: skip
                row[x] = (_at(gg[x] * ye[x], f_gg + f_ye, fn)
                          - _at(gy2[x] * ge[x], f_gy2 + f_ge, fn))  # fmt: skip
            _cast_logged_row(acc, fd, BDET, base + L_BDET, fm, sl, ol, dl)
            _cast_logged_row(row, fn, BNV, base + L_BNV, fm, sl, ol, nl)
            for x in range(n):
                solved = dl[x] > 0  # a singular box: the divider is fed 0 / 1, v = 0
                num[x] = -nl[x] if solved else np.int64(0)
                den[x] = dl[x] if solved else np.int64(1)
        if lanes:
            divide_row_lanes(num, fm[BNV, 1], den, fm[BDET, 1], V, lut, r_bits, fm, dl_, ol,
                             v[y], flags, log, modes)  # fmt: skip
        else:
            _divide_row(num, fm[BNV, 1], den, fm[BDET, 1], V, kind, lut, r_bits, fm, dl_, ol,
                        v[y], flags)  # fmt: skip
    state[0] = done


@njit(cache=True, nogil=True)
def _stage_rows_corrected(g, e, gy, v, rv, win, base, fm, st, ov, ev, rge, ree, y0, y1):
    """Lines ``y0 <= y < y1`` of the box form's correction, once ``v`` of every line is
    there: ``e + gy v`` with ``v`` of line ``y - rv`` (top lines: line 0's) cast into
    ``p3_ev`` and the window's row pass on ``g ev`` and ``ev²`` into ``rge``, ``ree`` (in
    place of :func:`_stage_rows`' on ``e``; line ``y`` into line ``y % rows``: a plane or
    a ring of lines). ``ev`` with no lines is not kept. Where both casts fuse
    (:func:`_fused_cast`) and the window is unrolled, the two row passes share one loop
    (the box form's tail 13.22 against 13.54 ns a pixel and stage with two
    :func:`_window_row` calls, 512 x 512 ``lab``, one thread, AMD EPYC Zen 4)."""
    n = g.shape[1]
    f_g, f_gy, f_e, f_v, f_ev = fm[G, 1], fm[GY, 1], fm[E, 1], fm[V, 1], fm[EV, 1]
    fc = max(f_e, f_gy + f_v)
    row = np.empty(n, dtype=np.int64)
    line = np.empty(n, dtype=np.int64)
    r = win.shape[0] - 1
    pad = np.empty(n + 2 * max(r, UNROLLED_RADIUS), dtype=np.int64)
    keep = ev.shape[0] > 0
    f_wge, f_wee = fm[WIN, 1] + f_g + f_ev, fm[WIN, 1] + 2 * f_ev
    rows = rge.shape[0]
    fuse, plan = _fused_cast(fc, EV, fm)
    fuse_ge, plan_ge = _fused_cast(f_wge, RGE, fm)
    fuse_ee, plan_ee = _fused_cast(f_wee, REE, fm)
    pair = r <= UNROLLED_RADIUS and fuse_ge and fuse_ee
    pad2 = np.empty(n + 2 * max(r, UNROLLED_RADIUS), dtype=np.int64)
    w0 = win[0]
    w1, w2, w3, w4 = _window_taps(win)
    for y in range(y0, y1):
        el, yl, vl = e[y], gy[y], v[max(y - rv, 0)]
        evl = ev[y] if keep else line
        if fuse:  # the cast in the correction's loop (_fused_cast)
            lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
            for x in range(n):
                t = _at(el[x], f_e, fc) + _at(yl[x] * vl[x], f_gy + f_v, fc)
                evl[x], lo, hi, count = _logged_cast(t, plan, PLAIN_MODES, lo, hi, count)
            _fused_log(lo, hi, count, fc, EV, base + L_EV, st, ov)
        else:
            for x in range(n):
                row[x] = _at(el[x], f_e, fc) + _at(yl[x] * vl[x], f_gy + f_v, fc)
            _cast_logged_row(row, fc, EV, base + L_EV, fm, st, ov, evl)
        j = y % rows
        if pair:  # both row passes in one loop, their casts in it (_fused_cast)
            _pad_product(g[y], evl, UNROLLED_RADIUS, pad)
            _pad_product(evl, evl, UNROLLED_RADIUS, pad2)
            lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
            lo2, hi2, count2 = _I64_MAX, _I64_MIN, np.int64(0)
            ol, ol2 = rge[j], ree[j]
            for x in range(n):
                t = _unrolled_sum(pad, x, w0, w1, w2, w3, w4)
                ol[x], lo, hi, count = _logged_cast(t, plan_ge, PLAIN_MODES, lo, hi, count)
                t = _unrolled_sum(pad2, x, w0, w1, w2, w3, w4)
                ol2[x], lo2, hi2, count2 = _logged_cast(t, plan_ee, PLAIN_MODES, lo2, hi2, count2)
            _fused_log(lo, hi, count, f_wge, RGE, base + L_RGE, st, ov)
            _fused_log(lo2, hi2, count2, f_wee, REE, base + L_REE, st, ov)
            continue
        _window_row(g[y], evl, f_wge, win, RGE, base + L_RGE, fm, st, ov, pad, row, rge[j])
        _window_row(evl, evl, f_wee, win, REE, base + L_REE, fm, st, ov, pad, row, ree[j])


@njit(cache=True, nogil=True)
def _stage_rows_vertical(
    a, w, g, e, ay, f_l, win, base, first, fm, st, ov, wy, gy, ryy, rgy, rye, y0, y1,
):  # fmt: skip
    """Lines ``y0 <= y < y1`` of the vertical term's line work, once :func:`_stage_rows`
    has written every line of ``w`` (the column differences read lines ``y ± 1``): (the
    level's ``first`` stage: E1's column difference ``ay``,) ``Wy``, ``gy`` and the
    window's row pass on ``gy²``, ``g gy``, ``gy e``."""
    n = a.shape[1]
    f_g, f_gy, f_e = fm[G, 1], fm[GY, 1], fm[E, 1]
    row = np.empty(n, dtype=np.int64)
    r = win.shape[0] - 1
    pad = np.empty(n + 2 * max(r, UNROLLED_RADIUS), dtype=np.int64)
    f_wyy, f_wgy = fm[WIN, 1] + 2 * f_gy, fm[WIN, 1] + f_g + f_gy
    f_wye = fm[WIN, 1] + f_gy + f_e
    modes = np.bool_(True)  # the casts' body for any modes (ANY_MODES), typed
    for y in range(y0, y1):
        _gy_line(a, w, ay[y], y, f_l, base, first, modes, fm, st, ov, row, wy[y], gy[y])
        gl, el, yl = g[y], e[y], gy[y]
        _window_row(yl, yl, f_wyy, win, RYY, base + L_RYY, fm, st, ov, pad, row, ryy[y])
        _window_row(gl, yl, f_wgy, win, RGY, base + L_RGY, fm, st, ov, pad, row, rgy[y])
        _window_row(yl, el, f_wye, win, RYE, base + L_RYE, fm, st, ov, pad, row, rye[y])


@njit(cache=True, nogil=True)
def _stage_columns(
    u, umax, win, vertical, base, kind, lanes, lut, r_bits, log, modes, fm, st, dst, ov,
    rgg, rge, ree, ryy, rgy, rye, sums, du, y0, y1,
):  # fmt: skip
    """Lines ``y0 <= y < y1`` of one warp stage's column work, once the row sums of
    every line are there: the window's column pass (``sgg``, ``sge``, ``see`` into
    ``sums``; with ``vertical`` also ``syy``, ``sgy``, ``sye`` and the 2x2 system's
    ``det`` and ``nu``), the divider ``du`` (``lanes``: the reciprocal divider in SIMD
    lanes, :func:`~rangefx.rtl_model.kernels.divide_row_lanes`, the same quotients and
    counts; its float log only with ``log``) and the clipped update of ``u`` in place.
    ``sums`` and ``du`` with no lines are not kept: each line lives in a line buffer."""
    m, n = u.shape
    f_u, f_du = fm[U, 1], fm[DU, 1]
    f_sgg, f_sge = fm[SGG, 1], fm[SGE, 1]
    f_syy, f_sgy, f_sye = fm[SYY, 1], fm[SGY, 1], fm[SYE, 1]
    f_det, f_nu = fm[DET, 1], fm[NU, 1]
    fu2 = max(f_u, f_du)
    # exact fraction bits of det = Σgg Σyy - Σgy², nu = Σyy Σge - Σgy Σye
    fd = max(f_sgg + f_syy, 2 * f_sgy)
    fn = max(f_syy + f_sge, f_sgy + f_sye)
    acc = np.empty(n, dtype=np.int64)
    row = np.empty(n, dtype=np.int64)
    row2 = np.empty(n, dtype=np.int64)
    num = np.empty(n, dtype=np.int64)
    den = np.empty(n, dtype=np.int64)
    flags = np.empty(n, dtype=np.bool_)
    lines = np.empty((N_SUMS + 1, n), dtype=np.int64)  # the sums and du when not kept
    keep_sums, keep_du = sums.shape[1] > 0, du.shape[0] > 0
    fuse_u, plan_u = _fused_cast(fu2, U, fm)
    for y in range(y0, y1):
        ggl, gel, eel = (sums[0, y], sums[1, y], sums[2, y]) if keep_sums else (
            lines[0], lines[1], lines[2])  # fmt: skip
        _window_col_line(rgg, win, y, m, RGG, SGG, base + L_SGG, fm, st, ov, acc, ggl)
        _window_col_line(rge, win, y, m, RGE, SGE, base + L_SGE, fm, st, ov, acc, gel)
        _window_col_line(ree, win, y, m, REE, SEE, base + L_SEE, fm, st, ov, acc, eel)
        if vertical:  # the 2x2 normal equations in (u, v), v discarded
            yyl, gyl, yel = (sums[3, y], sums[4, y], sums[5, y]) if keep_sums else (
                lines[3], lines[4], lines[5])  # fmt: skip
            _window_col_line(ryy, win, y, m, RYY, SYY, base + L_SYY, fm, st, ov, acc, yyl)
            _window_col_line(rgy, win, y, m, RGY, SGY, base + L_SGY, fm, st, ov, acc, gyl)
            _window_col_line(rye, win, y, m, RYE, SYE, base + L_SYE, fm, st, ov, acc, yel)
            for x in range(n):
                row[x] = (_at(ggl[x] * yyl[x], f_sgg + f_syy, fd)
                          - _at(gyl[x] * gyl[x], 2 * f_sgy, fd))  # fmt: skip
                row2[x] = (_at(yyl[x] * gel[x], f_syy + f_sge, fn)
                           - _at(gyl[x] * yel[x], f_sgy + f_sye, fn))  # fmt: skip
            dl, nl = (sums[6, y], sums[7, y]) if keep_sums else (lines[6], lines[7])
            _cast_logged_row(row, fd, DET, base + L_DET, fm, st, ov, dl)
            _cast_logged_row(row2, fn, NU, base + L_NU, fm, st, ov, nl)
            for x in range(n):
                # the determinant test: a singular window feeds the divider 0 / 1
                solved = dl[x] > 0
                num[x] = -nl[x] if solved else np.int64(0)
                den[x] = dl[x] if solved else np.int64(1)
            fnum, fden = f_nu, f_det
        else:
            for x in range(n):
                # the normal equation of eq 10; no gradient in the window: the divider
                # is fed 0 / 1 (operands selected)
                grad = ggl[x] > 0
                num[x] = -gel[x] if grad else np.int64(0)
                den[x] = ggl[x] if grad else np.int64(1)
            fnum, fden = f_sge, f_sgg
        dul = du[y] if keep_du else lines[N_SUMS]
        if lanes:
            divide_row_lanes(num, fnum, den, fden, DU, lut, r_bits, fm, dst, ov, dul, flags,
                             log, modes)  # fmt: skip
        else:
            _divide_row(num, fnum, den, fden, DU, kind, lut, r_bits, fm, dst, ov, dul, flags)
        ul = u[y]
        if fuse_u:  # the cast and the clip in the update's loop (_fused_cast)
            lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
            for x in range(n):
                t = _at(ul[x], f_u, fu2) + _at(dul[x], f_du, fu2)
                q, lo, hi, count = _logged_cast(t, plan_u, PLAIN_MODES, lo, hi, count)
                ul[x] = min(max(q, np.int64(0)), umax)
            _fused_log(lo, hi, count, fu2, U, base + L_U, st, ov)
            continue
        for x in range(n):
            row[x] = _at(ul[x], f_u, fu2) + _at(dul[x], f_du, fu2)
        _cast_logged_row(row, fu2, U, base + L_U, fm, st, ov, row2)
        for x in range(n):
            ul[x] = min(max(row2[x], np.int64(0)), umax)


#: Lines of a chunk of the fused warp stage (:func:`_stage_fused`): the line work runs
#: this many lines ahead of the column work at a time, through a ring of ``2 radius +
#: FUSED_CHUNK`` row-sum lines per product.
FUSED_CHUNK = 8


@njit(cache=True, nogil=True)
def _stage_fused(
    a, b, u, uh, uh_off, ax, f_l, rom, keys_bits, win, umax, base, kind, lanes, lut, r_bits,
    log, modes, fm, st, dst, ov, rgg, rge, ree, sums, y0, y1,
):  # fmt: skip
    """Lines ``y0 <= y < y1`` of one warp stage without the vertical term and without
    taps, as :func:`_stage_rows` then :func:`_stage_columns` over every line give them,
    in one pass down the lines: the line work of :data:`FUSED_CHUNK` lines, ``radius``
    lines ahead, then the column work of a chunk, the row sums in a ring of lines
    (``rgg``, ``rge``, ``ree``: ``2 radius + FUSED_CHUNK`` lines each, this band's own:
    the other band fills its ring at the same time) instead of three planes written,
    then read back ``2 radius + 1`` times. A band's column work needs
    the row sums of ``radius`` lines of the other band: their line work runs here too,
    logged nowhere (the other band logs them) and at the estimate before the stage
    (``uh``: the lines ``uh_off ..`` of ``u`` copied before the bands start, since the
    other band updates them)."""
    m, n = u.shape
    r = win.shape[0] - 1
    chunk = rgg.shape[0] - 2 * r
    none = np.empty((0, n), dtype=np.int64)
    # typed, not constants: a constant argument would compile the callees once more
    # (tests/test_compile.py)
    own, off, fit = np.int64(0), np.bool_(False), np.bool_(True)
    sth, ovh = st.copy(), ov.copy()  # the halo's log, discarded
    lo, hi = max(y0 - r, 0), min(y1 + r, m)
    done = lo  # the next line whose row sums are due
    for t in range(y0, y1, chunk):
        need = min(t + chunk + r, hi)
        # the line work of [done, need): the other band's lines apart
        _stage_rows(a, b, uh, uh_off, ax, f_l, rom, keys_bits, win, base, modes, fm, sth, ovh,
                    none, none, none, none, rgg, rge, ree, done, min(need, y0), fit)  # fmt: skip
        _stage_rows(a, b, u, own, ax, f_l, rom, keys_bits, win, base, modes, fm, st, ov, none,
                    none, none, none, rgg, rge, ree, max(done, y0), min(need, y1),
                    fit)  # fmt: skip
        _stage_rows(a, b, uh, uh_off, ax, f_l, rom, keys_bits, win, base, modes, fm, sth, ovh,
                    none, none, none, none, rgg, rge, ree, max(done, y1), need, fit)  # fmt: skip
        done = need
        _stage_columns(u, umax, win, off, base, kind, lanes, lut, r_bits, log, modes, fm, st,
                       dst, ov, rgg, rge, ree, none, none, none, sums, none, t,
                       min(t + chunk, y1))  # fmt: skip


@njit(cache=True, nogil=True)
def _stage_box_tail_lines(
    g, e, gy, v, rv, u, umax, win, base, kind, lanes, lut, r_bits, log, modes, fm, st, dst,
    ov, ev, rgg, rge, ree, sums, du, y0, y1, ya, yb, state,
):  # fmt: skip
    """Lines ``ya <= y < yb`` of the box form's correction and column work for the band
    ``y0 <= y < y1``, once ``v`` of the lines they read is there, as
    :func:`_stage_rows_corrected` then :func:`_stage_columns` over every line give them,
    in one pass down the lines (as :func:`_stage_fused`): the correction of
    :data:`FUSED_CHUNK` lines, ``radius`` lines ahead (no further), then the column work
    of those lines, the row sums on ``e + gy v`` in ``rge``, ``ree`` (a ring of ``2
    radius + FUSED_CHUNK`` lines each, this band's own; ``rgg`` :func:`_stage_rows`'
    plane). The correction does not read ``u``: the ``radius`` lines of the other band
    that a band's column work needs are corrected here too from the same planes, logged
    nowhere (the other band logs them). Resumable: ``state[0]`` (the next line whose
    corrected row sums are due; ``max(y0 - radius, 0)`` at the band's start) carries
    from one call to the next (:func:`_stage_box_fused`)."""
    m, n = u.shape
    r = win.shape[0] - 1
    none = np.empty((0, n), dtype=np.int64)
    off = np.bool_(False)  # typed, not a constant (tests/test_compile.py)
    sth, ovh = st.copy(), ov.copy()  # the halo's log, discarded
    hi = min(y1 + r, m)
    done = state[0]  # the next line whose corrected row sums are due
    for t in range(ya, yb, FUSED_CHUNK):
        end = min(t + FUSED_CHUNK, yb)
        need = min(end + r, hi)
        _stage_rows_corrected(g, e, gy, v, rv, win, base, fm, sth, ovh, none, rge, ree, done,
                              min(need, y0))  # fmt: skip
        _stage_rows_corrected(g, e, gy, v, rv, win, base, fm, st, ov, ev, rge, ree,
                              max(done, y0), min(need, y1))  # fmt: skip
        _stage_rows_corrected(g, e, gy, v, rv, win, base, fm, sth, ovh, none, rge, ree,
                              max(done, y1), need)  # fmt: skip
        done = max(done, need)
        _stage_columns(u, umax, win, off, base, kind, lanes, lut, r_bits, log, modes, fm, st,
                       dst, ov, rgg, rge, ree, none, none, none, sums, du, t, end)  # fmt: skip
    state[0] = done


#: Lines of the box form's fused stage's column work a turn (:func:`_stage_box_fused`):
#: its line work and box run ahead by as many lines (the correction within a turn: by
#: :data:`FUSED_CHUNK` lines at a time).
BOX_CHUNK = 32


@njit(cache=True, nogil=True)
def _stage_box_fused(
    a, b, u, uh, uh_off, ax, f_l, rom, keys_bits, win, rv, umax, base, first, kind, lanes,
    lanes_v, lut, r_bits, log, modes, fm, st, dst, ov, w, g, e, ay, gy, rgg, box_ring, v,
    rge, ree, sums, y0, y1,
):  # fmt: skip
    """Lines ``y0 <= y < y1`` (a band) of one warp stage of the box form without taps, as
    :func:`_stage_rows`, :func:`_stage_box`, :func:`_stage_rows_corrected` and
    :func:`_stage_columns` over every line give them, in one pass down the lines: per
    :data:`BOX_CHUNK` lines of the column work, the box (``v``) of the lines that their
    correction reads and the line work of the lines that box reads (``radius + 1`` to
    ``2 rv + 1`` lines ahead), so that the planes (W, ``g``, ``e``, ``gy``, ``v``,
    ``rgg``) are read back while their lines are still in the cache, not a whole 512 x
    512 plane (2 MB) later; one call (one hand-off to the worker thread) a stage instead
    of three. The line work of line ``y`` reads
    ``u[y]`` before the column work updates it (the line work runs ahead). The planes
    are this band's own (the scratch of the thread that runs it): a band also computes
    the lines of the other band that its column work reaches, ``radius + 2 rv + 1``
    above it and ``max(radius, rv) + 1`` below (their line work at the estimate before
    the stage, ``uh``: the lines ``uh_off ..`` of ``u`` copied before the bands start),
    into its planes, logged nowhere (the other band logs them). The same sums, casts
    and log as the three passes (each line is cast once, in the same kernels; only their
    order differs)."""
    m, n = a.shape
    r = win.shape[0] - 1
    none = np.empty((0, n), dtype=np.int64)
    no_sums = np.empty((5, 0, n), dtype=np.int64)
    # typed, not constants (tests/test_compile.py)
    own, fit, private = np.int64(0), np.bool_(False), np.bool_(True)
    sth, ovh = st.copy(), ov.copy()  # the other band's line work's log, discarded
    # v of the band's lines and of those its correction reads (rv lines above the
    # correction's, which reaches radius lines past the band); their box reads gy of
    # rv lines either side, gy W of one line more
    vlo, vhi = max(y0 - r - rv, 0), max(y1, min(y1 + r - rv, m))
    cols = np.zeros((5, n), dtype=np.int64)
    box_state = np.array([max(vlo - rv, 0), 0], dtype=np.int64)
    tail_state = np.array([max(y0 - r, 0)], dtype=np.int64)
    rows_done = max(vlo - rv - 1, 0)  # the next line whose line work is due
    box_done = vlo  # the next line whose v is due
    for t in range(y0, y1 + BOX_CHUNK, BOX_CHUNK):
        end = min(t + BOX_CHUNK, y1)
        # the chunk's correction reads lines < end + radius of e, g, gy, and v of lines
        # up to rv lines above those; the band's last turn (t >= y1): every line's v
        need_v = max(min(end + r, m) - rv, 1) if t < y1 else vhi
        need_rows = min(max(need_v, box_done) + rv + 1, m)
        # the line work of the lines due: the other band's at the estimate before the
        # stage; a range with no line is not called (each call sets up its buffers)
        if rows_done < min(need_rows, y0):
            _stage_rows(a, b, uh, uh_off, ax, f_l, rom, keys_bits, win, base, modes, fm, sth,
                        ovh, w, none, g, e, rgg, none, none, rows_done, min(need_rows, y0),
                        fit)  # fmt: skip
        if max(rows_done, y0) < min(need_rows, y1):
            _stage_rows(a, b, u, own, ax, f_l, rom, keys_bits, win, base, modes, fm, st, ov, w,
                        none, g, e, rgg, none, none, max(rows_done, y0), min(need_rows, y1),
                        fit)  # fmt: skip
        if max(rows_done, y1) < need_rows:
            _stage_rows(a, b, uh, uh_off, ax, f_l, rom, keys_bits, win, base, modes, fm, sth,
                        ovh, w, none, g, e, rgg, none, none, max(rows_done, y1), need_rows,
                        fit)  # fmt: skip
        rows_done = max(rows_done, need_rows)
        if need_v > box_done:
            _stage_box_lines(a, w, g, e, ay, f_l, rv, base, first, kind, lanes_v, lut, r_bits,
                             log, modes, fm, st, dst, ov, none, gy, box_ring, no_sums, none,
                             none, v, y0, y1, box_done, need_v, cols, box_state,
                             private)  # fmt: skip
            box_done = need_v
        if t < y1:
            _stage_box_tail_lines(g, e, gy, v, rv, u, umax, win, base, kind, lanes, lut,
                                  r_bits, log, modes, fm, st, dst, ov, none, rgg, rge, ree,
                                  sums, none, y0, y1, t, end, tail_state)  # fmt: skip


@njit(cache=True, nogil=True)
def _final_kernel(
    u, sums, vertical, regs, kind, lanes, lut, r_bits, log, modes, fm, st, dst, ov,
    out_range, out_valid, out_float, scale, taps, t0, want_taps, y0, y1,
):  # fmt: skip
    """Level 0, lines ``y0 <= y < y1``: the residual and gradient tests (with
    ``vertical`` the 2x2 fit's residual, ``nv`` cast here, and the determinant test), the
    match inside E2, the range divider ``z = f B / u`` gated by ``u >= u_min``
    (``z <= range_max``; ``lanes`` as in :func:`_stage_columns`), range + valid, and the
    range as a float (``out_float``: the raw code times ``scale = 2**-F``, exact, as
    :meth:`~rangefx.rtl_model.fixedpoint.FixedFormat.to_float` gives it, in the loop
    that writes the code: a NumPy pass over the plane after it took 0.85 ms of CPU a
    512 x 512 frame, cProfile, one thread)."""
    n = u.shape[1]
    sgg, sge, see = sums[0], sums[1], sums[2]
    sgy, sye, det, nu = sums[4], sums[5], sums[6], sums[7]
    tg2, tr2, umax, umin, fb, rmax = regs[0], regs[1], regs[2], regs[3], regs[4], regs[5]
    f_u, f_sgg, f_sge, f_see = fm[U, 1], fm[SGG, 1], fm[SGE, 1], fm[SEE, 1]
    f_sgy, f_sye, f_det, f_nu, f_nv = fm[SGY, 1], fm[SYE, 1], fm[DET, 1], fm[NU, 1], fm[NV, 1]
    f_tr2, f_fb = fm[TR2, 1], fm[FB, 1]
    f_res = max(f_see + f_sgg, 2 * f_sge)
    f_nv_in = max(f_sgg + f_sye, f_sgy + f_sge)
    f_vres = max(f_see + f_det, f_sge + f_nu, f_sye + f_nv)
    nv = np.empty(n, dtype=np.int64)
    right = np.int64(n - 1) << f_u
    # a row at a time (casts and divider logged once per row, as in _stage_rows)
    work = np.empty((7, n), dtype=np.int64)
    pre, res, thr, rthr, num, den, rq = (
        work[0], work[1], work[2], work[3], work[4], work[5], work[6],
    )  # fmt: skip
    flags = np.empty(n, dtype=np.bool_)
    fuse_res, plan_res = _fused_cast(f_res, RES, fm)
    fuse_thr, plan_thr = _fused_cast(f_tr2 + f_sgg, RES, fm)
    fuse = fuse_res and fuse_thr
    for y in range(y0, y1):
        if vertical:  # Σe² det - Σge nu - Σye nv <= T_r² det
            for x in range(n):
                pre[x] = (_at(sgg[y, x] * sye[y, x], f_sgg + f_sye, f_nv_in)
                          - _at(sgy[y, x] * sge[y, x], f_sgy + f_sge, f_nv_in))  # fmt: skip
            _cast_logged_row(pre, f_nv_in, NV, S_NV, fm, st, ov, nv)
            for x in range(n):
                pre[x] = (_at(see[y, x] * det[y, x], f_see + f_det, f_vres)
                          - _at(sge[y, x] * nu[y, x], f_sge + f_nu, f_vres)
                          - _at(sye[y, x] * nv[x], f_sye + f_nv, f_vres))  # fmt: skip
                thr[x] = tr2 * det[y, x]
            _cast_logged_row(pre, f_vres, RES, S_RES, fm, st, ov, res)
            _cast_logged_row(thr, f_tr2 + f_det, RES, S_RTHR, fm, st, ov, rthr)
        elif fuse:  # both casts in the loop that forms their operands (_fused_cast)
            lo, hi, count = _I64_MAX, _I64_MIN, np.int64(0)
            lo_t, hi_t, count_t = _I64_MAX, _I64_MIN, np.int64(0)
            ggl, gel, eel = sgg[y], sge[y], see[y]
            for x in range(n):
                gg, ge = ggl[x], gel[x]
                t = _at(eel[x] * gg, f_see + f_sgg, f_res) - _at(ge * ge, 2 * f_sge, f_res)
                res[x], lo, hi, count = _logged_cast(t, plan_res, PLAIN_MODES, lo, hi, count)
                t = tr2 * gg
                rthr[x], lo_t, hi_t, count_t = _logged_cast(
                    t, plan_thr, PLAIN_MODES, lo_t, hi_t, count_t
                )
            _fused_log(lo, hi, count, f_res, RES, S_RES, st, ov)
            _fused_log(lo_t, hi_t, count_t, f_tr2 + f_sgg, RES, S_RTHR, st, ov)
        else:
            for x in range(n):
                gg, ge, ee = sgg[y, x], sge[y, x], see[y, x]
                pre[x] = _at(ee * gg, f_see + f_sgg, f_res) - _at(ge * ge, 2 * f_sge, f_res)
                thr[x] = tr2 * gg
            _cast_logged_row(pre, f_res, RES, S_RES, fm, st, ov, res)
            _cast_logged_row(thr, f_tr2 + f_sgg, RES, S_RTHR, fm, st, ov, rthr)
        for x in range(n):
            uu = u[y, x]
            # gated off, the divider is fed 0 / 1 (operands selected)
            gate = uu > 0 and uu >= umin
            num[x] = fb if gate else np.int64(0)
            den[x] = uu if gate else np.int64(1)
        if lanes:
            divide_row_lanes(num, f_fb, den, f_u, RANGE, lut, r_bits, fm, dst, ov, rq, flags,
                             log, modes)  # fmt: skip
        else:
            _divide_row(num, f_fb, den, f_u, RANGE, kind, lut, r_bits, fm, dst, ov, rq, flags)
        # the validity and the range in a loop of its own, without branches, so that it
        # vectorises (the kernel 7.7 -> 5.6 ns a pixel, 512 x 512 lab, one thread, min
        # of 21); the taps copied after it
        vl, rl, fl, ul, gl = out_valid[y], out_range[y], out_float[y], u[y], sgg[y]
        dl = det[y] if vertical else gl  # with vertical, the determinant test too
        for x in range(n):
            gg, uu = gl[x], ul[x]
            src = (np.int64(x) << f_u) - uu
            ok = ((gg >= tg2) & (res[x] <= rthr[x]) & (src >= 0) & (src <= right) & (uu > 0)
                  & (uu >= umin) & (uu <= umax) & (not flags[x]) & (rq[x] > 0)
                  & (rq[x] <= rmax) & (dl[x] > 0 or not vertical))  # fmt: skip
            vl[x] = ok
            z = rq[x] if ok else rmax
            rl[x] = z
            fl[x] = np.float64(z) * scale
        if want_taps:
            for x in range(n):
                if vertical:
                    taps[t0 - 1, y, x] = nv[x]
                taps[t0, y, x] = res[x]
                taps[t0 + 1, y, x] = rthr[x]
                taps[t0 + 2, y, x] = np.int64(vl[x])
                taps[t0 + 3, y, x] = rl[x]


# --------------------------------------------------------------------------------------
# host side
# --------------------------------------------------------------------------------------
def keys_weights(t: float) -> tuple[float, float, float, float]:
    """Keys cubic (a = -½) weights of the taps at offsets -1, 0, 1, 2 for fraction ``t``
    (exact in float64 for the ROM's dyadic fractions)."""
    a, t2, t3 = _KEYS_A, t * t, t * t * t
    return (
        a * (t3 - 2 * t2 + t),
        (a + 2) * t3 - (a + 3) * t2 + 1,
        -(a + 2) * t3 + (2 * a + 3) * t2 - a * t,
        -a * (t3 - t2),
    )


def keys_exact(i: int, keys_bits: int) -> tuple[int, int, int, int]:
    """The four Keys weights of fraction ``t = i 2**-T`` (``T = keys_bits``) exactly, as
    integers ``n`` with ``w = n 2**-(3T + 1)`` (``a = -½``; the cubic times ``2^(3T+1)``)."""
    s, i2, i3 = 1 << keys_bits, i * i, i * i * i
    return (
        -(i3 - 2 * i2 * s + i * s * s),
        3 * i3 - 5 * i2 * s + 2 * s**3,
        -3 * i3 + 4 * i2 * s + i * s * s,
        i3 - i2 * s,
    )


def keys_rom_casts(config: P3Config) -> tuple[np.ndarray, int, tuple[float, float]]:
    """The Keys ROM (:func:`keys_rom`), the number of its weights whose cast into
    ``p3_keys`` overflowed (its mode acted: SAT holds a weight at the limit, WRAP wraps
    1.0 to 0 in a format without an integer bit) and the exact weights' (min, max).

    The ROM is datapath: it is counted and logged as the signal ``p3_keys`` (once per
    weight, at the ROM's build, not per read) rather than as a saturated host register,
    because the word-length studies size it like every signal and judge a config by its
    overflow count, which must therefore see a ROM that cannot hold its weights."""
    rom, overflows, weights = _keys_rom_build(config.formats["p3_keys"], config.keys_bits)
    return rom.copy(), overflows, weights


@functools.lru_cache(maxsize=16)
def _keys_rom_build(fmt: FixedFormat, bits: int) -> tuple[np.ndarray, int, tuple[float, float]]:
    """:func:`keys_rom_casts` once per (format, ``keys_bits``): 1024 Python casts cost
    ~12 ms a run otherwise (cProfile, 512 x 512 ``lab``, shared machine)."""
    frac_in = 3 * bits + 1
    rom = np.empty((1 << bits, 4), dtype=np.int64)
    overflows, lo, hi = 0, 0, 0
    for i in range(1 << bits):
        for j, w in enumerate(keys_exact(i, bits)):
            raw, acted = cast_raw(w, frac_in, fmt.word, fmt.frac, fmt.signed, int(fmt.quant),
                                  int(fmt.overflow))  # fmt: skip
            rom[i, j] = raw
            overflows += int(acted)
            lo, hi = min(lo, w), max(hi, w)
    return rom, overflows, (math.ldexp(lo, -frac_in), math.ldexp(hi, -frac_in))


def keys_rom(config: P3Config) -> np.ndarray:
    """The warp's weight ROM: ``2**keys_bits`` rows (fraction ``i 2**-keys_bits``) of 4
    weights, raw codes of ``p3_keys`` (the exact weights quantised with its modes)."""
    return keys_rom_casts(config)[0]


class P3Registers:
    """Per-frame constants as the host writes them (raw codes in their formats)."""

    def __init__(
        self, config: P3Config, camera: PinholeCamera, baseline: float, range_max: float,
        built: int, width: int,
    ) -> None:  # fmt: skip
        ms = config.multiscale().resolve(width)
        rf = runtime.RegisterFile(config)
        box = (2 * config.normalise_radius + 1) ** 2
        self.nbox = rf.write("1/box", 1.0 / box, "p3_nbox") if config.normalise != "none" else 0
        window = ms.window()
        r = config.radius
        self.window = np.array([rf.write(f"W{k}", window[r + k], "p3_win") for k in range(r + 1)],
                               dtype=np.int64)  # fmt: skip
        tr2_fmt = config.formats["p3_tr2"]
        tr2_max = float(tr2_fmt.to_float(tr2_fmt.raw_max))
        tr2 = rf.write("T_r^2", min(config.threshold_r**2, tr2_max), "p3_tr2")
        tg2 = rf.write("T_g^2", config.threshold_g**2, "p3_sgg")
        fb_value = float(camera.f_px * baseline)
        fb = rf.write("fB", fb_value, "p3_fb")
        self.umax = [
            rf.write(f"u_max{level}", ms.disparity_limit / 2**level, "p3_u")
            for level in range(built)
        ]
        u_fmt = config.formats["p3_u"]
        need = math.ceil(Fraction(fb_value) * 2**u_fmt.frac / Fraction(range_max))
        if need > u_fmt.raw_max:
            rf.saturated.append("u_min")
        umin = rf.hold("u_min", min(need, u_fmt.raw_max), "p3_u", fb_value / range_max)
        rmax = rf.write("range_max", range_max, "p3_range")
        self.final = np.array([tg2, tr2, self.umax[0], umin, fb, rmax], dtype=np.int64)
        self.values = rf.values
        self.codes = rf.codes
        self.saturated = tuple(rf.saturated)


def stereo_baseline(motion: MotionIncrement) -> float:
    """The baseline ``B > 0`` of a stereo pair with the second camera on the right;
    ``ValueError`` for anything else (P3 models stereo mode, as G6)."""
    fwd, right, down = motion.camera_displacement
    if right <= 0 or abs(fwd) > 1e-9 * right or abs(down) > 1e-9 * right:
        raise ValueError(
            "P3 needs a stereo pair with the second camera on the right (a positive lateral "
            f"baseline, no forward or vertical displacement; got {fwd:g}, {right:g}, {down:g})"
        )
    if not np.allclose(motion.dT2, 0.0):
        raise ValueError("P3 needs a stereo pair without rotation between the views")
    return float(right)


def p3_registers(
    config: P3Config, camera: PinholeCamera, motion: MotionIncrement, ranging: RangingConfig,
    shape: tuple[int, int],
) -> P3Registers:  # fmt: skip
    """The host's registers for a case (window taps, thresholds, fB, clips, range_max)."""
    built = pyramid_levels(config.multiscale(), shape)
    return P3Registers(
        config, camera, stereo_baseline(motion), ranging.range_max, built, int(shape[1])
    )


def level_shapes(config: P3Config, shape: tuple[int, int]) -> list[tuple[int, int]]:
    """(height, width) of every level the pyramid builds for ``shape``, finest first."""
    m, n = shape
    out = [(m, n)]
    for _ in range(pyramid_levels(config.multiscale(), shape) - 1):
        m, n = (m + 1) // 2, (n + 1) // 2
        out.append((m, n))
    return out


def stage_latencies(config: P3Config) -> dict[str, int]:
    """Declared latency in clock cycles of every pixel stage of one warp stage and of the
    output (the line latencies are in :func:`p3_schedule`)."""
    div = runtime.divider_latency(config.divider, config.formats["p3_du"].word)
    rdiv = runtime.divider_latency(config.divider, config.formats["p3_range"].word)
    box = config.vertical_form == "box"
    vdiv = runtime.divider_latency(config.divider, config.formats["p3_v"].word) if box else 0
    return {
        "input": 1,
        # R pixels ahead for the box, the running sums' add, the subtraction + cast
        "normalise": config.normalise_radius + 2 if config.normalise != "none" else 0,
        "warp": 4,  # two taps ahead, ROM read, four products, adder tree + cast
        "derivative": 2,  # one pixel ahead, difference + cast (Wx); g one more
        "products": 1,
        "window_row": config.radius + 1,
        "window_column": 1,
        # the box form: rv pixels ahead and the running sum's add; the column sum + cast
        "box_row": config.vertical_radius + 1 if box else 0,
        "box_column": 1 if box else 0,
        # vertical: det and nu (the box form: bdet and bnv), two products and a
        # difference each, then the cast
        "normal_equations": 2 if config.vertical else 0,
        "v_divider": vdiv,
        "correction": 1 if box else 0,  # the box form: e + gy v, one product and an add
        "du_divider": div,
        "update": 1,
        "residual": 2,
        "range_divider": rdiv,
        "output": 1,
    }


def _warp_cycles(config: P3Config) -> int:
    """Cycles from ``u_k`` of a pixel to ``u_k+1`` of the same pixel (one warp stage's
    pixel latency; its line latency is the window radius)."""
    lat = stage_latencies(config)
    # the box form: its sums, bdet and bnv, v and e + gy v before the 1-D window's products
    box = (lat["products"] + lat["box_row"] + lat["box_column"] + lat["v_divider"]
           + lat["correction"]) if config.vertical_form == "box" else 0  # fmt: skip
    return (
        lat["warp"] + lat["derivative"] + 1 + lat["products"] + lat["window_row"]
        + lat["window_column"] + lat["normal_equations"] + lat["du_divider"] + lat["update"]
        + box
    )  # fmt: skip


def tap_offsets(config: P3Config, shape: tuple[int, int]) -> dict[str, tuple[int, int]]:
    """Tap -> (lines, cycles): a sample of line ``y``, column ``x`` leaves ``cycles``
    clocks after pixel ``x`` of line ``y + lines`` arrived (flush lines after the frame)."""
    sched = p3_schedule(config, shape)
    # level 0's warps start when both the coarse estimate (delay lines) and the
    # normalised line (R lines and the normalisation's pixel latency) are there
    rn = 0 if config.normalise == "none" else config.normalise_radius
    d, r, p = max(sched["delay_lines"], rn), config.radius, _warp_cycles(config)
    lat = stage_latencies(config)
    i0 = lat["input"] + lat["normalise"]
    out = {"ax": (d, i0 + lat["derivative"]), "u_start": (d, i0)}
    if rn:
        out["e1.norm"] = out["e2.norm"] = (rn, i0)
    # vertical: the column differences need line y + 1 (of E1, then of W), so ay, wy and
    # gy leave a line later, and g and e wait that line in line buffers: the window's
    # six products start together, one line later, and every stage takes r + 1 lines
    # the box form: the box centred on line y - rv (its sums, bdet, bnv, v: the taps of
    # line y) is complete with line y's gy; e + gy v then feeds the 1-D window's
    # products, which start with it (g and e waiting the box's cycles in a short delay)
    v = int(bool(config.vertical))
    form = config.vertical_form
    if v:
        out["ay"] = (d + 1, i0 + lat["derivative"])
    names = ("rgg", "rge", "ree") + (("ryy", "rgy", "rye") if form == "window" else ())
    ne_u = lat["normal_equations"] if form == "window" else 0  # det and nu before du
    for k in range(config.warps):
        lines, c = d + k * (r + v), i0 + k * p
        out[f"warp{k}"] = (lines, c + lat["warp"])
        out[f"err{k}"] = (lines, c + lat["warp"] + 1)
        out[f"wx{k}"] = (lines, c + lat["warp"] + lat["derivative"])
        out[f"g{k}"] = (lines, c + lat["warp"] + lat["derivative"] + 1)
        start = c + lat["warp"] + lat["derivative"] + 1  # the products' inputs
        if v:
            out[f"wy{k}"] = (lines + 1, c + lat["warp"] + lat["derivative"])
            out[f"gy{k}"] = (lines + 1, start)
        if form == "box":  # the box's taps of line y: the box centred rv lines up
            cb = start + lat["products"] + lat["box_row"] + lat["box_column"]
            for t in ("bgg", "bge", "byy", "bgy", "bye"):
                out[f"{t}{k}"] = (lines + 1, cb)
            cb += lat["normal_equations"]
            out[f"bdet{k}"] = out[f"bnv{k}"] = (lines + 1, cb)
            cb += lat["v_divider"]
            out[f"v{k}"] = (lines + 1, cb)
            start = cb + lat["correction"]
            out[f"ev{k}"] = (lines + 1, start)
        row = start + lat["products"] + lat["window_row"]
        for t in names:
            out[f"{t}{k}"] = (lines + v, row)
        col = row + lat["window_column"]
        for t in names:
            out[f"s{t[1:]}{k}"] = (lines + v + r, col)
        if form == "window":
            out[f"det{k}"] = out[f"nu{k}"] = (lines + v + r, col + lat["normal_equations"])
        div = col + ne_u + lat["du_divider"]
        out[f"du{k}"] = (lines + v + r, div)
        out[f"u{k}"] = (lines + v + r, c + p)
    lines, c = d + config.warps * (r + v), i0 + config.warps * p
    if form == "window":  # nv from the last stage's sums, then the 2x2 fit's residual
        out["nv"] = (lines, c + lat["normal_equations"])
        c += lat["normal_equations"]
    out["res"] = out["rthr"] = (lines, c + lat["residual"])
    out["valid"] = out["range"] = (lines, c + lat["residual"] + lat["range_divider"] + 1)
    return out


@functools.lru_cache(maxsize=32)
def _schedule(ms: MultiscaleConfig, n: int, m: int) -> dict:
    """:func:`~rangefx.golden.multiscale.streaming_schedule` once per (settings, shape):
    a run reads it three times (:func:`p3_schedule` twice, :func:`buffer_bits`), ~0.3 ms
    each. Shared: its readers here do not change it."""
    return streaming_schedule(ms, n, m)


def p3_schedule(config: P3Config, shape: tuple[int, int]) -> dict[str, int]:
    """Timing facts of the schedule on ``shape`` images: levels built, level 0's latency
    in lines and its delay lines (``streaming_schedule``), one warp stage's pixel cycles."""
    m, n = shape
    sched = _schedule(config.multiscale(), n, m)
    return {
        "levels": len(sched["levels"]),
        "latency_lines": int(sched["latency_lines"]),
        "delay_lines": int(sched["levels"][0]["delay_lines"]),
        "warp_cycles": _warp_cycles(config),
    }


def tap_cycles(
    tap: str, config: P3Config, in_cycles: np.ndarray, hblank: int,
    rows: tuple[int, int] | None = None, out: np.ndarray | None = None,
) -> np.ndarray:  # fmt: skip
    """Cycle of every sample of ``tap`` (shape (m, n)): :func:`tap_offsets` on the input
    beats; a line past the frame's last is a flush line (the vertical filters replicate
    the last line), one every ``n + hblank`` clocks after the frame's last beat.
    ``rows`` ``(j0, j1)``: only lines ``j0 <= j < j1``, into ``out`` when given (shape
    ``(j1 - j0, n)``; a model fills its result band by band)."""
    m, n = in_cycles.shape
    j0, j1 = rows or (0, m)
    if out is None:
        out = np.empty((j1 - j0, n), dtype=np.int64)
    if tap.rpartition(".")[2] == "pix_in":
        np.copyto(out, in_cycles[j0:j1])
        return out
    offsets = tap_offsets(config, (m, n))
    if tap not in offsets:
        raise ValueError(f"unknown P3 tap {tap!r}; taps: {', '.join(offsets)}")
    lines, cycles = offsets[tap]
    k = min(max(m - lines, j0), j1)  # lines j < k: their source line is inside the frame
    np.add(in_cycles[j0 + lines : k + lines], cycles, out=out[: k - j0])
    src = np.arange(k, j1)[:, None] + lines - m  # flush lines: 0 is the first after the frame
    out[k - j0 :] = (int(in_cycles[m - 1, n - 1]) + hblank + 1 + cycles + src * (n + hblank)
                     + np.arange(n)[None, :])  # fmt: skip
    return out


def box_row_bits(config: P3Config) -> int:
    """Bits of the box form's five exact row sums at one pixel: each product's two words
    plus ``ceil(log2(2 rv + 1))`` for the sum (the line buffers down the columns)."""
    f = {k: v.word for k, v in config.formats.items()}
    grow = math.ceil(math.log2(2 * config.vertical_radius + 1))
    g, gy, e = f["p3_g"], f["p3_gy"], f["p3_e"]
    return 2 * g + (g + e) + 2 * gy + (g + gy) + (gy + e) + 5 * grow


def buffer_bits(config: P3Config, shape: tuple[int, int]) -> dict[str, int]:
    """Line-buffer bits of every buffer of the streaming schedule, by kind: the words of
    :func:`~rangefx.golden.multiscale.streaming_schedule` times their formats
    (normalise and delay lines: the level's pixels, normalised as they leave the delay,
    so that the long delay holds the narrow raw word; reduce: the exact row sums, the
    parent's word + 4; warp row: what the warp reads, ``p3_norm`` when normalising, else
    the level's pixel word; window products: the three row-sum words; window align: E1,
    E2 (as the warp row) and u; expand: u; vertical: E1's two lines (as the warp row),
    W's two lines, one line each of ``g`` and ``e``, the three more row-sum words; the box
    form: the five box row sums, exact: both factors' words plus ``ceil(log2(2 rv + 1))``)."""
    m, n = shape
    f = config.formats
    sched = _schedule(config.multiscale(), n, m)
    pix = lambda level: f["p3_pix"].word if level == 0 else f["p3_pyr"].word  # noqa: E731
    # what the warps, window and delay lines hold: the level, or its normalised pixels
    warped = lambda level: f["p3_norm"].word if normalised else pix(level)  # noqa: E731
    normalised = config.normalise != "none"
    rows = f["p3_rgg"].word + f["p3_rge"].word + f["p3_ree"].word
    u = f["p3_u"].word
    out = dict.fromkeys(
        ("normalise", "reduce", "warp_row", "window_products", "window_align", "expand",
         "coarse_delay", "vertical"), 0,
    )  # fmt: skip
    # vertical: E1's and W's lines for the column differences, g's and e's wait for gy,
    # the three more row sums down the columns
    vrows = f["p3_ryy"].word + f["p3_rgy"].word + f["p3_rye"].word
    if config.vertical_form == "box":  # the five exact box row sums (2 rv lines each)
        vrows = box_row_bits(config)
    per_row = 5 if config.vertical_form == "box" else 3

    for lv in sched["levels"]:
        level, words = lv["level"], lv["buffer_words"]
        out["normalise"] += words["normalise"] * pix(level)
        out["reduce"] += words["reduce"] * (pix(level - 1) + 4) if level else 0
        out["warp_row"] += words["warp_row"] * warped(level)
        out["window_products"] += words["window_products"] // 3 * rows
        out["window_align"] += words["window_align"] // 3 * (2 * warped(level) + u)
        out["expand"] += words["expand"] * u
        out["coarse_delay"] += words["coarse_delay"] * pix(level)
        out["vertical"] += (
            words["vertical_e1"] * warped(level)
            + words["vertical_warp"] * f["p3_warp"].word
            + words["vertical_align"] // 2 * (f["p3_g"].word + f["p3_e"].word)
            + words["vertical_products"] // per_row * vrows
        )
    return out


#: Fewest pixels of a level that its line work splits into two bands for (two threads):
#: below, the hand-off to the worker thread costs more than the band's work.
BAND_PIXELS = 4096


def _two_bands(h: int, w: int, stats: list[runtime.SignalStats]) -> bool:
    """Whether :func:`_in_bands` splits a ``h`` x ``w`` level into two bands."""
    return len(stats) == 2 and h >= 2 and h * w >= BAND_PIXELS


def _in_bands(
    work: Callable[[np.ndarray, np.ndarray, np.ndarray, int, int], None], h: int, w: int,
    stats: list[runtime.SignalStats],
) -> None:  # fmt: skip
    """``work(st, dst, ov, y0, y1)`` over the lines ``0 <= y < h`` of a ``h`` x ``w``
    level: two bands at once on the two threads (each band its own log, one per entry of
    ``stats``) when there are two and the level has :data:`BAND_PIXELS` or more, else
    one band on the calling thread."""
    if _two_bands(h, w, stats):
        mid = h // 2
        runtime.run_two(work, (*stats[1].arrays, mid, h), (*stats[0].arrays, 0, mid))
    else:
        work(*stats[0].arrays, 0, h)


def _run_level(
    config: P3Config, a: np.ndarray, b: np.ndarray, u: np.ndarray, f_l: int, umax: int,
    rom: np.ndarray, win: np.ndarray, base: int, divider: tuple[int, np.ndarray, bool],
    log: bool, modes: bool | None, fm: np.ndarray, stats: list[runtime.SignalStats], key: str,
    taps: np.ndarray | None, final: bool,
) -> np.ndarray:  # fmt: skip
    """The ``warps`` stages of one level on E1 ``a``, E2 ``b`` (``f_l`` fraction bits)
    from the start estimate ``u`` (updated in place), E1's central difference ``ax``
    once (:func:`_difference_lines`): per stage the line work (:func:`_stage_rows`; the
    window form then :func:`_stage_rows_vertical`) and the column work
    (:func:`_stage_columns`), each over every line (in two bands on two threads:
    :func:`_in_bands`) before the next starts, since the window's column pass reads
    ``radius`` lines either side; with taps the box form's line work, then
    :func:`_stage_box`, :func:`_stage_rows_corrected` and :func:`_stage_columns` over
    every line (the row sums in planes); without taps the box form in one pass down each
    band's lines (:func:`_stage_box_fused`: the band's own planes and rings, one hand-off
    a stage) and the 1-D fit in one pass down each band's lines (:func:`_stage_fused`,
    each band its own ring). Returns
    the last stage's window sums (``sgg``, ``sge``, ``see``, and with ``vertical``
    ``syy``, ``sgy``, ``sye``, ``det``, ``nu``), written only at level 0 (``final``) or
    with taps; ``taps`` (level 0 of a run with taps): ``ax``, ``u_start`` (``ay``), then
    per stage the :data:`WARP_TAPS` (and :data:`VERTICAL_TAPS` or :data:`BOX_TAPS`)
    copied into it. The planes are the calling thread's
    :func:`~rangefx.rtl_model.runtime.scratch` buffers ``key.*``."""
    h, w = a.shape
    kind, lut, lanes, lanes_v = divider
    form = config.vertical_form
    vertical, box = form == "window", form == "box"  # the 2x2 system in the window; the box
    # without the vertical term and taps, a stage is one pass down the lines, the row
    # sums in a ring of lines (_stage_fused)
    fused = form == "off" and taps is None
    mv = h if form != "off" else 0  # the vertical term's planes: empty when it is off
    plane = lambda name, lines=h: runtime.scratch(f"{key}.{name}", (lines, w))  # noqa: E731
    ax = plane("ax")
    # the row sums: planes, or (fused) each band's own ring of lines, the scratch of the
    # thread that runs it (a ring shared by the two bands was a race: each overwrote the
    # other's lines, issue 38); the box form's rge, ree: rings (_stage_box_fused) but
    # for the taps
    rgg = plane("rgg", 0 if fused else h)
    rge, ree = (plane(k, 0 if fused or (box and taps is None) else h) for k in ("rge", "ree"))
    ring = (2 * config.radius + FUSED_CHUNK, w)
    # W, g, e as planes only for the taps and the vertical term, Wx and du for the taps,
    # the window sums for the taps and the last stage of level 0 (else line buffers)
    mk = h if form != "off" or taps is not None else 0
    wp, g, e = (plane(k, mk) for k in ("w", "g", "e"))
    wx = plane("wx", h if taps is not None else 0)
    du = plane("du", h if taps is not None else 0)
    sums = runtime.scratch(f"{key}.sums", (N_SUMS, h, w))
    no_sums = np.empty((N_SUMS, 0, w), dtype=np.int64)
    ay, wy, gy = (plane(k, mv) for k in ("ay", "wy", "gy"))
    ryy, rgy, rye = (plane(k, h if vertical else 0) for k in ("ryy", "rgy", "rye"))
    # the box form: v; the box sums, bdet, bnv, ev kept for the taps only (the five exact
    # box row sums: each band's ring of lines, _stage_box)
    mb, mt = (h if box else 0), (h if box and taps is not None else 0)
    bsums = runtime.scratch(f"{key}.bsums", (5, mt, w))
    v, bdet, bnv, ev = plane("v", mb), plane("bdet", mt), plane("bnv", mt), plane("ev", mt)
    if taps is not None:
        taps[1] = u

    def differences(st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int, y1: int) -> None:
        _difference_lines(a, f_l, base + L_AX, fm, st, ov, ax, y0, y1)

    def rows(st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int, y1: int) -> None:
        _stage_rows(a, b, u, 0, ax, f_l, rom, config.keys_bits, win, base, modes, fm, st, ov, wp,
                    wx, g, e, rgg, rge, ree, y0, y1, not box)  # fmt: skip

    def rows_vertical(first: bool, st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int,
                      y1: int) -> None:  # fmt: skip
        _stage_rows_vertical(a, wp, g, e, ay, f_l, win, base, first, fm, st, ov, wy, gy, ryy,
                             rgy, rye, y0, y1)  # fmt: skip

    def box_stage(first: bool, st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int,
                  y1: int) -> None:  # fmt: skip
        ring = runtime.scratch(f"{key}.ring.box", (2 * config.vertical_radius + 2, 5, w))
        _stage_box(a, wp, g, e, ay, f_l, config.vertical_radius, base, first, kind, lanes_v,
                   lut, config.recip_bits, log, modes, fm, st, dst, ov, wy, gy, ring, bsums,
                   bdet, bnv, v, y0, y1)  # fmt: skip

    def corrected(st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int, y1: int) -> None:
        _stage_rows_corrected(g, e, gy, v, config.vertical_radius, win, base, fm, st, ov, ev,
                              rge, ree, y0, y1)  # fmt: skip

    def columns(out: np.ndarray, st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int,
                y1: int) -> None:  # fmt: skip
        _stage_columns(u, umax, win, vertical, base, kind, lanes, lut, config.recip_bits, log,
                       modes, fm, st, dst, ov, rgg, rge, ree, ryy, rgy, rye, out, du, y0,
                       y1)  # fmt: skip

    def stage(out: np.ndarray, st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int,
              y1: int) -> None:  # fmt: skip
        rgg, rge, ree = (runtime.scratch(f"{key}.ring.{k}", ring) for k in ("rgg", "rge", "ree"))
        _stage_fused(a, b, u, uh, uh_off, ax, f_l, rom, config.keys_bits, win, umax, base,
                     kind, lanes, lut, config.recip_bits, log, modes, fm, st, dst, ov, rgg,
                     rge, ree, out, y0, y1)  # fmt: skip

    def box_fused(first: bool, out: np.ndarray, st: np.ndarray, dst: np.ndarray, ov: np.ndarray,
                  y0: int, y1: int) -> None:  # fmt: skip
        # the band's own planes and rings: the scratch of the thread that runs it (it
        # computes the other band's lines its column work reaches into them)
        wp, g, e, gy, rgg, v = (plane(k) for k in ("w", "g", "e", "gy", "rgg", "v"))
        rge, ree = (runtime.scratch(f"{key}.ring.{k}", ring) for k in ("rge", "ree"))
        box_ring = runtime.scratch(f"{key}.ring.box", (2 * rv + 2, 5, w))
        _stage_box_fused(a, b, u, uh, uh_lo, ax, f_l, rom, config.keys_bits, win, rv, umax,
                         base, first, kind, lanes, lanes_v, lut, config.recip_bits, log, modes,
                         fm, st, dst, ov, wp, g, e, ay, gy, rgg, box_ring, v, rge, ree,
                         out, y0, y1)  # fmt: skip

    _in_bands(differences, h, w, stats)
    # the estimate of the lines of the other band either side of the bands' boundary
    # that a band computes, before each stage (_in_bands splits at h // 2): the 1-D
    # fit's (_stage_fused) and the box form's (_stage_box_fused); in one band no line is
    # the other band's, and u itself is passed (not read there: copying it cost ~0.7 ms
    # of CPU a 512 x 512 frame, cProfile, one thread)
    rv, r = config.vertical_radius, config.radius
    bands = _two_bands(h, w, stats)
    uh_off = max(h // 2 - r, 0) if bands else 0
    uh_lo = max(h // 2 - (r + 2 * rv + 1), 0) if bands else 0
    uh_hi = min(h // 2 + max(r, rv) + 1, h)
    for k in range(config.warps):
        first = k == 0
        kept = taps is not None or (final and k == config.warps - 1)
        if fused:
            uh = u[uh_off : h // 2 + r].copy() if bands else u
            _in_bands(functools.partial(stage, sums if kept else no_sums), h, w, stats)
            continue
        if box and taps is None:  # the line work, the box and the tail in one pass
            uh = u[uh_lo:uh_hi].copy() if bands else u
            _in_bands(functools.partial(box_fused, first, sums if kept else no_sums), h, w,
                      stats)  # fmt: skip
            continue
        _in_bands(rows, h, w, stats)
        if vertical:
            _in_bands(functools.partial(rows_vertical, first), h, w, stats)
        if box:
            _in_bands(functools.partial(box_stage, first), h, w, stats)
        if box:  # with taps: the row sums on e + gy v into planes, every line
            _in_bands(corrected, h, w, stats)
        _in_bands(functools.partial(columns, sums if kept else no_sums), h, w, stats)
        if taps is None:
            continue
        if first:
            taps[0] = ax
            if form != "off":
                taps[2] = ay
        t0 = (3 if form != "off" else 2) + k * len(_stage_taps(config))
        for j, arr in enumerate((wp, wx, g, e, rgg, rge, ree, *sums[:3], du, u)):
            taps[t0 + j] = arr
        more = (wy, gy, ryy, rgy, rye, *sums[3:]) if vertical else ()
        if box:  # the box's taps as line y uses them: the box centred rv lines up
            late = np.maximum(np.arange(h) - config.vertical_radius, 0)
            more = (wy, gy, *(p[late] for p in (*bsums, bdet, bnv, v)), ev)
        for j, arr in enumerate(more):
            taps[t0 + N_STAGE_TAPS + j] = arr
    return sums


def run_p3(
    case: Case,
    config: P3Config,
    ranging: RangingConfig,
    timing: TimingConfig,
    *,
    taps: bool,
    threads: int,
    log: bool,
) -> PipelineResult:
    """Run P3 on ``case``'s registered stereo pair (E1 left, E2 right, camera 2
    ``B > 0`` to the right), integer grey levels; only ``ranging.range_max`` is read (G6's
    thresholds are design fields). ``threads`` = 2 builds the two pyramids at once, then
    runs each level of :data:`BAND_PIXELS` or more and the output stage in two bands of
    lines (:func:`_in_bands`). ``log`` off: ``minmax`` is empty (the casts still keep
    their min/max, the dividers skip their float log); overflow counts are always
    kept. The arguments are those :meth:`~rangefx.rtl_model.pipeline.Pipeline.run` checked
    (the public entry)."""
    # as given (the input cast reads any integer dtype): converting both 512 x 512 uint8
    # images to int64 first cost ~0.25 ms a frame (one thread)
    im1, im2 = runtime.check_image_pair(case.image1, case.image2, case.camera, pipeline="p3",
                                        min_shape=(1, 2), convert=False)  # fmt: skip
    m, n = im1.shape
    regs = p3_registers(config, case.camera, case.motion, ranging, (m, n))
    fm = runtime.format_table(config)
    kind, lut = runtime.divider_setup(config)
    rom, rom_overflows, rom_range = keys_rom_casts(config)
    shapes = level_shapes(config, (m, n))
    f_pix, f_pyr = fm[PIX, 1], fm[PYR, 1]
    normalise = config.normalise != "none"

    def pyramid(
        img: np.ndarray, site: int, norm_sites: tuple[int, int]
    ) -> tuple[list[np.ndarray], runtime.SignalStats]:
        """One camera's pyramid and, when normalising, each level normalised."""
        stats = runtime.SignalStats(N_SITES, len(P3_SIGNALS))
        st, _, ov = stats.arrays
        level = np.empty((m, n), dtype=np.int64)
        _input_kernel(img, site, fm, st, ov, level)
        out = [level]
        for k in range(1, len(shapes)):
            frac, s = (f_pix, S_PYR0) if k == 1 else (f_pyr, S_PYR1)
            out.append(_reduce_kernel(out[-1], frac, s, fm, st, ov))
        if normalise:
            for k, raw in enumerate(out):
                norm = np.empty(raw.shape, dtype=np.int64)
                _normalise_kernel(raw, f_pix if k == 0 else f_pyr, regs.nbox, fm[NBOX, 1],
                                  config.normalise_radius, norm_sites[k > 0], fm, st, ov,
                                  norm)  # fmt: skip
                out[k] = norm
        return out, stats

    streams = ((im1, S_PIX1, S_NORM[0]), (im2, S_PIX2, S_NORM[1]))
    if threads == 2:
        (p1, s1), (p2, s2) = runtime.run_two(pyramid, *streams)
    else:
        (p1, s1), (p2, s2) = (pyramid(*a) for a in streams)
    # one log per band: the second band's on the worker thread
    band_stats = [runtime.SignalStats(N_SITES, len(P3_SIGNALS)) for _ in range(threads)]
    st, _, ov = band_stats[0].arrays  # the expansions' log
    names = tap_names(config)
    tp = np.zeros((len(names), m, n) if taps else (len(names), 1, 1), dtype=np.int64)
    u = np.zeros(shapes[-1], dtype=np.int64)
    form = config.vertical_form
    vertical = form == "window"  # the 2x2 system in the window (the box form: the 1-D fit)
    modes = cast_modes(fm)
    # the reciprocal divider in SIMD lanes where its operands fit (divide_lanes_fit)
    reciprocal = kind == DIV_RECIPROCAL
    f_num, f_den, d_word = (NU, DET, fm[DET, 0]) if vertical else (SGE, SGG, fm[SGG, 0])
    lanes_du = reciprocal and divide_lanes_fit(fm[f_num, 1], fm[f_den, 1], d_word, DU,
                                               config.recip_bits, fm)  # fmt: skip
    lanes_z = reciprocal and divide_lanes_fit(fm[FB, 1], fm[U, 1], fm[U, 0], RANGE,
                                              config.recip_bits, fm)  # fmt: skip
    lanes_v = form == "box" and reciprocal and divide_lanes_fit(
        fm[BNV, 1], fm[BDET, 1], fm[BDET, 0], V, config.recip_bits, fm)  # fmt: skip
    # fraction bits of the pixels the warps read at level 0 and at the coarser levels
    f_level = (fm[NORM, 1],) * 2 if normalise else (f_pix, f_pyr)
    for level in range(len(shapes) - 1, -1, -1):
        h, w = shapes[level]
        if u.shape != (h, w):
            u = _expand_kernel(u, h, w, fm, st, ov)
            lag = min(config.coarse_lag, h)
            if lag:  # the coarse estimate arrives late: line y gets that of y - lag
                u = np.ascontiguousarray(u[np.maximum(np.arange(h) - lag, 0)])
        want = taps and level == 0
        sums = _run_level(
            config, p1[level], p2[level], u, f_level[level > 0], regs.umax[level], rom,
            regs.window, S_LEVEL + (N_LEVEL_SITES if level else 0), (kind, lut, lanes_du, lanes_v),
            log, modes, fm, band_stats, f"p3.{level}", tp if want else None, level == 0,
        )  # fmt: skip
    out_range = np.empty((m, n), dtype=np.int64)
    out_valid = np.empty((m, n), dtype=np.bool_)
    range_float = np.empty((m, n), dtype=np.float64)
    scale = 2.0 ** -config.formats["p3_range"].frac  # exact (FixedFormat.to_float)
    # the input beats' cycles in closed form band by band, as the output stage (as P1);
    # with input gaps, the stream's running count once
    closed = timing.gap_prob == 0
    in_cycles = np.empty((m, n), dtype=np.int64) if closed else input_cycles((m, n), timing)[-1]
    out_cycles = np.empty((m, n), dtype=np.int64)

    def final(st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int, y1: int) -> None:
        _final_kernel(
            u, sums, vertical, regs.final, kind, lanes_z, lut, config.recip_bits, log, modes,
            fm, st, dst, ov, out_range, out_valid, range_float, scale, tp, len(names) - 4, taps,
            y0, y1,
        )  # fmt: skip
        if closed:
            line_cycles((m, n), timing, 0, y0, y1, in_cycles[y0:y1])

    def stamps(st: np.ndarray, dst: np.ndarray, ov: np.ndarray, y0: int, y1: int) -> None:
        # after every band's input cycles: a line's output reads a later line's input
        tap_cycles("range", config, in_cycles, timing.hblank, (y0, y1), out_cycles[y0:y1])

    _in_bands(final, m, n, band_stats)
    _in_bands(stamps, m, n, band_stats)
    overflows, minmax = runtime.SignalStats.merge([s1, s2, *band_stats], P3_SIGNALS)
    overflows["p3_keys"] += rom_overflows  # the ROM is datapath (keys_rom_casts)
    minmax["p3_keys"] = rom_range
    tap_dict = {name: tp[k] for k, name in enumerate(names)} if taps else {}
    if taps and normalise:
        tap_dict.update({"e1.norm": p1[0], "e2.norm": p2[0]})
    return build_result(
        "p3", config, timing, "stereo", range_raw=out_range,
        range_float=range_float, valid=out_valid,
        taps=tap_dict, stats=(overflows, minmax), log=log, cycles=(in_cycles, out_cycles),
        stage_latency=stage_latencies(config), registers=regs,
        buffers={"line_buffer_bits": sum(buffer_bits(config, (m, n)).values())},
        schedule=p3_schedule(config, (m, n)),
    )  # fmt: skip
