"""Independent, deliberately slow test oracle of the P1 datapath (issue 4, deliverable 6).

Written from ``docs/p1_datapath.md`` only: it shares nothing with the numba kernels of
``rangefx.rtl_model`` but the word-length config (formats, modes and design fields) and
the pipeline's public tap names (``FRONTEND_TAPS``, ``RANGE_TAPS``: the interface the
bit-exact test compares by; a tap the oracle does not compute is compared as zeros).
Signal values are :class:`apytypes.APyFixed` (exact arithmetic, growing word length); the
casts and dividers are ``oracle_exact.py``'s.

Everything runs as Python loops over the pixels in scan order; use small images only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from apytypes import APyFixed
from oracle_exact import (
    OracleResult,
    SignalLog,
    apy_value,
    cast_exact,
    divide_by_zero_code,
    exact_parts,
    fmt_value,
    fraction_of,
    reciprocal_lut,
    reciprocal_value,
    reg_raw,
    restoring_value,
)

from rangefx.golden.geometry import MotionIncrement, PinholeCamera, k_matrix
from rangefx.golden.ranging import RangingConfig
from rangefx.rtl_model.fixedpoint import FixedFormat
from rangefx.rtl_model.p1 import FRONTEND_TAPS, RANGE_TAPS
from rangefx.rtl_model.p1.config import P1Config

__all__ = ["oracle_p1"]


# ---------------------------------------------------------------------------------------
# the datapath
# ---------------------------------------------------------------------------------------
@dataclass
class _Sig:
    """A cast signal: raw code and its exact value."""

    raw: int
    v: APyFixed


class _Ctx(SignalLog):
    def __init__(self, config: P1Config) -> None:
        super().__init__(config)
        self._lut = None
        if config.divider == "reciprocal":
            self._lut = reciprocal_lut(config.recip_lut_bits, config.recip_bits)

    def fmt(self, name: str) -> FixedFormat:
        return self.config.fmt(name)

    def _log(self, name: str, n: int, f: int) -> None:
        self.log(name, fraction_of(n, f))

    def cast_nf(self, n: int, f: int, name: str, *, log: bool = True) -> _Sig:
        fmt = self.fmt(name)
        if log:
            self._log(name, n, f)
        raw, acted = cast_exact(n, f, fmt)
        self.overflows[name] += acted
        return _Sig(raw, fmt_value(raw, fmt))

    def cast(self, v: APyFixed | int, name: str) -> _Sig:
        """``cast(v, S)`` of the exact value ``v``: logs min/max, counts overflows."""
        n, f = (v, 0) if isinstance(v, int) else exact_parts(v)
        return self.cast_nf(n, f, name)

    def reg(self, x: float, name: str) -> _Sig:
        """``reg(x, S)``: not logged, not counted."""
        # DEFINITION: reg() is not a cast, so it neither logs min/max nor counts overflows
        # (the brief: "register quantisation is not counted"); xp/yp are cast per pixel.
        fmt = self.fmt(name)
        raw = reg_raw(x, fmt)
        return _Sig(raw, fmt_value(raw, fmt))

    def divide(self, num: _Sig, fn: int, den: _Sig, fd: int, name: str) -> tuple[_Sig, bool]:
        """``divide(N, D, S)``; returns the quotient and whether the divider overflowed."""
        fmt = self.fmt(name)
        n, d = num.raw, den.raw
        if d == 0:
            # D = 0 is not a cast: no min/max is logged; 0 / 0 gives 0 and no overflow,
            # N / 0 counts one overflow of S and makes the pixel invalid.
            if n == 0:
                return _Sig(0, fmt_value(0, fmt)), False
            raw = divide_by_zero_code((n > 0) - (n < 0), fmt)
            self.overflows[name] += 1
            return _Sig(raw, fmt_value(raw, fmt)), True
        if self.config.divider == "restoring":
            m, f = restoring_value(n, fn, d, fd, fmt)
        else:
            cfg = self.config
            m, f = reciprocal_value(n, fn, d, fd, self._lut, cfg.recip_lut_bits, cfg.recip_bits)
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
    zero = {name: _Sig(0, fmt_value(0, ctx.fmt(name))) for name in ("row_state", "col_state")}
    zero["col2_state"] = _Sig(0, fmt_value(0, ctx.fmt("col2_state")))
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
            e1 = fmt_value(int(t1["col_s1"][j, i]), s1f)
            e2 = fmt_value(int(t2["col_s1"][j, i]), s1f)
            ex1 = fmt_value(int(t1["ex"][j, i]), exf)
            ex2 = fmt_value(int(t2["ex"][j, i]), exf)
            ey1 = fmt_value(int(t1["col_s2"][j, i]), s2f)
            ey2 = fmt_value(int(t2["col_s2"][j, i]), s2f)
            # 1. coordinates from the pixel counters (i = column, j = row)
            xp = ctx.cast(apy_value(i, 0) - CX.v, "coord")
            yp = ctx.cast(apy_value(j, 0) - CY.v, "coord")
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
