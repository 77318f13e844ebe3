"""The numba cast and divider kernels every pipeline model shares (SPEC §4, §10).

Raw int64 arithmetic only, on the format table of :func:`~rangefx.rtl_model.runtime.format_table`
(one row per signal: word, frac, signed, quant, overflow): a cast into a signal that logs
its site's raw min/max (:func:`cast_site`, :func:`cast_row_site`, :func:`signal_plan`,
:func:`log_site`), and ``divide(N, D, S)`` of ``docs/p1_datapath.md`` with both divider
kinds, on scalars (:func:`divide_scalar`, :func:`divide_into`, :func:`divide_row`) and on
SIMD lanes (:func:`restoring_lane`, :func:`reciprocal_seed_index`, :func:`reciprocal_lane`,
:func:`lane_log_values`, their fallback :func:`divide_lanes_scalar`, and the row form
:func:`divide_row_lanes`). A band kernel writes its per-column lane loops itself from
these helpers: handed to an inlined function once per column, its arrays kept seven
reference-count increments and decrements per column (~7 % of P2's band kernel,
measured). The small helpers are ``inline="always"``, so they compile into each
pipeline's kernels as if written there.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.cpython.unsafe.numbers import leading_zeros, viewer

from .fixedpoint import (
    cast_by_plan,
    cast_plan,
    cast_row,
    cast_shifted,
    cast_short,
    overflow_raw,
)
from .runtime import (
    DIV_RESTORING,
    KERNEL_BOOL,
    KERNEL_FLAGS,
    KERNEL_FLOAT_PLANE,
    KERNEL_INT,
    KERNEL_PLANE,
    KERNEL_ROW,
)

__all__ = [
    "at_frac",
    "bit_length",
    "cast_row_site",
    "cast_site",
    "divide_into",
    "divide_lanes_fit",
    "divide_lanes_scalar",
    "divide_row",
    "divide_row_lanes",
    "divide_scalar",
    "floor_div",
    "floor_log2_lanes",
    "lane_log_values",
    "lane_overflows",
    "ldexp2",
    "log_site",
    "reciprocal_lane",
    "reciprocal_seed_index",
    "restoring_lane",
    "restoring_lane_setup",
    "signal_plan",
]

# short names of the argument types of the helpers with an explicit signature (see
# rangefx.rtl_model.runtime.KERNEL_INT: one compiled copy, not one per constant index)
_I, _B, _R, _P = KERNEL_INT, KERNEL_BOOL, KERNEL_ROW, KERNEL_PLANE
_FP, _FL = KERNEL_FLOAT_PLANE, KERNEL_FLAGS
_TWO52_BITS = np.int64(0x4330000000000000)  # the float64 2.0**52, as its bits
# the reciprocal divider's Newton operands (seed, normalised denominator, 2 - m y0, y1)
# are below 2**(R + 1) <= 2**29 (recip_bits <= 28): masked to 32 bits, which changes no
# value, so that LLVM multiplies them with the 32 x 32 -> 64-bit vpmuludq instead of
# emulating a 64-bit lane product on AVX2 (three vpmuludq and shifts)
_LOW32 = np.int64(0xFFFFFFFF)


@njit(cache=True, nogil=True, inline="always")
def cast_site(raw, frac_in, s, site, fm, st, ov):
    """Cast ``raw * 2**-frac_in`` into signal ``s``; log the raw pre-quantisation value.

    Min/max are kept per cast *site* as raw integers (each site has one ``frac_in``) and
    turned into values on the host; float conversion per cast would cost more than the
    cast itself.
    """
    # Unconditional stores and the common cast inlined: a branch around the stores, or a
    # non-inlined call on the common path, defeats numba's reference-count pruning of the
    # arrays and makes every cast ~8x slower (measured).
    st[site, 0] = min(st[site, 0], raw)
    st[site, 1] = max(st[site, 1], raw)
    st[site, 2] = frac_in
    st[site, 3] = s
    sh = frac_in - fm[s, 1]
    out, flag = cast_shifted(raw, sh, fm[s, 0], fm[s, 2] != 0, fm[s, 3], fm[s, 4], 0 <= sh <= 62)
    ov[s] += flag
    return out


@njit(cache=True, nogil=True, inline="always")
def at_frac(raw, frac, target):
    """``raw`` re-expressed with ``target >= frac`` fraction bits (exact left shift)."""
    return raw << (target - frac)


@njit(cache=True, nogil=True, inline="always")
def bit_length(x):
    """Bit length of ``x > 0`` (a leading-zero count, as in hardware)."""
    return np.int64(64 - leading_zeros(np.uint64(x)))


@njit(cache=True, nogil=True, inline="always")
def floor_log2_lanes(x):
    """``bit_length(x) - 1`` for ``1 <= x < 2**63`` by integer operations SIMD lanes have on
    every x86: ``x`` (shifted right by 26 bits when ``x >= 2**52``) is put in the mantissa
    of the float ``2**52``, which minus ``2**52`` is ``x`` as an exact float; its exponent
    field is the answer. AVX2 has no 64-bit leading-zero count; against LLVM's emulation
    of one, ``divide_row_lanes`` measured 16.2 -> 15.0 ns per element with this alone and
    -> 11.9-12.5 with the 32-bit Newton operands too (Zen 1, one row of 512)."""
    s = np.int64(26) if x >= np.int64(1) << 52 else np.int64(0)
    f = viewer((x >> s) | _TWO52_BITS, types.float64) - 4503599627370496.0
    return (viewer(f, types.int64) >> 52) - 1023 + s


@njit(cache=True, nogil=True, inline="always")
def ldexp2(x, k):
    """``math.ldexp(x, k)``; for ``|k| <= 1022`` as a product with ``2.0**k`` built from its
    exponent bits (the same value unless the result is subnormal; no libm call)."""
    if -1022 <= k <= 1022:
        return x * viewer(np.int64(k + 1023) << 52, types.float64)
    return math.ldexp(x, k)


@njit(cache=True, nogil=True)
def floor_div(t, d):
    """``t // d`` for 0 <= t, 0 < d; float-assisted when exact (integer division is slow)."""
    if t < 9007199254740992 and d < 9007199254740992:
        q = np.int64(float(t) / float(d))
        if q * d > t:
            q -= 1
        elif (q + 1) * d <= t:
            q += 1
        return q
    return t // d


