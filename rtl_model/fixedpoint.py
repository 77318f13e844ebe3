"""Fixed-point formats and bit-exact cast kernels (SPEC §4 "Fixed-point semantics").

A value of format (signed, W, F) is held as a raw integer ``r`` and means ``r * 2**-F``.
``F`` may be negative or larger than ``W``.  Quantisation and overflow modes carry the
Vitis HLS ``ap_fixed`` names and meanings.  Casting is always *quantise, then overflow*:
the exact value is first rounded to a multiple of ``2**-F_out`` with the quantisation mode,
then the resulting integer is brought into the ``W_out``-bit range with the overflow mode
(so a rounding carry out of the top bit is an overflow, as in ``ap_fixed``).

The kernels work on ``int64`` raw integers only: no floats, no Python objects, so they can
be called from other ``@njit`` code.  The public Python wrappers validate and allocate.

Inlining policy: the few-instruction pieces of the common cast (``_round_offsets``,
``_quantise_short``, ``overflow_raw``, ``cast_shifted``) are inlined into the callers'
loops (numba ``inline="always"``); the rare, larger cases (``quantise_shift``'s shifts
beyond 62, ``shift_left_raw``, ``_cast_shifted``) are calls. Inlining those too bought
no speed and cost ~2.4x the cold compile of the P1 kernels (230 s vs 95 s, measured).
"""

from __future__ import annotations

import enum
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit, types
from numba.core.errors import NumbaIRAssumptionWarning
from numba.extending import overload

__all__ = [
    "ANY_MODES",
    "MAX_WORD",
    "PLAIN_MODES",
    "PLAIN_OVERFLOWS",
    "PLAIN_QUANTS",
    "FixedFormat",
    "Overflow",
    "Quant",
    "cast_array",
    "cast_by_plan",
    "cast_modes",
    "cast_plan",
    "cast_raw",
    "cast_row",
    "cast_shifted",
    "cast_short",
    "overflow_raw",
    "plain_modes",
    "quantise_shift",
    "rounding_doc_text",
    "rounding_table",
    "rounding_table_markdown",
    "shift_left_raw",
    "write_rounding_doc",
]

MAX_WORD = 62
MAX_ABS_FRAC = 1022
_I64_MIN = -(2**63)
_I64_MAX = 2**63 - 1


class Quant(enum.IntEnum):
    """Quantisation modes, named and defined as Vitis HLS ``ap_fixed`` (SPEC §4).

    With ``q = floor(x)`` and ``x - q`` the remainder of the exact value ``x`` in units of
    the result LSB:

    * ``TRN``: toward -inf (``q``); dropping bits of a two's complement word.
    * ``TRN_ZERO``: toward zero.
    * ``RND``: to nearest, ties toward +inf.
    * ``RND_ZERO``: to nearest, ties toward zero.
    * ``RND_INF``: to nearest, ties away from zero.
    * ``RND_MIN_INF``: to nearest, ties toward -inf.
    * ``RND_CONV``: to nearest, ties to even (convergent).
    """

    TRN = 0
    TRN_ZERO = 1
    RND = 2
    RND_ZERO = 3
    RND_INF = 4
    RND_MIN_INF = 5
    RND_CONV = 6


class Overflow(enum.IntEnum):
    """Overflow modes, named and defined as Vitis HLS ``ap_fixed`` (SPEC §4).

    * ``WRAP``: keep the low ``W`` bits (two's complement for signed formats).
    * ``SAT``: clamp to ``[raw_min, raw_max]``.
    * ``SAT_ZERO``: an out-of-range value becomes 0.
    * ``SAT_SYM``: clamp to ``[-raw_max, raw_max]`` for signed formats (the most negative
      code ``-2**(W-1)`` is never produced and counts as an overflow); as ``SAT`` for
      unsigned formats and, as in the ``ap_fixed`` header, for signed 1-bit formats
      (there the symmetric clamp leaves the sign bit set: a negative result is ``-1``).
    """

    WRAP = 0
    SAT = 1
    SAT_ZERO = 2
    SAT_SYM = 3


_Q_TRN = 0
_Q_TRN_ZERO = 1
_Q_RND = 2
_Q_RND_ZERO = 3
_Q_RND_INF = 4
_Q_RND_MIN_INF = 5
_Q_RND_CONV = 6
_O_WRAP = 0
_O_SAT = 1
_O_SAT_ZERO = 2
_O_SAT_SYM = 3


