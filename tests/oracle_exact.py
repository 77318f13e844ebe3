"""Exact fixed-point arithmetic shared by the independent test oracles (``oracle_p1.py``,
``oracle_p2.py``, ``oracle_p3.py``).

Written from the datapath pages, not from ``rangefx.rtl_model``: values are exact (Python
ints, :class:`fractions.Fraction`, :class:`apytypes.APyFixed`); every ``cast`` quantises with
apytypes in the configured quantisation mode and brings the result into range with apytypes'
``WRAP``/``SAT`` (``SAT_ZERO``/``SAT_SYM``, which apytypes 0.5.1 lacks, are built on its
``SAT`` result by a representability check done here). Left shifts (a cast to more fraction
bits) are exact and done on Python ints, which avoids apytypes' mis-saturation when a left
shift needs more than 64 bits. The dividers' bit-level steps use Python ints: the radix-2
restoring divider is an explicit bit-by-bit restoring loop, the reciprocal divider is the
LUT + Newton definition. Also here: what every oracle returns (:class:`OracleResult`) and
keeps of its casts (:class:`SignalLog`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from apytypes import APyFixed, OverflowMode, QuantizationMode

from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant

__all__ = [
    "OracleResult",
    "SignalLog",
    "apy_value",
    "cast_exact",
    "code_range",
    "divide_by_zero_code",
    "divide_reciprocal",
    "divide_restoring",
    "exact_parts",
    "fmt_value",
    "fraction_of",
    "reciprocal_lut",
    "reciprocal_value",
    "reg_raw",
    "restoring_loop",
    "restoring_value",
    "shift_floor",
    "signed_raw",
]

_APY_QUANT = {q: getattr(QuantizationMode, q.name) for q in Quant}


# ---------------------------------------------------------------------------------------
# exact values <-> apytypes
# ---------------------------------------------------------------------------------------
def apy_value(n: int, f: int) -> APyFixed:
    """The exact value ``n * 2**-f`` as an APyFixed (two's complement, just wide enough)."""
    bits = max(n.bit_length() + 1, 2)
    return APyFixed(n % (1 << bits), bits=bits, frac_bits=f)


def signed_raw(v: APyFixed) -> int:
    """Raw integer (signed) of an APyFixed."""
    raw = int(v.to_bits())
    return raw - (1 << v.bits) if raw >> (v.bits - 1) else raw


def exact_parts(v: APyFixed) -> tuple[int, int]:
    """``(n, f)`` with ``v = n * 2**-f``."""
    return signed_raw(v), v.frac_bits


def fmt_value(raw: int, fmt: FixedFormat) -> APyFixed:
    """APyFixed holding raw code ``raw`` of ``fmt`` (an unsigned format gets a sign bit)."""
    return apy_value(raw, fmt.frac)


def fraction_of(n: int, f: int) -> Fraction:
    return Fraction(n, 1 << f) if f >= 0 else Fraction(n << -f)


# ---------------------------------------------------------------------------------------
# cast = quantise (apytypes, configured mode), then overflow (apytypes WRAP/SAT + checks)
# ---------------------------------------------------------------------------------------
def quantise_exact(n: int, f: int, fmt: FixedFormat) -> int:
    """Integer multiple of ``2**-F`` nearest ``n 2**-f`` under ``fmt.quant`` (no overflow)."""
    if fmt.frac >= f:  # exact left shift: done on ints (apytypes mis-saturates > 64 bits)
        return n << (fmt.frac - f)
    x = apy_value(n, f)
    int_bits = x.int_bits + 1  # room for a rounding carry: nothing can wrap here
    if int_bits + fmt.frac < 2:
        int_bits = 2 - fmt.frac
    y = x.cast(
        int_bits=int_bits,
        frac_bits=fmt.frac,
        quantization=_APY_QUANT[fmt.quant],
        overflow=OverflowMode.WRAP,
    )
    return signed_raw(y)


def code_range(fmt: FixedFormat) -> tuple[int, int]:
    """Codes the overflow mode accepts untouched (SAT_SYM: the most negative is excluded)."""
    if fmt.signed:
        hi = (1 << (fmt.word - 1)) - 1
        lo = -hi if (fmt.overflow is Overflow.SAT_SYM and fmt.word > 1) else -hi - 1
    else:
        lo, hi = 0, (1 << fmt.word) - 1
    return lo, hi


def overflow_exact(q: int, fmt: FixedFormat) -> tuple[int, bool]:
    """Bring integer ``q`` into ``fmt``'s word with its overflow mode; (code, acted)."""
    lo, hi = code_range(fmt)
    acted = not lo <= q <= hi
    apy_mode = OverflowMode.WRAP if fmt.overflow is Overflow.WRAP else OverflowMode.SAT
    src = apy_value(q, 0)
    if fmt.signed:
        out = signed_raw(src.cast(bits=fmt.word, frac_bits=0, overflow=apy_mode))
    else:
        # unsigned W bits: a signed W+1-bit word holds [-2**W, 2**W - 1]; wrap keeps the
        # low W bits of it, saturation clamps its negative half to 0.
        wide = src.cast(bits=fmt.word + 1, frac_bits=0, overflow=apy_mode)
        if fmt.overflow is Overflow.WRAP:
            out = int(wide.to_bits()) & ((1 << fmt.word) - 1)
        else:
            out = max(signed_raw(wide), 0)
    if fmt.overflow is Overflow.SAT_ZERO and acted:
        out = 0
    if fmt.overflow is Overflow.SAT_SYM and out < lo:
        out = lo  # apytypes' SAT gave -2**(W-1); SAT_SYM stops at -raw_max
    return out, acted


def cast_exact(n: int, f: int, fmt: FixedFormat) -> tuple[int, bool]:
    """Cast the exact value ``n * 2**-f`` into ``fmt``: (raw code, overflow acted)."""
    return overflow_exact(quantise_exact(n, f, fmt), fmt)


def reg_raw(x: float, fmt: FixedFormat) -> int:
    """Host register: float64 ``x`` (an exact dyadic rational) quantised into ``fmt``."""
    fr = Fraction(float(x))
    num, den = fr.numerator, fr.denominator
    f = den.bit_length() - 1
    assert den == 1 << f
    return cast_exact(num, f, fmt)[0]


# ---------------------------------------------------------------------------------------
# dividers (Python ints for the bit-level steps)
# ---------------------------------------------------------------------------------------
def divide_by_zero_code(n_sign: int, fmt: FixedFormat) -> int:
    """D = 0, N != 0: the overflow mode of S acts on an infinite value with N's sign."""
    lo, hi = code_range(fmt)
    if fmt.overflow == Overflow.SAT_ZERO:
        return 0
    return hi if n_sign > 0 else lo


def restoring_loop(t: int, d: int) -> tuple[int, int]:
    """Radix-2 restoring division of ``t >= 0`` by ``d > 0``: one quotient bit per step."""
    rem = 0
    quo = 0
    for k in range(t.bit_length() - 1, -1, -1):
        rem = (rem << 1) | ((t >> k) & 1)  # shift in the next dividend bit
        quo <<= 1
        trial = rem - d
        if trial >= 0:  # restore (keep rem) when the trial subtraction goes negative
            rem = trial
            quo |= 1
    return quo, rem


def restoring_value(n: int, fn: int, d: int, fd: int, fmt: FixedFormat) -> tuple[int, int]:
    """Pre-quantisation value ``(m, f)`` of the restoring divider for ``d != 0``."""
    sign = (1 if n >= 0 else -1) * (1 if d > 0 else -1)
    shift = fmt.frac + 1 + fd - fn
    t, dd = (abs(n) << shift, abs(d)) if shift >= 0 else (abs(n), abs(d) << -shift)
    q, rem = restoring_loop(t, dd)
    sticky = 1 if rem else 0
    return sign * (2 * q + sticky), fmt.frac + 2


def reciprocal_lut(lut_bits: int, recip_bits: int) -> list[int]:
    """``LUT[idx] = round_half_up(2**(R+1) / (2 + (2 idx + 1) 2**-L))``."""
    out = []
    for idx in range(1 << lut_bits):
        x = Fraction(1 << (recip_bits + 1)) / (2 + Fraction(2 * idx + 1, 1 << lut_bits))
        out.append(math.floor(x + Fraction(1, 2)))
    return out


def reciprocal_value(
    n: int, fn: int, d: int, fd: int, lut: list[int], lut_bits: int, recip_bits: int
) -> tuple[int, int]:
    """Pre-quantisation value ``(m, f)`` of the reciprocal divider for ``d != 0``."""
    sign = (1 if n >= 0 else -1) * (1 if d > 0 else -1)
    L, R = lut_bits, recip_bits
    dm = abs(d)
    p = dm.bit_length() - 1
    idx = shift_floor(dm, L - p) - (1 << L)
    y0 = lut[idx]
    m_r = shift_floor(dm, R - p)
    t = (m_r * y0) >> R
    e = (1 << (R + 1)) - t
    y1 = (y0 * e) >> R
    return sign * abs(n) * y1, fn - fd + p + R


def shift_floor(x: int, s: int) -> int:
    """``floor(x * 2**s)`` for an integer ``x``."""
    return x << s if s >= 0 else x >> -s


def divide_restoring(n: int, fn: int, d: int, fd: int, fmt: FixedFormat) -> tuple[int, bool]:
    """Restoring divider ``divide(N, D, S)``: (raw code of S, overflow)."""
    if d == 0:
        return (0, False) if n == 0 else (divide_by_zero_code((n > 0) - (n < 0), fmt), True)
    return cast_exact(*restoring_value(n, fn, d, fd, fmt), fmt)


def divide_reciprocal(
    n: int, fn: int, d: int, fd: int, fmt: FixedFormat, lut_bits: int = 8, recip_bits: int = 20
) -> tuple[int, bool]:
    """Reciprocal (LUT + Newton) divider ``divide(N, D, S)``: (raw code of S, overflow)."""
    if d == 0:
        return (0, False) if n == 0 else (divide_by_zero_code((n > 0) - (n < 0), fmt), True)
    lut = reciprocal_lut(lut_bits, recip_bits)
    return cast_exact(*reciprocal_value(n, fn, d, fd, lut, lut_bits, recip_bits), fmt)


# ---------------------------------------------------------------------------------------
# what an oracle returns and keeps
# ---------------------------------------------------------------------------------------
@dataclass
class OracleResult:
    """What a bit-exact test compares: taps (int64 raw codes, shape (m, n)), among them the
    outputs ``range`` and ``valid``, overflow counts and pre-quantisation ranges."""

    taps: dict[str, np.ndarray]
    overflows: dict[str, int]
    minmax: dict[str, tuple[float, float]]

    @property
    def range_raw(self) -> np.ndarray:
        return self.taps["range"]

    @property
    def valid(self) -> np.ndarray:
        return self.taps["valid"].astype(bool)


class SignalLog:
    """What every oracle keeps of its casts beside the taps: the overflow count and the
    exact pre-quantisation min/max of every signal of ``config`` (the model's
    ``overflows`` and ``minmax``)."""

    def __init__(self, config: WordLengthConfig) -> None:
        self.config = config
        self.overflows = dict.fromkeys(config.signals(), 0)
        self.lo: dict[str, Fraction] = {}
        self.hi: dict[str, Fraction] = {}

    def log(self, name: str, x: Fraction) -> None:
        """Widen ``name``'s min/max to the exact value ``x``."""
        if name not in self.lo or x < self.lo[name]:
            self.lo[name] = x
        if name not in self.hi or x > self.hi[name]:
            self.hi[name] = x

    def minmax(self) -> dict[str, tuple[float, float]]:
        signals = self.config.signals()
        return {k: (float(self.lo[k]), float(self.hi[k])) for k in signals if k in self.lo}

    def result(self, taps: dict[str, np.ndarray]) -> OracleResult:
        return OracleResult(taps=taps, overflows=dict(self.overflows), minmax=self.minmax())