@njit(cache=True, nogil=True, inline="always")
def divide_scalar(n, fn, d, fd, word, frac, signed, quant, ovf_mode, kind, lut, r_bits):
    """``divide(N, D, S)`` of docs/p1_datapath.md on scalars (inlined: see ``cast_site``).

    ``lut`` is the reciprocal seed table (:func:`reciprocal_lut`, ``2**L`` entries; unused
    by the restoring divider). Returns ``(raw, overflowed, lo, hi)``: ``lo``/``hi`` are the
    value to log into the signal's min/max (the quotient ``fl(fl(N)/fl(D)) 2**(F_D - F_N)``;
    ``+inf``/``-inf``, i.e. nothing, for ``D = 0``).
    """
    if d == 0:
        if n == 0:
            return np.int64(0), False, np.inf, -np.inf
        big = np.int64(1) << 62  # beyond any format: the overflow mode decides
        out, _ = overflow_raw(big if n > 0 else -big, word, signed, ovf_mode)
        return out, True, np.inf, -np.inf
    value = ldexp2(float(n) / float(d), fd - fn)
    # sign, seed index and normalisation by masks and clamped shifts, not branches: the
    # signs of real quotients are random, and a mispredicted branch per pixel cost more
    # than the divider's arithmetic (a row of divisions: 31 -> 22 ns/pixel, measured; 15
    # with the seed read from its table instead of computed with a division)
    negative = -np.int64((n < 0) != (d < 0))
    an = abs(n)
    ad = abs(d)
    if kind == DIV_RESTORING:
        sh = frac + 1 + fd - fn
        t = an << max(sh, 0)
        dd = ad << max(-sh, 0)
        q = floor_div(t, dd)
        sticky = np.int64(t != q * dd)
        # far out of range: any larger value saturates identically
        raw = 2 * min(q, np.int64(1) << (word + 2)) + sticky
        frac_in = frac + 2
    else:
        lut_bits = bit_length(lut.shape[0]) - 1
        p = bit_length(ad) - 1
        idx = ((ad >> max(p - lut_bits, 0)) << max(lut_bits - p, 0)) - lut.shape[0]
        y0 = lut[idx]
        m_r = (ad >> max(p - r_bits, 0)) << max(r_bits - p, 0)
        t = (m_r * y0) >> r_bits
        e = (np.int64(1) << (r_bits + 1)) - t
        y1 = (y0 * e) >> r_bits
        raw = an * y1
        frac_in = fn - fd + p + r_bits
    sh = frac_in - frac
    out, flag = cast_shifted((raw ^ negative) - negative, sh, word, signed, quant, ovf_mode,
                             0 <= sh <= 62)  # fmt: skip
    return out, flag, value, value