@njit(cache=True, nogil=True)
def _floor_shift(raw, shift):
    """Floor of ``raw / 2**shift`` (``shift >= 1``) and the remainder's class.

    Returns ``(q, half_cmp, inexact)``: ``q = floor(raw / 2**shift)``; ``half_cmp`` is -1, 0
    or +1 as the remainder ``raw / 2**shift - q`` is below, at or above one half;
    ``inexact`` is True when the remainder is non-zero.
    """
    if shift <= 62:
        q = raw >> shift
        rem = raw - (q << shift)
        half = np.int64(1) << (shift - 1)
        if rem < half:
            cmp = -1
        elif rem == half:
            cmp = 0
        else:
            cmp = 1
        return q, cmp, rem != 0
    if raw >= 0:
        if shift == 63:
            half = np.int64(1) << 62
            cmp = -1 if raw < half else (0 if raw == half else 1)
        else:
            cmp = -1
        return np.int64(0), cmp, raw != 0
    if shift == 63:
        excess = raw + (np.int64(1) << 62)
        cmp = -1 if excess < 0 else (0 if excess == 0 else 1)
        return np.int64(-1), cmp, raw != _I64_MIN
    if shift == 64:
        cmp = 0 if raw == _I64_MIN else 1
        return np.int64(-1), cmp, True
    return np.int64(-1), 1, True


@njit(cache=True, nogil=True, inline="always")
def _round_offsets(shift, quant):
    """Offsets ``(a, b, c)`` for ``0 <= shift <= 62`` (all zero at 0): the rounded quotient is
    ``q + floor((rem + a + b [raw < 0] + c (q mod 2)) / 2**shift)`` with ``q``, ``rem`` the
    floor and remainder of ``raw / 2**shift`` (so the sum stays below ``2**(shift + 1)``).

    With ``h = 2**(shift - 1)``: TRN adds nothing; TRN_ZERO ``2**shift - 1`` when negative
    (a ceiling); RND ``h`` (ties up); RND_MIN_INF ``h - 1`` (ties down); RND_ZERO ``h - 1``,
    plus one when negative (ties toward zero); RND_INF ``h``, minus one when negative (ties
    away from zero); RND_CONV ``h - 1``, plus one when ``q`` is odd (ties to even).
    """
    # conditional expressions, not if-blocks: they become selects that the compiler can
    # hoist out of a loop over elements (the if-block form measured ~1.5x slower per cast)
    half = (np.int64(1) << shift) >> 1
    sub = np.int64(1) if shift > 0 else np.int64(0)
    rounding = quant >= _Q_RND
    up = quant == _Q_RND or quant == _Q_RND_INF  # ties resolved upward before the sign fix
    a = np.int64(0) if not rounding else (half if up else half - sub)
    b = (
        (np.int64(1) << shift) - 1
        if quant == _Q_TRN_ZERO
        else (sub if quant == _Q_RND_ZERO else (-sub if quant == _Q_RND_INF else np.int64(0)))
    )
    c = sub if quant == _Q_RND_CONV else np.int64(0)
    return a, b, c


@njit(cache=True, nogil=True, inline="always")
def _quantise_short(raw, shift, quant):
    """:func:`quantise_shift` for ``0 <= shift <= 62``: the floor plus one carry.

    The carry ``floor(t / 2**shift)`` of ``t = rem + offsets < 2**(shift + 1)`` is 0 or 1,
    so it is a comparison (vectorisable), not a second 64-bit arithmetic shift (AVX2 has
    none and emulates it).
    """
    a, b, c = _round_offsets(shift, quant)
    one_s = np.int64(1) << shift
    q = raw >> shift
    t = (raw & (one_s - 1)) + a + (b & -np.int64(raw < 0)) + (c & -(q & 1))
    return q + np.int64(t >= one_s)


@njit(cache=True, nogil=True)
def quantise_shift(raw, shift, quant):
    """Drop ``shift`` LSBs of ``raw`` with quantisation mode ``quant`` (SPEC §4).

    Parameters
    ----------
    raw : int64
        Raw integer.
    shift : int64
        Number of LSBs to drop; any ``shift >= 1`` is exact, including ``shift >= 64``.
        ``shift <= 0`` is an exact left shift ``raw * 2**-shift``: the caller guarantees the
        product fits int64 (otherwise the result is that product modulo 2**64; a shift of
        64 or more returns 0).
    quant : int64
        A :class:`Quant` value.

    Returns
    -------
    int64
        ``round(raw / 2**shift)`` under ``quant``: with ``q = floor(raw / 2**shift)`` (an
        arithmetic right shift) and the remainder ``rem``: TRN ``q``; TRN_ZERO ``q + 1`` iff
        ``q < 0`` and ``rem != 0``; otherwise ``q + 1`` iff ``rem > 1/2``, or ``rem == 1/2``
        and the tie rule goes up (RND always, RND_ZERO iff ``q < 0``, RND_INF iff
        ``q >= 0``, RND_MIN_INF never, RND_CONV iff ``q`` is odd).
    """
    if shift <= 0:
        if shift <= -64:
            return np.int64(0)
        return raw << (-shift)
    if shift <= 62:
        # the common case: q = floor, then one carry from the remainder plus a per-mode
        # offset. No data-dependent branch and no per-mode return, so that in a loop the
        # mode-dependent offsets are computed once and the loop body is the same few
        # instructions for every mode (the branchy form cost ~3.5x as much per cast).
        return _quantise_short(raw, shift, quant)
    q, cmp, inexact = _floor_shift(raw, shift)
    if quant == _Q_TRN:
        return q
    if quant == _Q_TRN_ZERO:
        return q + 1 if (inexact and q < 0) else q
    if cmp > 0:
        return q + 1
    if cmp < 0:
        return q
    if quant == _Q_RND:
        return q + 1
    if quant == _Q_RND_ZERO:
        return q + 1 if q < 0 else q
    if quant == _Q_RND_INF:
        return q + 1 if q >= 0 else q
    if quant == _Q_RND_CONV:
        return q + 1 if (q & 1) == 1 else q
    return q


