"""Independent, deliberately slow test oracle of the P1 datapath (issue 4, deliverable 6).

Written from ``docs/p1_datapath.md`` only: it shares nothing with the numba kernels of
``rangefx.rtl_model`` but the word-length config (formats, modes and design fields) and
the pipeline's public tap names (``FRONTEND_TAPS``, ``RANGE_TAPS``: the interface the
bit-exact test compares by; a tap the oracle does not compute is compared as zeros).
Signal values are :class:`apytypes.APyFixed` (exact arithmetic, growing word length);
every ``cast`` quantises with apytypes in the configured quantisation mode and brings the
result into range with apytypes' ``WRAP``/``SAT`` (``SAT_ZERO``/``SAT_SYM``, which
apytypes 0.5.1 lacks, are built on its ``SAT`` result by a representability check done
here). Left shifts (a cast to more fraction bits) are exact and done on Python ints, which
avoids apytypes' mis-saturation when a left shift needs more than 64 bits. The dividers'
bit-level steps use Python ints: the radix-2 restoring divider is an explicit bit-by-bit
restoring loop, the reciprocal divider is the LUT + Newton definition.

Everything runs as Python loops over the pixels in scan order; use small images only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from apytypes import APyFixed, OverflowMode, QuantizationMode

from rangefx.golden.geometry import MotionIncrement, PinholeCamera, k_matrix
from rangefx.golden.ranging import RangingConfig
from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1 import FRONTEND_TAPS, RANGE_TAPS
from rangefx.rtl_model.p1.config import P1Config

__all__ = [
    "OracleResult",
    "SignalLog",
    "cast_exact",
    "divide_reciprocal",
    "divide_restoring",
    "oracle_p1",
    "reg_raw",
]

_APY_QUANT = {q: getattr(QuantizationMode, q.name) for q in Quant}


# ---------------------------------------------------------------------------------------
# exact values <-> apytypes
# ---------------------------------------------------------------------------------------
def _apy(n: int, f: int) -> APyFixed:
    """The exact value ``n * 2**-f`` as an APyFixed (two's complement, just wide enough)."""
    bits = max(n.bit_length() + 1, 2)
    return APyFixed(n % (1 << bits), bits=bits, frac_bits=f)


def _signed(v: APyFixed) -> int:
    """Raw integer (signed) of an APyFixed."""
    raw = int(v.to_bits())
    return raw - (1 << v.bits) if raw >> (v.bits - 1) else raw


def _exact(v: APyFixed) -> tuple[int, int]:
    """``(n, f)`` with ``v = n * 2**-f``."""
    return _signed(v), v.frac_bits


def _value(raw: int, fmt: FixedFormat) -> APyFixed:
    """APyFixed holding raw code ``raw`` of ``fmt`` (an unsigned format gets a sign bit)."""
    return _apy(raw, fmt.frac)


def _fraction(n: int, f: int) -> Fraction:
    return Fraction(n, 1 << f) if f >= 0 else Fraction(n << -f)


# ---------------------------------------------------------------------------------------
# cast = quantise (apytypes, configured mode), then overflow (apytypes WRAP/SAT + checks)
# ---------------------------------------------------------------------------------------
def _quantise(n: int, f: int, fmt: FixedFormat) -> int:
    """Integer multiple of ``2**-F`` nearest ``n 2**-f`` under ``fmt.quant`` (no overflow)."""
    if fmt.frac >= f:  # exact left shift: done on ints (apytypes mis-saturates > 64 bits)
        return n << (fmt.frac - f)
    x = _apy(n, f)
    int_bits = x.int_bits + 1  # room for a rounding carry: nothing can wrap here
    if int_bits + fmt.frac < 2:
        int_bits = 2 - fmt.frac
    y = x.cast(
        int_bits=int_bits,
        frac_bits=fmt.frac,
        quantization=_APY_QUANT[fmt.quant],
        overflow=OverflowMode.WRAP,
    )
    return _signed(y)


def _range(fmt: FixedFormat) -> tuple[int, int]:
    """Codes the overflow mode accepts untouched (SAT_SYM: the most negative is excluded)."""
    if fmt.signed:
        hi = (1 << (fmt.word - 1)) - 1
        lo = -hi if (fmt.overflow is Overflow.SAT_SYM and fmt.word > 1) else -hi - 1
    else:
        lo, hi = 0, (1 << fmt.word) - 1
    return lo, hi


def _overflow(q: int, fmt: FixedFormat) -> tuple[int, bool]:
    """Bring integer ``q`` into ``fmt``'s word with its overflow mode; (code, acted)."""
    lo, hi = _range(fmt)
    acted = not lo <= q <= hi
    apy_mode = OverflowMode.WRAP if fmt.overflow is Overflow.WRAP else OverflowMode.SAT
    src = _apy(q, 0)
    if fmt.signed:
        out = _signed(src.cast(bits=fmt.word, frac_bits=0, overflow=apy_mode))
    else:
        # unsigned W bits: a signed W+1-bit word holds [-2**W, 2**W - 1]; wrap keeps the
        # low W bits of it, saturation clamps its negative half to 0.
        wide = src.cast(bits=fmt.word + 1, frac_bits=0, overflow=apy_mode)
        if fmt.overflow is Overflow.WRAP:
            out = int(wide.to_bits()) & ((1 << fmt.word) - 1)
        else:
            out = max(_signed(wide), 0)
    if fmt.overflow is Overflow.SAT_ZERO and acted:
        out = 0
    if fmt.overflow is Overflow.SAT_SYM and out < lo:
        out = lo  # apytypes' SAT gave -2**(W-1); SAT_SYM stops at -raw_max
    return out, acted


def cast_exact(n: int, f: int, fmt: FixedFormat) -> tuple[int, bool]:
    """Cast the exact value ``n * 2**-f`` into ``fmt``: (raw code, overflow acted)."""
    return _overflow(_quantise(n, f, fmt), fmt)


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
def _div_zero(n_sign: int, fmt: FixedFormat) -> int:
    """D = 0, N != 0: the overflow mode of S acts on an infinite value with N's sign."""
    lo, hi = _range(fmt)
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


def _restoring_value(n: int, fn: int, d: int, fd: int, fmt: FixedFormat) -> tuple[int, int]:
    """Pre-quantisation value ``(m, f)`` of the restoring divider for ``d != 0``."""
    sign = (1 if n >= 0 else -1) * (1 if d > 0 else -1)
    shift = fmt.frac + 1 + fd - fn
    t, dd = (abs(n) << shift, abs(d)) if shift >= 0 else (abs(n), abs(d) << -shift)
    q, rem = restoring_loop(t, dd)
    sticky = 1 if rem else 0
    return sign * (2 * q + sticky), fmt.frac + 2


def _recip_lut(lut_bits: int, recip_bits: int) -> list[int]:
    """``LUT[idx] = round_half_up(2**(R+1) / (2 + (2 idx + 1) 2**-L))``."""
    out = []
    for idx in range(1 << lut_bits):
        x = Fraction(1 << (recip_bits + 1)) / (2 + Fraction(2 * idx + 1, 1 << lut_bits))
        out.append(math.floor(x + Fraction(1, 2)))
    return out


def _reciprocal_value(
    n: int, fn: int, d: int, fd: int, lut: list[int], lut_bits: int, recip_bits: int
) -> tuple[int, int]:
    """Pre-quantisation value ``(m, f)`` of the reciprocal divider for ``d != 0``."""
    sign = (1 if n >= 0 else -1) * (1 if d > 0 else -1)
    L, R = lut_bits, recip_bits
    dm = abs(d)
    p = dm.bit_length() - 1
    idx = _shift_floor(dm, L - p) - (1 << L)
    y0 = lut[idx]
    m_r = _shift_floor(dm, R - p)
    t = (m_r * y0) >> R
    e = (1 << (R + 1)) - t
    y1 = (y0 * e) >> R
    return sign * abs(n) * y1, fn - fd + p + R


def _shift_floor(x: int, s: int) -> int:
    """``floor(x * 2**s)`` for an integer ``x``."""
    return x << s if s >= 0 else x >> -s


def divide_restoring(n: int, fn: int, d: int, fd: int, fmt: FixedFormat) -> tuple[int, bool]:
    """Restoring divider ``divide(N, D, S)``: (raw code of S, overflow)."""
    if d == 0:
        return (0, False) if n == 0 else (_div_zero((n > 0) - (n < 0), fmt), True)
    return cast_exact(*_restoring_value(n, fn, d, fd, fmt), fmt)


def divide_reciprocal(
    n: int, fn: int, d: int, fd: int, fmt: FixedFormat, lut_bits: int = 8, recip_bits: int = 20
) -> tuple[int, bool]:
    """Reciprocal (LUT + Newton) divider ``divide(N, D, S)``: (raw code of S, overflow)."""
    if d == 0:
        return (0, False) if n == 0 else (_div_zero((n > 0) - (n < 0), fmt), True)
    lut = _recip_lut(lut_bits, recip_bits)
    return cast_exact(*_reciprocal_value(n, fn, d, fd, lut, lut_bits, recip_bits), fmt)


# ---------------------------------------------------------------------------------------
# the datapath
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


@dataclass
class _Sig:
    """A cast signal: raw code and its exact value."""

    raw: int
    v: APyFixed


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


class _Ctx(SignalLog):
    def __init__(self, config: P1Config) -> None:
        super().__init__(config)
        self._lut = None
        if config.divider == "reciprocal":
            self._lut = _recip_lut(config.recip_lut_bits, config.recip_bits)

    def fmt(self, name: str) -> FixedFormat:
        return self.config.fmt(name)

    def _log(self, name: str, n: int, f: int) -> None:
        self.log(name, _fraction(n, f))

    def cast_nf(self, n: int, f: int, name: str, *, log: bool = True) -> _Sig:
        fmt = self.fmt(name)
        if log:
            self._log(name, n, f)
        raw, acted = cast_exact(n, f, fmt)
        self.overflows[name] += acted
        return _Sig(raw, _value(raw, fmt))

    def cast(self, v: APyFixed | int, name: str) -> _Sig:
        """``cast(v, S)`` of the exact value ``v``: logs min/max, counts overflows."""
        n, f = (v, 0) if isinstance(v, int) else _exact(v)
        return self.cast_nf(n, f, name)

    def reg(self, x: float, name: str) -> _Sig:
        """``reg(x, S)``: not logged, not counted."""
        # DEFINITION: reg() is not a cast, so it neither logs min/max nor counts overflows
        # (the brief: "register quantisation is not counted"); xp/yp are cast per pixel.
        fmt = self.fmt(name)
        raw = reg_raw(x, fmt)
        return _Sig(raw, _value(raw, fmt))

    def divide(self, num: _Sig, fn: int, den: _Sig, fd: int, name: str) -> tuple[_Sig, bool]:
        """``divide(N, D, S)``; returns the quotient and whether the divider overflowed."""
        fmt = self.fmt(name)
        n, d = num.raw, den.raw
        if d == 0:
            # D = 0 is not a cast: no min/max is logged; 0 / 0 gives 0 and no overflow,
            # N / 0 counts one overflow of S and makes the pixel invalid.
            if n == 0:
                return _Sig(0, _value(0, fmt)), False
            raw = _div_zero((n > 0) - (n < 0), fmt)
            self.overflows[name] += 1
            return _Sig(raw, _value(raw, fmt)), True
        if self.config.divider == "restoring":
            m, f = _restoring_value(n, fn, d, fd, fmt)
        else:
            cfg = self.config
            m, f = _reciprocal_value(n, fn, d, fd, self._lut, cfg.recip_lut_bits, cfg.recip_bits)
        # logged: fl(fl(N) / fl(D)) 2**(F_D - F_N); the final cast logs nothing more
        self.log(name, Fraction(math.ldexp(float(n) / float(d), fd - fn)))
        before = self.overflows[name]
        sig = self.cast_nf(m, f, name, log=False)
        return sig, self.overflows[name] != before


_HALF = APyFixed(1, bits=2, frac_bits=1)
_ONE = APyFixed(1, bits=2, frac_bits=0)


def _stream(image: np.ndarray, ctx: _Ctx, C: _Sig, B: _Sig) -> dict[str, np.ndarray]:
    """Bias → row filter → column filter(s) → x-derivative of one stream, in scan order."""
    cfg = ctx.config
    consistent = cfg.variant == "consistent"
    first = cfg.init == "first"
    m, n = image.shape
    taps = {k: np.zeros((m, n), dtype=np.int64) for k in FRONTEND_TAPS}
    if not consistent:
        del taps["col2_state"]
    lb1: list[_Sig | None] = [None] * n
    lb2: list[_Sig | None] = [None] * n
    zero = {name: _Sig(0, _value(0, ctx.fmt(name))) for name in ("row_state", "col_state")}
    zero["col2_state"] = _Sig(0, _value(0, ctx.fmt("col2_state")))
    k = cfg.pole_shift

    def pole_times(diff: APyFixed) -> APyFixed:
        """C * diff: a product with the pole register, or in the ``shift`` filter form a
        move of the binary point by k (the hardware's wiring, C = 2^-k)."""
        return C.v * diff if k is None else diff >> k

    for j in range(m):
        p = None
        for i in range(n):
            x = ctx.cast(int(image[j, i]), "pix_in")
            b = ctx.cast(x.v + B.v, "bias_in")
            # row filter
            if i == 0:
                p = ctx.cast(b.v, "row_state") if first else zero["row_state"]
            prod = pole_times(b.v - p.v)
            r2 = ctx.cast(prod, "row_r2")
            p_next = ctx.cast(p.v + prod, "row_state")
            if consistent:
                r1 = ctx.cast((p.v + p_next.v) * _HALF, "row_r1")
            else:
                r1 = ctx.cast(p.v, "row_r1")
            p = p_next
            # column filter on r1 (line buffer LB1, read before write)
            if j == 0:
                lb1[i] = ctx.cast(r1.v, "col_state") if first else zero["col_state"]
            q = lb1[i]
            cprod = pole_times(r1.v - q.v)
            s2 = ctx.cast(cprod, "col_s2")
            q_next = ctx.cast(q.v + cprod, "col_state")
            if consistent:
                s1 = ctx.cast((q.v + q_next.v) * _HALF, "col_s1")
            else:
                s1 = ctx.cast(q.v, "col_s1")
            lb1[i] = q_next
            # x-derivative
            if consistent:
                if j == 0:
                    lb2[i] = ctx.cast(r2.v, "col2_state") if first else zero["col2_state"]
                q2 = lb2[i]
                q2_next = ctx.cast(q2.v + pole_times(r2.v - q2.v), "col2_state")
                ex = ctx.cast((q2.v + q2_next.v) * _HALF, "col2_out")
                lb2[i] = q2_next
                taps["col2_state"][j, i] = q2_next.raw
            else:
                fn = ctx.fmt("col_s1").frac + ctx.fmt("row_r2").frac
                fd = ctx.fmt("row_r1").frac
                ex, _ = ctx.divide(_Sig(s1.raw * r2.raw, None), fn, r1, fd, "div_quot")
            for key, sig in (
                ("bias_in", b),
                ("row_r1", r1),
                ("row_r2", r2),
                ("row_state", p_next),
                ("col_s1", s1),
                ("col_s2", s2),
                ("col_state", q_next),
                ("ex", ex),
            ):
                taps[key][j, i] = sig.raw
    return taps


def _range_stage(
    t1: dict[str, np.ndarray],
    t2: dict[str, np.ndarray],
    ctx: _Ctx,
    camera: PinholeCamera,
    motion: MotionIncrement,
    ranging: RangingConfig,
) -> dict[str, np.ndarray]:
    """Eq 28 per pixel in scan order, thresholds, range + valid."""
    cfg = ctx.config
    m, n = t1["col_s1"].shape
    f_px = float(camera.f_px)
    cx, cy = camera.principal_point
    R, k345 = k_matrix(motion)
    CX, CY = ctx.reg(cx, "coord"), ctx.reg(cy, "coord")
    Fr = ctx.reg(f_px, "f_reg")
    K3, K4, K5 = (ctx.reg(float(k), "k_t_reg") for k in k345)
    M = [
        [
            ctx.reg(float(R[i, 0]), "k_m_reg"),
            ctx.reg(float(R[i, 1]) / f_px, "k_m_reg"),
            ctx.reg(float(R[i, 2]) / f_px, "k_m_reg"),
        ]
        for i in range(3)
    ]
    TE = ctx.reg(ranging.threshold_e, "c1")
    TG2 = ctx.reg(float(ranging.threshold_g) ** 2, "tg2_reg")
    DMIN = ctx.reg(ranging.min_denominator, "den")
    RMAX = ctx.reg(ranging.range_max, "range")

    ex_name = "col2_out" if cfg.variant == "consistent" else "div_quot"
    s1f, s2f, exf = ctx.fmt("col_s1"), ctx.fmt("col_s2"), ctx.fmt(ex_name)
    out = {k: np.zeros((m, n), dtype=np.int64) for k in RANGE_TAPS}
    for j in range(m):
        for i in range(n):
            e1 = _value(int(t1["col_s1"][j, i]), s1f)
            e2 = _value(int(t2["col_s1"][j, i]), s1f)
            ex1 = _value(int(t1["ex"][j, i]), exf)
            ex2 = _value(int(t2["ex"][j, i]), exf)
            ey1 = _value(int(t1["col_s2"][j, i]), s2f)
            ey2 = _value(int(t2["col_s2"][j, i]), s2f)
            # 1. coordinates from the pixel counters (i = column, j = row)
            xp = ctx.cast(_apy(i, 0) - CX.v, "coord")
            yp = ctx.cast(_apy(j, 0) - CY.v, "coord")
            # 2. intensity difference and mean gradients
            c1 = ctx.cast(e1 - e2, "c1")
            a1 = ctx.cast((ex1 + ex2) * _HALF, "grad_a")
            b1 = ctx.cast((ey1 + ey2) * _HALF, "grad_b")
            # 3. rotation terms
            k = [
                ctx.cast(M[r][0].v + M[r][1].v * xp.v + M[r][2].v * yp.v, "k_rot") for r in range(3)
            ]
            # 4. geometry
            vx = ctx.cast(Fr.v * K4.v - xp.v * K3.v, "geom_v")
            vy = ctx.cast(Fr.v * K5.v - yp.v * K3.v, "geom_v")
            wx = ctx.cast(Fr.v * k[1].v - xp.v * k[0].v, "geom_w")
            wy = ctx.cast(Fr.v * k[2].v - yp.v * k[0].v, "geom_w")
            w0 = ctx.cast(_ONE + k[0].v, "geom_w")
            # 5. numerator and denominator of eq 28
            gv = ctx.cast(a1.v * vx.v + b1.v * vy.v, "gv")
            num = ctx.cast(K3.v * c1.v - gv.v, "num")
            den = ctx.cast(a1.v * wx.v + b1.v * wy.v - c1.v * w0.v, "den")
            # 6. range divider
            den_ok = abs(den.raw) >= DMIN.raw and den.raw != 0
            num_d = num if den_ok else _Sig(0, None)
            den_d = den if den_ok else _Sig(1 << ctx.fmt("den").frac, None)
            rq, div_ovf = ctx.divide(
                num_d, ctx.fmt("num").frac, den_d, ctx.fmt("den").frac, "range"
            )
            # 7. gradient test
            v_sq = ctx.cast(vx.v * vx.v + vy.v * vy.v, "v_sq")
            g_sq = ctx.cast(gv.v * gv.v, "grad_sq")
            g_thr = ctx.cast(TG2.v * v_sq.v, "grad_sq")
            # 8. validity (raw comparisons within one format)
            valid = (
                abs(c1.raw) >= TE.raw
                and g_sq.raw >= g_thr.raw
                and den_ok
                and not div_ovf
                and 0 < rq.raw <= RMAX.raw
            )
            values = {
                "xp": xp.raw,
                "yp": yp.raw,
                "c1": c1.raw,
                "a1": a1.raw,
                "b1": b1.raw,
                "k0": k[0].raw,
                "k1": k[1].raw,
                "k2": k[2].raw,
                "vx": vx.raw,
                "vy": vy.raw,
                "wx": wx.raw,
                "wy": wy.raw,
                "w0": w0.raw,
                "gv": gv.raw,
                "num": num.raw,
                "den": den.raw,
                "range_q": rq.raw,
                "v_sq": v_sq.raw,
                "g_sq": g_sq.raw,
                "g_thr": g_thr.raw,
                "valid": int(valid),
                "range": rq.raw if valid else RMAX.raw,
            }
            for key, val in values.items():
                out[key][j, i] = val
    return out


def oracle_p1(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: P1Config,
    ranging: RangingConfig,
    *,
    mode: str = "stereo",
) -> OracleResult:
    """Run the P1 datapath of ``docs/p1_datapath.md`` on a small image pair.

    ``image1``/``image2`` are E1/E2 (stereo: left/right; motion: previous/current frame,
    the previous frame's stream outputs coming from the frame store — the same values).
    """
    if mode not in ("stereo", "motion"):
        raise ValueError(f"mode must be 'stereo' or 'motion', not {mode!r}")
    im1, im2 = np.asarray(image1), np.asarray(image2)
    if im1.ndim != 2 or im1.shape != im2.shape:
        raise ValueError(f"need two 2-D images of one shape, got {im1.shape} and {im2.shape}")
    if im1.dtype.kind not in "iu" or im2.dtype.kind not in "iu":
        raise ValueError("images must hold integer grey levels")
    if im1.shape != (camera.height, camera.width):
        raise ValueError(f"images are {im1.shape}, camera is {camera.height}x{camera.width}")
    ctx = _Ctx(config)
    C = ctx.reg(config.pole, "pole_coef")
    B = ctx.reg(config.bias, "bias_reg")
    t1 = _stream(im1, ctx, C, B)
    t2 = _stream(im2, ctx, C, B)
    taps = {f"e1.{k}": v for k, v in t1.items()}
    taps.update({f"e2.{k}": v for k, v in t2.items()})
    taps.update(_range_stage(t1, t2, ctx, camera, motion, ranging))
    return ctx.result(taps)