@njit(cache=True, nogil=True, inline="always")
def lane_overflows(word, signed, ovf_mode):
    """The quotients of ``D = 0`` in the lane dividers, ``(N > 0, N < 0)``: far beyond
    any format, so the overflow mode decides (as :func:`divide_scalar`)."""
    ov_pos, _ = overflow_raw(np.int64(1) << 62, word, signed, ovf_mode)
    ov_neg, _ = overflow_raw(-(np.int64(1) << 62), word, signed, ovf_mode)
    return ov_pos, ov_neg


@njit(cache=True, nogil=True, inline="always")
def restoring_lane_setup(fn, fd, word, frac, signed, quant, ovf_mode):
    """The per-call constants of :func:`restoring_lane`: ``(sh, plan, cap)``."""
    plan = cast_plan(np.int64(2), word, signed, quant, ovf_mode)
    return frac + 1 + fd - fn, plan, np.int64(1) << (word + 2)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def restoring_lane(n, d, sh, plan, cap, ov_pos, ov_neg, modes):
    """:func:`divide_scalar`'s restoring divider on one lane, branch-free: ``(quotient,
    overflowed, beyond)``; ``beyond`` when an operand is 2**53 or more (the float
    ``floor_div`` would not be exact: the caller falls back to :func:`divide_scalar`)."""
    one, exact = np.int64(1), np.int64(9007199254740992)
    dz = d == 0
    ds = one if dz else d
    negative = -np.int64((n < 0) != (ds < 0))
    t = abs(n) << max(sh, 0)
    dd = abs(ds) << max(-sh, 0)
    beyond = (t >= exact) | (dd >= exact)
    q = np.int64(float(t) / float(dd))
    dec = q * dd > t
    q = q - np.int64(dec) + np.int64((not dec) & ((q + 1) * dd <= t))
    raw = 2 * min(q, cap) + np.int64(t != q * dd)
    v, flag = cast_by_plan((raw ^ negative) - negative, plan, modes)
    out = (np.int64(0) if n == 0 else (ov_pos if n > 0 else ov_neg)) if dz else v
    return out, (n != 0) if dz else flag, beyond


@njit(cache=True, nogil=True, inline="always")
def reciprocal_seed_index(d, lut_bits, mask):
    """The seed ROM address of the reciprocal divider for the denominator ``d``: the
    ``lut_bits`` bits of ``|d|`` below its leading one (``D = 0`` reads entry 0)."""
    ad = max(abs(d), np.int64(1))
    p = floor_log2_lanes(ad)
    return ((ad >> max(p - lut_bits, 0)) << max(lut_bits - p, 0)) & mask


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def reciprocal_lane(n, d, seed, fn, fd, r_bits, word, frac, signed, quant, ovf_mode, ov_pos,
                    ov_neg, modes):  # fmt: skip
    """:func:`divide_scalar`'s reciprocal divider on one lane from its ROM entry ``seed``
    (at :func:`reciprocal_seed_index`), branch-free: ``(quotient, overflowed, beyond)``;
    ``beyond`` when the final cast would shift by more than 62 bits. The Newton operands
    (seed, normalised denominator, 2 - m y0, y1) are < 2**29 for every valid ``r_bits``
    (4..28): masked to 32 bits, LLVM multiplies them with one 32-bit product each
    instead of a three-multiply 64-bit emulation on AVX2."""
    one = np.int64(1)
    dz = d == 0
    ds = one if dz else d
    negative = -np.int64((n < 0) != (ds < 0))
    ad = abs(ds)
    p = floor_log2_lanes(ad)
    y0 = seed & _LOW32
    m_r = ((ad >> max(p - r_bits, 0)) << max(r_bits - p, 0)) & _LOW32
    e = ((one << (r_bits + 1)) - ((m_r * y0) >> r_bits)) & _LOW32
    raw = abs(n) * (((y0 * e) >> r_bits) & _LOW32)
    sh = fn - fd + p + r_bits - frac
    plan = cast_plan(min(max(sh, -62), 62), word, signed, quant, ovf_mode)
    v, flag = cast_by_plan((raw ^ negative) - negative, plan, modes)
    out = (np.int64(0) if n == 0 else (ov_pos if n > 0 else ov_neg)) if dz else v
    return out, (n != 0) if dz else flag, abs(sh) > 62


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def lane_log_values(n, d, scale):
    """The value a lane divider logs for ``n / d`` (``scale = 2**(F_D - F_N)``), as
    ``(for the minimum, for the maximum)``: ``D = 0`` logs nothing."""
    dz = d == 0
    value = float(n) / float(np.int64(1) if dz else d) * scale
    return (np.inf if dz else value), (-np.inf if dz else value)