@njit(cache=True, nogil=True, inline="always")
def overflow_raw(raw, word, signed, mode):
    """Bring ``raw`` into the range of a ``word``-bit format with overflow ``mode`` (SPEC §4).

    Parameters
    ----------
    raw : int64
        Raw integer already at the target fraction bits.
    word : int64
        Target word length ``W``, ``1 <= W <= 62``.
    signed : bool
        Two's complement range ``[-2**(W-1), 2**(W-1) - 1]`` if True, else ``[0, 2**W - 1]``.
    mode : int64
        An :class:`Overflow` value.

    Returns
    -------
    (int64, bool)
        The value in range, and whether ``raw`` was out of range (for signed SAT_SYM with
        ``W >= 2`` the code ``-2**(W-1)`` also counts, since it is replaced by
        ``-(2**(W-1) - 1)``; for ``W = 1`` the header keeps ``-1``, as SAT).
    """
    one = np.int64(1)
    # conditional expressions and one return (selects the compiler hoists out of loops;
    # see _round_offsets)
    hi = (one << (word - 1)) - 1 if signed else (one << word) - 1
    # ap_fixed's SAT_SYM clamp of a 1-bit word is the code with its sign bit set (-1)
    lo = (-hi if (mode == _O_SAT_SYM and word > 1) else -hi - 1) if signed else np.int64(0)
    below_hi = raw <= hi
    inside = (raw >= lo) & below_hi
    wrapped = ((raw - lo) & ((one << word) - 1)) + lo  # two's-complement wrap, mod 2**64 safe
    saturated = lo if below_hi else hi  # out of range: one select, not a min and a max
    other = wrapped if mode == _O_WRAP else (np.int64(0) if mode == _O_SAT_ZERO else saturated)
    return raw if inside else other, not inside


@njit(cache=True, nogil=True)
def shift_left_raw(raw, n, word, signed, overflow):
    """Exact ``raw * 2**n`` (``n >= 1``) brought into a ``word``-bit format by ``overflow``.

    A product that does not fit int64 is an overflow: saturated by sign, or wrapped to the
    low ``word`` bits of the exact product. Returns (int64, overflowed).
    """
    if raw == 0:
        return np.int64(0), False
    if n >= 63:
        fits = False
    else:
        fits = (_I64_MIN >> n) <= raw <= (_I64_MAX >> n)
    if fits:
        return overflow_raw(raw << n, word, signed, overflow)
    if overflow == _O_WRAP:
        if n >= word:
            low = np.int64(0)
        else:
            low = (raw & ((np.int64(1) << (word - n)) - 1)) << n
        value, _ = overflow_raw(low, word, signed, overflow)
        return value, True
    sentinel = np.int64(_I64_MAX) if raw > 0 else np.int64(_I64_MIN)
    value, _ = overflow_raw(sentinel, word, signed, overflow)
    return value, True


@njit(cache=True, nogil=True)
def cast_raw(raw, frac_in, word_out, frac_out, signed_out, quant, overflow):
    """Cast ``raw * 2**-frac_in`` to format (signed_out, word_out, frac_out) (SPEC §4).

    Quantises with :func:`quantise_shift` (``shift = frac_in - frac_out``), then applies
    :func:`overflow_raw`; a negative shift is :func:`shift_left_raw`. Exact for every int64
    ``raw`` and any fraction bits.

    Returns
    -------
    (int64, bool)
        The raw result and whether an overflow occurred.
    """
    return _cast_shifted(raw, frac_in - frac_out, word_out, signed_out, quant, overflow)


@njit(cache=True, nogil=True)
def _cast_shifted(raw, shift, word, signed, quant, overflow):
    """:func:`cast_raw` with ``shift = frac_in - frac_out`` (any sign) given."""
    if shift >= 0:
        return overflow_raw(quantise_shift(raw, shift, quant), word, signed, overflow)
    return shift_left_raw(raw, -shift, word, signed, overflow)