_LANES_F = types.float64[::1]


@njit(
    _I(_R, _I, _R, _I, _I, _I, _I, _B, _I, _I, _I, _R, _I, _R, _FL, _LANES_F, _LANES_F, _B),
    cache=True, nogil=True, error_model="numpy",
)  # fmt: skip
def divide_lanes_scalar(
    num, fn, den, fd, count, word, frac, signed, quant, ovf_mode, kind, lut, r_bits,
    out, flags, lo, hi, log,
):  # fmt: skip
    """:func:`divide_scalar` of ``num[k] / den[k]`` for ``k < count`` into ``out[k]``,
    ``flags[k]`` and, when ``log``, ``lo[k]``/``hi[k]`` lowered/raised to the value logged;
    returns the number of overflows. The fallback of a band's lane loops for the lanes
    the branch-free helpers do not cover (``beyond``: ``floor_div`` operands of 2**53 or
    more, a reciprocal cast shifting by more than 62 bits, a log scale beyond 2**+-1022);
    one explicit signature, since its callers pass constants."""
    n_ovf = np.int64(0)
    for k in range(count):
        q, flag, v_lo, v_hi = divide_scalar(num[k], fn, den[k], fd, word, frac, signed, quant,
                                            ovf_mode, kind, lut, r_bits)  # fmt: skip
        out[k] = q
        flags[k] = flag
        n_ovf += flag
        if log:
            lo[k] = min(lo[k], v_lo)
            hi[k] = max(hi[k], v_hi)
    return n_ovf


@njit(cache=True, nogil=True, inline="always")
def divide_into(n, fn, d, fd, s, kind, lut, r_bits, fm, dst, ov):
    """:func:`divide_scalar` into signal ``s``: logs min/max and counts overflows."""
    out, flag, lo, hi = divide_scalar(n, fn, d, fd, fm[s, 0], fm[s, 1], fm[s, 2] != 0, fm[s, 3],
                                fm[s, 4], kind, lut, r_bits)  # fmt: skip
    dst[s, 0] = min(dst[s, 0], lo)
    dst[s, 1] = max(dst[s, 1], hi)
    ov[s] += flag
    return out, flag


@njit((_R, _I, _R, _I, _I, _I, _R, _I, _P, _FP, _R, _R, _FL), cache=True, nogil=True)
def divide_row(num, fn, den, fd, s, kind, lut, r_bits, fm, dst, ov, out, flags):
    """:func:`divide_scalar` of a row into signal ``s`` (``out``, overflow ``flags``); the log
    and the overflow count are kept in registers and written once per row (updating them
    in memory per element measured ~2x the divider's own cost)."""
    word, frac, signed, quant, ovf = fm[s, 0], fm[s, 1], fm[s, 2] != 0, fm[s, 3], fm[s, 4]
    lo, hi, count = dst[s, 0], dst[s, 1], np.int64(0)
    for i in range(num.shape[0]):
        q, flag, v_lo, v_hi = divide_scalar(num[i], fn, den[i], fd, word, frac, signed, quant, ovf,
                                      kind, lut, r_bits)  # fmt: skip
        out[i] = q
        flags[i] = flag
        count += flag
        lo = v_lo if v_lo < lo else lo
        hi = v_hi if v_hi > hi else hi
    dst[s, 0], dst[s, 1] = lo, hi
    ov[s] += count


@njit((_I, _I, _I, _I, _I, _P), cache=True, nogil=True)
def divide_lanes_fit(fn, fd, d_word, s, r_bits, fm):
    """Whether :func:`divide_row_lanes` takes a division into signal ``s`` of a numerator
    at ``fn`` by a denominator at ``fd`` of at most ``d_word`` bits: every final cast of
    the reciprocal product shifts right by 0..62 bits and the log's scale is a plain
    product (:func:`ldexp2`)."""
    base = fn - fd + r_bits - fm[s, 1]
    return base >= 0 and base + d_word - 1 <= 62 and abs(fd - fn) <= 1022