@njit(cache=True, nogil=True, inline="always")
def cast_shifted(raw, shift, word, signed, quant, overflow, short):
    """:func:`cast_raw` with ``shift = frac_in - frac_out`` given. ``short`` promises
    ``0 <= shift <= 62``: that case is a few branch-free inlined instructions, the others a
    call. A loop whose caller decided the shift's case once passes a constant (only that
    case is compiled into the loop); a scalar site passes ``0 <= shift <= 62``. Returns
    (int64, overflowed)."""
    if short:
        return overflow_raw(_quantise_short(raw, shift, quant), word, signed, overflow)
    return _cast_shifted(raw, shift, word, signed, quant, overflow)


@njit(cache=True, nogil=True)
def cast_row(raw, frac_in, word, frac, signed, quant, overflow, out):
    """:func:`cast_raw` of every element of the 1-D ``raw`` into ``out``, with its log.

    Returns
    -------
    (int64, int64, int64)
        Minimum and maximum of ``raw`` (the pre-quantisation log; int64 max/min for an
        empty row) and the number of overflows.
    """
    shift = frac_in - frac
    # the shift's case is decided once per row: the common 0..62 loop, compiled without
    # the other cases in its body, measured 2.1 vs 4.9 ns per element (one loop for all)
    if 0 <= shift <= 62:
        return _cast_row_loop(raw, shift, word, signed, quant, overflow, out, True)
    return _cast_row_loop(raw, shift, word, signed, quant, overflow, out, False)


@njit(cache=True, nogil=True, inline="always")
def _cast_row_loop(raw, shift, word, signed, quant, overflow, out, short):
    """The loop of :func:`cast_row`; ``short`` (a constant at each call) selects the
    ``0 <= shift <= 62`` body.

    The short body quantises and logs only; overflow is then decided on the row's extremes
    (every quantisation mode is monotonic, so the quantised minimum and maximum are the
    extremes of the quantised row) and only a row that overflows takes a second loop that
    applies the overflow mode and counts, element by element. Per-element range checks
    and selects are most of a cast's cost on AVX2 (no 64-bit vector min/max).
    """
    lo = np.int64(_I64_MAX)
    hi = np.int64(_I64_MIN)
    count = np.int64(0)
    if short:
        for i in range(raw.shape[0]):
            r = raw[i]
            lo = min(lo, r)
            hi = max(hi, r)
            out[i] = _quantise_short(r, shift, quant)
        if raw.shape[0] == 0:
            return lo, hi, count
        _, low_out = overflow_raw(_quantise_short(lo, shift, quant), word, signed, overflow)
        _, high_out = overflow_raw(_quantise_short(hi, shift, quant), word, signed, overflow)
        if low_out or high_out:
            for i in range(raw.shape[0]):
                value, flag = overflow_raw(out[i], word, signed, overflow)
                out[i] = value
                count += flag
        return lo, hi, count
    for i in range(raw.shape[0]):
        r = raw[i]
        lo = min(lo, r)
        hi = max(hi, r)
        value, flag = cast_shifted(r, shift, word, signed, quant, overflow, False)
        out[i] = value
        count += flag
    return lo, hi, count


@njit(cache=True, nogil=True, inline="always")
def cast_plan(shift, word, signed, quant, overflow):
    """Loop-invariant constants of a cast with ``shift = frac_in - frac_out``,
    ``|shift| <= 62`` (for :func:`cast_by_plan`, computed once outside a loop):
    ``(left, right, a, b, c, lo, hi, mask, overflow, lo_x, hi_x)``, where ``[lo_x, hi_x]``
    is the range ``[lo, hi]`` divided by ``2**left`` (inward): the values whose left shift
    lands in range."""
    left = max(-shift, 0)
    right = max(shift, 0)
    a, b, c = _round_offsets(right, quant)
    one = np.int64(1)
    hi = (one << (word - 1)) - 1 if signed else (one << word) - 1
    lo = (-hi if (overflow == _O_SAT_SYM and word > 1) else -hi - 1) if signed else np.int64(0)
    lo_x, hi_x = -((-lo) >> left), hi >> left
    return (left, right, a, b, c, lo, hi, (one << word) - 1, np.int64(overflow), lo_x, hi_x)


#: The ``modes`` argument of :func:`cast_by_plan` (and of the kernels that pass it down)
#: when every cast of a config is *plain* (:func:`plain_modes`): its type, not its value,
#: selects the cast body, so a kernel is compiled at most twice (plain and any modes),
#: never once per config. ``ANY_MODES`` (a bool) compiles the body for every mode.
PLAIN_MODES = None
ANY_MODES = True
#: Quantisation modes whose rounding offset does not depend on the value (TRN, RND,
#: RND_MIN_INF) and overflow modes that saturate to the format's extremes (SAT, SAT_SYM).
PLAIN_QUANTS = (_Q_TRN, _Q_RND, _Q_RND_MIN_INF)
PLAIN_OVERFLOWS = (_O_SAT, _O_SAT_SYM)


def plain_modes(fm: np.ndarray) -> bool:
    """Whether every format of the table ``fm`` (rows ``(word, frac, signed, quant,
    overflow)``) quantises and overflows with a plain mode (:data:`PLAIN_QUANTS`,
    :data:`PLAIN_OVERFLOWS`), so that the plain cast body is exact for all its casts.
    Called once per model run: a loop over the table's Python ints (~2 µs for P2's 16
    rows) rather than two ``np.isin`` (~39 µs, ~1 % of a two-thread P2 run, measured)."""
    return all(q in PLAIN_QUANTS and o in PLAIN_OVERFLOWS for q, o in fm[:, 3:5].tolist())


#: Whether kernels take the plain cast body where it applies (False: the body for any
#: modes everywhere, for A/B measurements and the test that both give the same bits).
PLAIN_BODY = True


def cast_modes(fm: np.ndarray) -> bool | None:
    """The ``modes`` argument for a kernel run with the format table ``fm``:
    :data:`PLAIN_MODES` where :func:`plain_modes` holds (and :data:`PLAIN_BODY`), else
    :data:`ANY_MODES`."""
    return PLAIN_MODES if PLAIN_BODY and plain_modes(fm) else ANY_MODES


def cast_by_plan(raw, plan, modes):
    """:func:`cast_raw` of ``raw`` by a :func:`cast_plan`, for either sign of the shift:
    one branch-free body (selects only), so that a loop of several casts vectorises.
    Callable from numba-compiled code only (the body is chosen at compile time).

    ``modes`` is :data:`ANY_MODES` or :data:`PLAIN_MODES` (None: the caller guarantees
    the plan's modes are plain, :func:`plain_modes`); its type selects one of two bodies
    (:func:`_cast_by_plan_any`, :func:`_cast_by_plan_plain`) when the caller is typed, so
    neither carries the other's code (the same choice made by a branch inside one body
    left both in LLVM's vectoriser, which ran for minutes on P1's range kernel). The
    plain body drops the sign and parity terms of the rounding offset and the wrap.
    Returns (int64, overflowed)."""
    raise TypeError("cast_by_plan is called from numba-compiled code only")


def _cast_by_plan_any(raw, plan, modes):
    """:func:`cast_by_plan` for any modes.

    A plan shifts one way only (``left`` or ``right`` is 0), so the body rounds the right
    shift (a no-op for a left one) and then range-checks the rounded value *before* the
    left shift, against the range divided by ``2**left``: in range, the shift is exact
    and fits int64; out of range it is an overflow (the sign's extreme for the saturating
    modes; for WRAP the low ``W`` bits of the exact product, which those of the shift
    modulo 2**64 are, as in :func:`shift_left_raw`). No test of the shift itself, no
    min/max (the checks measured 2.57 -> 1.31 ns per element for a chain of three casts)."""
    left, right, a, b, c, lo, hi, mask, mode, lo_x, hi_x = plan
    one_s = np.int64(1) << right
    q = raw >> right
    t = (raw & (one_s - 1)) + a + (b & -np.int64(raw < 0)) + (c & -(q & 1))
    x = q + np.int64(t >= one_s)
    below_hi = x <= hi_x
    inside = (x >= lo_x) & below_hi
    y = x << left
    wrapped = ((y - lo) & mask) + lo
    saturated = lo if below_hi else hi
    other = wrapped if mode == _O_WRAP else (np.int64(0) if mode == _O_SAT_ZERO else saturated)
    return y if inside else other, not inside


def _cast_by_plan_plain(raw, plan, modes):
    """:func:`cast_by_plan` for plain modes (:data:`PLAIN_QUANTS`, :data:`PLAIN_OVERFLOWS`):
    the rounding offset is the plan's constant ``a`` (``b = c = 0``), an overflow
    saturates (``lo`` is already SAT_SYM's)."""
    left, right, a, _, _, lo, hi, _, _, lo_x, hi_x = plan
    one_s = np.int64(1) << right
    # the carry by a logical shift of a non-negative sum (AVX2 has that one, not the
    # arithmetic one): measured faster than the comparison form here
    carry = np.int64(np.uint64((raw & (one_s - 1)) + a) >> np.uint64(right))
    x = (raw >> right) + carry
    below_hi = x <= hi_x
    inside = (x >= lo_x) & below_hi
    y = x << left
    saturated = lo if below_hi else hi
    out = y if inside else saturated
    return out, not inside


# numba's SSA check reports the conditional expressions of the bodies inlined through the
# overload as "not in scope" (a pedantic warning of its own; the values are checked bit
# for bit against the Fraction reference and the oracles); only those are silenced
warnings.filterwarnings(
    "ignore", r".*variable '_cast_(by_plan|short)_[\w.]+' is not in scope", NumbaIRAssumptionWarning
)