@njit(
    [(_R, _I, _R, _I, _I, _R, _I, _P, _FP, _R, _R, _FL, _B, modes)
     for modes in (types.none, types.boolean)],
    cache=True,
    nogil=True,
)  # fmt: skip
def divide_row_lanes(num, fn, den, fd, s, lut, r_bits, fm, dst, ov, out, flags, log, modes):
    """:func:`divide_row` for the reciprocal divider, in SIMD lanes: the same quotients,
    flags, overflow count and log (``log`` off: none), with ``D = 0`` by selects instead
    of a branch. Three loops along the row: the seed index and normalisation, the seed
    ROM read (a scalar loop: LLVM would not vectorise the gather, and with it in the loop
    vectorised nothing), then Newton step, product and cast; the log in a fourth (the
    caller checks :func:`divide_lanes_fit`). ``modes``: the final cast's body
    (:func:`~rangefx.rtl_model.fixedpoint.cast_short`; None for a config of plain modes:
    1.76-1.79 against 2.08-2.13 ns per element in ``rangefx bench``)."""
    n = num.shape[0]
    word, frac, signed, quant, ovf = fm[s, 0], fm[s, 1], fm[s, 2] != 0, fm[s, 3], fm[s, 4]
    lut_bits = bit_length(lut.shape[0]) - 1
    mask = lut.shape[0] - 1
    base = fn - fd + r_bits - frac
    scale = ldexp2(1.0, fd - fn)
    one = np.int64(1)
    z_pos, z_neg = lane_overflows(word, signed, ovf)  # D = 0 (divide_scalar)
    lo, hi, count = dst[s, 0], dst[s, 1], np.int64(0)
    seed = np.empty(n, dtype=np.int64)
    norm = np.empty(n, dtype=np.int64)
    for i in range(n):  # reciprocal_seed_index, keeping the normalisation (one log2)
        ad = max(abs(den[i]), one)
        p = floor_log2_lanes(ad)
        seed[i] = ((ad >> max(p - lut_bits, 0)) << max(lut_bits - p, 0)) & mask
        norm[i] = p
    for i in range(n):
        seed[i] = lut[seed[i]]
    for i in range(n):
        nv = num[i]
        d = den[i]
        ad = max(abs(d), one)
        p = norm[i]
        y0 = seed[i] & _LOW32
        m_r = ((ad >> max(p - r_bits, 0)) << max(r_bits - p, 0)) & _LOW32
        t = (m_r * y0) >> r_bits
        y1 = ((y0 * (((one << (r_bits + 1)) - t) & _LOW32)) >> r_bits) & _LOW32
        negative = -np.int64((nv < 0) != (d < 0))
        raw = abs(nv) * y1
        q, flag = cast_short((raw ^ negative) - negative, base + p, word, signed, quant, ovf,
                             modes)  # fmt: skip
        zero = d == 0
        q = (np.int64(0) if nv == 0 else (z_pos if nv > 0 else z_neg)) if zero else q
        flag = (nv != 0) if zero else flag
        out[i] = q
        flags[i] = flag
        count += flag
    if log:  # its own loop: in the loop above, the float division ran even with log off
        for i in range(n):
            d = den[i]
            v = (float(num[i]) / float(d if d != 0 else one)) * scale
            lo = min(lo, np.inf if d == 0 else v)
            hi = max(hi, -np.inf if d == 0 else v)
    dst[s, 0], dst[s, 1] = lo, hi
    ov[s] += count


@njit((_R, _I, _I, _I, _P, _P, _R), cache=True, nogil=True)
def cast_row_site(raw, frac_in, s, site, fm, st, ov):
    """:func:`cast_site` of a whole row (one loop per cast: the format is loop-invariant)."""
    out = np.empty_like(raw)
    lo, hi, count = cast_row(raw, frac_in, fm[s, 0], fm[s, 1], fm[s, 2] != 0, fm[s, 3], fm[s, 4],
                             out)  # fmt: skip
    st[site, 0] = min(st[site, 0], lo)
    st[site, 1] = max(st[site, 1], hi)
    st[site, 2] = frac_in
    st[site, 3] = s
    ov[s] += count
    return out


@njit((_I, _I, _P), cache=True, nogil=True)
def signal_plan(frac_in, s, fm):
    """:func:`~rangefx.rtl_model.fixedpoint.cast_plan` of a cast into signal ``s``."""
    return cast_plan(frac_in - fm[s, 1], fm[s, 0], fm[s, 2] != 0, fm[s, 3], fm[s, 4])


@njit((_P, _I, _I, _I, _I, _I), cache=True, nogil=True)
def log_site(st, site, lo, hi, frac_in, s):
    """Merge a site's raw (lo, hi) kept in registers into its log."""
    st[site, 0] = min(st[site, 0], lo)
    st[site, 1] = max(st[site, 1], hi)
    st[site, 2] = frac_in
    st[site, 3] = s