@overload(cast_by_plan, inline="always")
def _cast_by_plan_typed(raw, plan, modes):
    return _cast_by_plan_plain if isinstance(modes, types.NoneType) else _cast_by_plan_any


def cast_short(raw, shift, word, signed, quant, overflow, modes):
    """:func:`cast_shifted` for ``0 <= shift <= 62`` (``short``) with the body chosen by
    ``modes`` as in :func:`cast_by_plan`, for loops whose shift changes per element (the
    lane dividers' final cast). Callable from numba-compiled code only. Returns
    (int64, overflowed)."""
    raise TypeError("cast_short is called from numba-compiled code only")


def _cast_short_any(raw, shift, word, signed, quant, overflow, modes):
    return cast_shifted(raw, shift, word, signed, quant, overflow, True)


def _cast_short_plain(raw, shift, word, signed, quant, overflow, modes):
    one = np.int64(1)
    one_s = one << shift
    a, _, _ = _round_offsets(shift, quant)  # b = c = 0 for the plain modes
    carry = np.int64(np.uint64((raw & (one_s - 1)) + a) >> np.uint64(shift))
    x = (raw >> shift) + carry
    # the range of overflow_raw (SAT_SYM's lo), without its wrap and mode selects
    hi = (one << (word - 1)) - 1 if signed else (one << word) - 1
    lo = (-hi if (overflow == _O_SAT_SYM and word > 1) else -hi - 1) if signed else np.int64(0)
    below_hi = x <= hi
    inside = (x >= lo) & below_hi
    saturated = lo if below_hi else hi
    out = x if inside else saturated
    return out, not inside


@overload(cast_short, inline="always")
def _cast_short_typed(raw, shift, word, signed, quant, overflow, modes):
    return _cast_short_plain if isinstance(modes, types.NoneType) else _cast_short_any


def _check_int(name: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer, not {value!r}")
    return int(value)


_FORMAT_RE = re.compile(r"^([su])(\d+)\.(-?\d+)$")


@dataclass(frozen=True)
class FixedFormat:
    """A fixed-point format: raw integer ``r`` of ``word`` bits means ``r * 2**-frac``.

    Parameters
    ----------
    signed : bool
        Two's complement if True, else unsigned.
    word : int
        Word length ``W``, ``1 <= W <= 62`` so that raw values and one carry fit int64.
    frac : int
        Fraction bits ``F``, ``|F| <= 1022`` (so ``lsb`` is a normal float64); may be
        negative or larger than ``W``.
    quant : Quant
        Quantisation mode used when casting *into* this format.
    overflow : Overflow
        Overflow mode used when casting *into* this format.
    """

    signed: bool
    word: int
    frac: int
    quant: Quant = Quant.TRN
    overflow: Overflow = Overflow.WRAP

    def __post_init__(self) -> None:
        if not isinstance(self.signed, bool | np.bool_):
            raise ValueError(f"signed must be a bool, not {self.signed!r}")
        word = _check_int("word", self.word)
        if not 1 <= word <= MAX_WORD:
            raise ValueError(f"word length must be in 1..{MAX_WORD}, not {self.word!r}")
        frac = _check_int("frac", self.frac)
        if abs(frac) > MAX_ABS_FRAC:
            raise ValueError(
                f"fraction bits must be in -{MAX_ABS_FRAC}..{MAX_ABS_FRAC}, not {self.frac!r}"
            )
        for name, enum_type in (("quant", Quant), ("overflow", Overflow)):
            value = getattr(self, name)
            foreign = isinstance(value, enum.Enum) and not isinstance(value, enum_type)
            if foreign or isinstance(value, bool) or not isinstance(value, int):
                raise ValueError(f"{name} must be a {enum_type.__name__}, not {value!r}")
            try:
                member = enum_type(value)
            except ValueError:
                raise ValueError(f"{name} must be a {enum_type.__name__}, not {value!r}") from None
            object.__setattr__(self, name, member)
        object.__setattr__(self, "signed", bool(self.signed))
        object.__setattr__(self, "word", word)
        object.__setattr__(self, "frac", frac)

    @classmethod
    def from_string(
        cls, text: str, quant: Quant = Quant.TRN, overflow: Overflow = Overflow.WRAP
    ) -> FixedFormat:
        """Parse ``"s16.8"`` (signed, W=16, F=8) or ``"u12.-2"`` (unsigned, W=12, F=-2)."""
        match = _FORMAT_RE.match(text.strip()) if isinstance(text, str) else None
        if match is None:
            raise ValueError(f"format must look like 's16.8' or 'u12.-2', not {text!r}")
        sign, word, frac = match.groups()
        return cls(sign == "s", int(word), int(frac), quant, overflow)

    @property
    def int_bits(self) -> int:
        """Integer bits ``W - F`` (including the sign bit, as ``ap_fixed``'s ``I``)."""
        return self.word - self.frac

    @property
    def raw_min(self) -> int:
        """Smallest raw code: ``-2**(W-1)`` if signed, else 0."""
        return -(1 << (self.word - 1)) if self.signed else 0

    @property
    def raw_max(self) -> int:
        """Largest raw code: ``2**(W-1) - 1`` if signed, else ``2**W - 1``."""
        return (1 << (self.word - 1)) - 1 if self.signed else (1 << self.word) - 1

    @property
    def lsb(self) -> float:
        """Weight of one raw step, ``2**-F``."""
        return math.ldexp(1.0, -self.frac)

    def describe(self) -> str:
        """Vitis HLS spelling, e.g. ``ap_fixed<16,8,AP_RND,AP_SAT>``."""
        kind = "ap_fixed" if self.signed else "ap_ufixed"
        return f"{kind}<{self.word},{self.int_bits},AP_{self.quant.name},AP_{self.overflow.name}>"

    def __str__(self) -> str:
        return f"{'s' if self.signed else 'u'}{self.word}.{self.frac}"

    def to_float(self, raw: int | np.ndarray, out: np.ndarray | None = None) -> float | np.ndarray:
        """Value of raw code(s) as float64, ``raw * 2**-F`` (exact while ``|raw| < 2**53``);
        an array's values go into ``out`` (float64, the same shape) when given."""
        if isinstance(raw, np.ndarray):
            if raw.dtype.kind in "iu":  # one pass: a product by 2**-F is exact (|F| <= 1022)
                return np.multiply(raw, 2.0**-self.frac, out=out, dtype=np.float64)
            if out is None:
                out = raw.astype(np.float64)
            else:
                np.copyto(out, raw, casting="unsafe")
            return np.ldexp(out, -self.frac, out=out)
        return math.ldexp(float(_check_int("raw", raw)), -self.frac)

    def from_float(self, x: float) -> int:
        """Raw code of float64 ``x`` quantised exactly with this format's modes.

        ``x = m * 2**(e - 53)`` with an integer ``m`` (``|m| < 2**53``) is cast by
        :func:`cast_raw` from ``frac_in = 53 - e``, so no float rounding is involved.
        """
        x = float(x)
        if not math.isfinite(x):
            raise ValueError(f"cannot quantise a non-finite value, {x!r}")
        mantissa, exponent = math.frexp(x)
        raw = int(math.ldexp(mantissa, 53))
        value, _ = cast_raw(
            raw,
            53 - exponent,
            self.word,
            self.frac,
            self.signed,
            int(self.quant),
            int(self.overflow),
        )
        return int(value)


def cast_array(raw: np.ndarray, frac_in: int, fmt: FixedFormat) -> tuple[np.ndarray, int]:
    """Cast raw codes ``raw * 2**-frac_in`` into ``fmt`` with its modes (SPEC §4).

    Parameters
    ----------
    raw : numpy.ndarray
        Integer array (any shape); values must fit int64.
    frac_in : int
        Fraction bits of ``raw``.
    fmt : FixedFormat
        Target format, quantisation and overflow modes.

    Returns
    -------
    (numpy.ndarray, int)
        int64 raw codes of ``fmt`` (same shape as ``raw``) and the number of overflows.
    """
    if not isinstance(fmt, FixedFormat):
        raise ValueError(f"fmt must be a FixedFormat, not {fmt!r}")
    frac_in = _check_int("frac_in", frac_in)
    if not _I64_MIN <= frac_in <= _I64_MAX:
        raise ValueError(f"frac_in must fit int64, not {frac_in!r}")
    arr = np.asarray(raw)
    if arr.dtype.kind not in "iu":
        raise ValueError(f"raw must be an integer array, not dtype {arr.dtype!r}")
    if arr.dtype == np.uint64 and arr.size and int(arr.max()) > _I64_MAX:
        raise ValueError(f"raw values must fit int64, got {int(arr.max())!r}")
    flat = np.ascontiguousarray(arr, dtype=np.int64).ravel()
    out = np.empty_like(flat)
    _, _, count = cast_row(
        flat,
        np.int64(frac_in),
        np.int64(fmt.word),
        np.int64(fmt.frac),
        fmt.signed,
        np.int64(fmt.quant),
        np.int64(fmt.overflow),
        out,
    )
    return out.reshape(arr.shape), int(count)


TIES = (-2.5, -1.5, -0.5, 0.5, 1.5, 2.5)

_MATLAB = {
    Quant.TRN: "Floor",
    Quant.TRN_ZERO: "Zero",
    Quant.RND: "Nearest",
    Quant.RND_ZERO: "none",
    Quant.RND_INF: "Round",
    Quant.RND_MIN_INF: "none",
    Quant.RND_CONV: "Convergent",
}
_VHDL = {
    Quant.TRN: "fixed_truncate",
    Quant.TRN_ZERO: "none",
    Quant.RND: "none",
    Quant.RND_ZERO: "none",
    Quant.RND_INF: "none",
    Quant.RND_MIN_INF: "none",
    Quant.RND_CONV: "fixed_round",
}


def rounding_table() -> list[dict]:
    """Each :class:`Quant` mode applied by :func:`quantise_shift` to the ties in ``TIES``.

    Each row: ``mode`` (Quant name), ``ap_fixed`` (``AP_...``), one key per tie
    (``"-2.5"`` ... ``"2.5"``) holding the integer result (F=0), ``matlab`` (fimath
    RoundingMethod with the same result everywhere, or ``"none"``) and ``vhdl`` (IEEE 1076-2008
    ``fixed_pkg`` ``fixed_round_style``, or ``"none"``).
    """
    rows = []
    for mode in Quant:
        row: dict = {"mode": mode.name, "ap_fixed": f"AP_{mode.name}"}
        for tie in TIES:
            row[str(tie)] = int(quantise_shift(np.int64(round(tie * 2)), 1, int(mode)))
        row["matlab"] = _MATLAB[mode]
        row["vhdl"] = _VHDL[mode]
        rows.append(row)
    return rows


def rounding_table_markdown() -> str:
    """:func:`rounding_table` as a Markdown table (ends with a newline)."""
    header = ["ap_fixed", *(str(t) for t in TIES), "MATLAB RoundingMethod", "VHDL fixed_pkg"]
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for row in rounding_table():
        cells = [
            f"`{row['ap_fixed']}`",
            *(str(row[str(t)]) for t in TIES),
            row["matlab"],
            row["vhdl"],
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


_DOC_HEAD = """\
# Rounding modes on ties

Generated by `python -m rangefx.rtl_model.fixedpoint` from
`rangefx.rtl_model.fixedpoint.rounding_table_markdown()` (SPEC §4); a test keeps it current.
Each cell is the integer that the mode gives for the tie in the column header (F=0),
computed by the model's own integer kernel.

"""

_DOC_TAIL = """
Names clash across tools: MATLAB `Round` is `AP_RND_INF` (ties away from zero) while MATLAB
`Nearest` is `AP_RND` (ties toward +inf), and IEEE `fixed_pkg` `fixed_round` is convergent
(`AP_RND_CONV`, ties to even, per its `round_fixed`), not `AP_RND`.
`AP_RND_ZERO` and `AP_RND_MIN_INF` have no MATLAB RoundingMethod, `fixed_pkg` offers only
`fixed_truncate` (`AP_TRN`) and `fixed_round` (`AP_RND_CONV`), and MATLAB `Ceiling` (toward
+inf) has no `ap_fixed` mode.
On ties alone `AP_TRN_ZERO` matches `AP_RND_ZERO` and `AP_TRN` matches `AP_RND_MIN_INF`, but
they differ off the ties (0.75 gives 0 and 1), so a tie-only test cannot tell them apart.
Defaults differ as well: `ap_fixed` uses `AP_TRN`/`AP_WRAP`, MATLAB `fimath`
`Nearest`/`Saturate`, and `fixed_pkg` `fixed_round`/`fixed_saturate`.

## The reference: the `ap_fixed` header itself

`tests/test_ap_fixed_header.py` builds a C++ program with g++ against the Vitis HLS
`ap_types` headers (they ship in the hls4ml wheel, `hls4ml/templates/vivado/ap_types/`;
`pip download --no-deps hls4ml` and unzip, then point `RANGEFX_AP_TYPES` at the folder) and
compares `cast_raw` and `cast_array`, value and overflow flag, for every quantisation x
overflow mode pair on random and boundary values; CI runs it. apytypes stays a second
opinion: it mis-rounds some shifts over 62 bits and some saturating left shifts.

One corner follows the header rather than the textbook: a signed 1-bit format under
`AP_SAT_SYM`. Its symmetric clamp `[-raw_max, raw_max]` would be `[0, 0]`, but the header
sets the sign bit for a negative result (its "most negative plus one" is the code `1`, i.e.
-1 in one bit), so the mode acts as `AP_SAT`: a negative result is -1, and -1 itself is
not an overflow. For `W >= 2` `AP_SAT_SYM` never produces `-2^(W-1)`.
"""


def rounding_doc_text() -> str:
    """Full text of ``docs/rounding.md``."""
    return _DOC_HEAD + rounding_table_markdown() + _DOC_TAIL


def write_rounding_doc(path: str | Path) -> None:
    """Write :func:`rounding_doc_text` to ``path`` (UTF-8, ``\\n`` line ends)."""
    Path(path).write_text(rounding_doc_text(), encoding="utf-8", newline="\n")


if __name__ == "__main__":
    write_rounding_doc(Path(__file__).resolve().parent.parent / "docs" / "rounding.md")
