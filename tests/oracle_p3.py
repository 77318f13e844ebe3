"""Independent, deliberately slow test oracle of the P3 datapath (issue 16).

Written from ``docs/multiscale.md`` ("P3: the fixed-point datapath") only: it shares
nothing with the numba kernels of ``rangefx.rtl_model.p3`` but the word-length config
(:class:`P3Config`) and G6's settings and window (:mod:`rangefx.golden.multiscale`).
Every signal is an exact :class:`fractions.Fraction` (the page's sums written directly:
the reduce as one 5x5 sum, the expand as the bilinear formula, the warp from the
fraction ``x - u``, the normalisation as the box sum at every level); every cast goes
through the apytypes-based :func:`oracle_p1.cast_exact`, the dividers are the P1
oracle's bit-level restoring loop or LUT + Newton reciprocal, the Keys ROM is built
from the exact cubic; the vertical term (``vertical``) as the page's 2x2 normal
equations, the determinant and the two numerators written out; its box form
(``vertical_radius`` rv > 0) as the page's box sums over the whole ``(2 rv + 1)²`` box at
once, ``v`` by the divider, taken from the line ``rv`` up, and the 1-D fit on ``e + gy v``.
Python loops per pixel: tiny images only.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from oracle_exact import (
    OracleResult,
    SignalLog,
    cast_exact,
    reciprocal_lut,
    reciprocal_value,
    reg_raw,
    restoring_value,
)

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.multiscale import pyramid_levels
from rangefx.golden.ranging import RangingConfig
from rangefx.rtl_model.p3.config import P3Config

__all__ = ["oracle_p3"]

_BINOM = (1, 4, 6, 4, 1)
_WARP_TAPS = ("warp", "wx", "g", "err", "rgg", "rge", "ree", "sgg", "sge", "see", "du", "u")
_VERTICAL_TAPS = ("wy", "gy", "ryy", "rgy", "rye", "syy", "sgy", "sye", "det", "nu")
_BOX_TAPS = ("wy", "gy", "bgg", "bge", "byy", "bgy", "bye", "bdet", "bnv", "v", "ev")


def _scale(f: int) -> Fraction:
    """``2**-f`` exactly, for fraction bits of either sign (``u1.-15`` formats)."""
    return Fraction(1, 1 << f) if f >= 0 else Fraction(1 << -f)


def _dyadic(x: Fraction) -> tuple[int, int]:
    """``(n, f)`` with ``x = n 2**-f`` (``x`` has a power-of-two denominator)."""
    f = x.denominator.bit_length() - 1
    assert x.denominator == 1 << f, x
    return x.numerator, f


def _keys(t: Fraction) -> tuple[Fraction, ...]:
    """Keys cubic, a = -1/2: weights of the taps at -1, 0, 1, 2 for fraction ``t``."""
    a = Fraction(-1, 2)
    return (
        a * (t**3 - 2 * t**2 + t),
        (a + 2) * t**3 - (a + 3) * t**2 + 1,
        -(a + 2) * t**3 + (2 * a + 3) * t**2 - a * t,
        -a * (t**3 - t**2),
    )


class _Ctx(SignalLog):
    def __init__(self, config: P3Config) -> None:
        super().__init__(config)
        self.lut = reciprocal_lut(config.recip_lut_bits, config.recip_bits)

    def val(self, raw: int, name: str) -> Fraction:
        return raw * _scale(self.config.fmt(name).frac)

    def cast(self, x: Fraction, name: str) -> int:
        """``cast(x, S)``: raw code; logs the exact value, counts an overflow."""
        self.log(name, x)
        raw, acted = cast_exact(*_dyadic(x), self.config.fmt(name))
        self.overflows[name] += acted
        return raw

    def divide(self, n: int, fn: int, d: int, fd: int, name: str) -> tuple[int, bool]:
        """``divide(N, D, S)`` of raw codes (``d != 0``): (raw quotient, overflowed)."""
        cfg, fmt = self.config, self.config.fmt(name)
        self.log(name, Fraction(math.ldexp(float(n) / float(d), fd - fn)))
        if cfg.divider == "restoring":
            q, f = restoring_value(n, fn, d, fd, fmt)
        else:
            q, f = reciprocal_value(n, fn, d, fd, self.lut, cfg.recip_lut_bits, cfg.recip_bits)
        raw, acted = cast_exact(q, f, fmt)
        self.overflows[name] += acted
        return raw, acted


def _clip(k: int, n: int) -> int:
    return min(max(k, 0), n - 1)


def oracle_p3(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: P3Config,
    ranging: RangingConfig,
) -> OracleResult:
    """Run the P3 datapath of ``docs/multiscale.md`` on a small stereo pair."""
    ctx = _Ctx(config)
    fmt = config.fmt
    ms = config.multiscale().resolve(len(image1[0]))
    r, K, T = config.radius, config.warps, config.keys_bits
    f_u = fmt("p3_u").frac
    im = [np.asarray(image1).tolist(), np.asarray(image2).tolist()]
    m, n = len(im[0]), len(im[0][0])
    built = pyramid_levels(ms, (m, n))
    # registers (host, float64 -> register format; neither logged nor counted)
    baseline = float(motion.camera_displacement[1])
    win = [ctx.val(reg_raw(ms.window()[r + k], fmt("p3_win")), "p3_win") for k in range(r + 1)]
    tr2_max = (2 ** fmt("p3_tr2").word - 1) * 2.0 ** -fmt("p3_tr2").frac
    TR2 = ctx.val(reg_raw(min(config.threshold_r**2, tr2_max), fmt("p3_tr2")), "p3_tr2")
    TG2 = reg_raw(config.threshold_g**2, fmt("p3_sgg"))
    fb_value = float(camera.f_px * baseline)
    FB = reg_raw(fb_value, fmt("p3_fb"))
    UMAX = [reg_raw(ms.disparity_limit / 2**lv, fmt("p3_u")) for lv in range(built)]
    u_top = (1 << (fmt("p3_u").word - 1)) - 1
    UMIN = min(math.ceil(Fraction(fb_value) * 2**f_u / Fraction(ranging.range_max)), u_top)
    RMAX = reg_raw(ranging.range_max, fmt("p3_range"))
    rows = 1 << T
    # the ROM is datapath: each weight cast (logged, counted) once, when it is built
    ROM = [[ctx.val(ctx.cast(w, "p3_keys"), "p3_keys") for w in _keys(Fraction(i, rows))]
           for i in range(rows)]  # fmt: skip

    # the normalisation: N = E - c Σ_box E, c the register 1 / (2R + 1)^2
    R = config.normalise_radius
    NBOX = ctx.val(reg_raw(1 / (2 * R + 1) ** 2, fmt("p3_nbox")), "p3_nbox")
    taps: dict[str, np.ndarray] = {}

    # the pyramid (exact values of each level's codes)
    pyr: list[list[list[list[Fraction]]]] = [[], []]
    for s in (0, 1):
        level = [[ctx.val(ctx.cast(Fraction(int(v)), "p3_pix"), "p3_pix") for v in row]
                 for row in im[s]]  # fmt: skip
        pyr[s].append(level)
        for _ in range(built - 1):
            p = pyr[s][-1]
            pm, pn = len(p), len(p[0])
            child = []
            for yc in range((pm + 1) // 2):
                line = []
                for xc in range((pn + 1) // 2):
                    acc = Fraction(0)
                    for i in range(5):
                        pr = p[_clip(2 * yc + i - 2, pm)]
                        for j in range(5):
                            acc += _BINOM[i] * _BINOM[j] * pr[_clip(2 * xc + j - 2, pn)]
                    acc /= 256
                    line.append(ctx.val(ctx.cast(acc, "p3_pyr"), "p3_pyr"))
                child.append(line)
            pyr[s].append(child)
        if config.normalise == "local_mean":  # every level on its own
            for lv, level in enumerate(pyr[s]):
                h, w = len(level), len(level[0])
                box = [[sum(level[_clip(y + i, h)][_clip(x + j, w)]
                            for i in range(-R, R + 1) for j in range(-R, R + 1))
                        for x in range(w)] for y in range(h)]  # fmt: skip
                codes = [[ctx.cast(level[y][x] - NBOX * box[y][x], "p3_norm") for x in range(w)]
                         for y in range(h)]  # fmt: skip
                if lv == 0:
                    taps[f"e{s + 1}.norm"] = np.array(codes, dtype=np.int64)
                pyr[s][lv] = [[ctx.val(c, "p3_norm") for c in row] for row in codes]
        else:
            assert config.normalise == "none", config.normalise

    u: list[list[int]] = []  # raw codes of p3_u
    sums = None
    for lv in range(built - 1, -1, -1):
        a, b = pyr[0][lv], pyr[1][lv]
        h, w = len(a), len(a[0])
        if lv == built - 1:
            u = [[0] * w for _ in range(h)]
        else:  # expand: bilinear at (y/2, x/2), doubled
            uc = u
            mc, nc = len(uc), len(uc[0])
            up = []
            for y in range(h):
                line = []
                for x in range(w):
                    py, px = Fraction(y, 2), Fraction(x, 2)
                    y0, x0 = min(math.floor(py), mc - 1), min(math.floor(px), nc - 1)
                    y1, x1 = min(y0 + 1, mc - 1), min(x0 + 1, nc - 1)
                    ty, tx = py - y0, px - x0
                    v00, v01 = ctx.val(uc[y0][x0], "p3_u"), ctx.val(uc[y0][x1], "p3_u")
                    v10, v11 = ctx.val(uc[y1][x0], "p3_u"), ctx.val(uc[y1][x1], "p3_u")
                    bil = (1 - ty) * ((1 - tx) * v00 + tx * v01) + ty * ((1 - tx) * v10 + tx * v11)
                    line.append(ctx.cast(2 * bil, "p3_u"))
                up.append(line)
            lag = min(config.coarse_lag, h)
            u = [list(up[max(y - lag, 0)]) for y in range(h)]
        record = lv == 0
        ax = [[ctx.val(ctx.cast((a[y][_clip(x + 1, w)] - a[y][_clip(x - 1, w)]) / 2, "p3_grad"),
                       "p3_grad") for x in range(w)] for y in range(h)]  # fmt: skip
        grad_lsb = _scale(fmt("p3_grad").frac)
        if record:
            taps["ax"] = np.array([[int(v / grad_lsb) for v in row] for row in ax])
            taps["u_start"] = np.array(u)
        form = config.vertical_form
        vertical = form == "window"  # the 2x2 system in the window
        if form != "off":  # E1y: central difference down the columns
            ay = [[ctx.val(ctx.cast((a[_clip(y + 1, h)][x] - a[_clip(y - 1, h)][x]) / 2,
                                    "p3_grad"), "p3_grad") for x in range(w)]
                  for y in range(h)]  # fmt: skip
            if record:
                taps["ay"] = np.array([[int(v / grad_lsb) for v in row] for row in ay])
        for k in range(K):
            W, WX, G, E = [], [], [], []
            for y in range(h):
                wrow = []
                for x in range(w):
                    src = x - ctx.val(u[y][x], "p3_u")
                    if f_u > T:  # the position rounded to T fraction bits
                        src += Fraction(1, 2 * rows)
                    base = math.floor(src)
                    idx = math.floor((src - base) * rows)
                    acc = sum(ROM[idx][j] * b[y][_clip(base - 1 + j, w)] for j in range(4))
                    wrow.append(ctx.cast(acc, "p3_warp"))
                W.append(wrow)
            for y in range(h):
                wv = [ctx.val(c, "p3_warp") for c in W[y]]
                wx = [ctx.cast((wv[_clip(x + 1, w)] - wv[_clip(x - 1, w)]) / 2, "p3_grad")
                      for x in range(w)]  # fmt: skip
                WX.append(wx)
                G.append([ctx.cast((ax[y][x] + ctx.val(wx[x], "p3_grad")) / 2, "p3_g")
                          for x in range(w)])  # fmt: skip
                E.append([ctx.cast(a[y][x] - wv[x], "p3_e") for x in range(w)])
            gv = [[ctx.val(c, "p3_g") for c in row] for row in G]
            ev = [[ctx.val(c, "p3_e") for c in row] for row in E]
            out = {}
            products = {
                "gg": [[gv[y][x] * gv[y][x] for x in range(w)] for y in range(h)],
                "ge": [[gv[y][x] * ev[y][x] for x in range(w)] for y in range(h)],
                "ee": [[ev[y][x] * ev[y][x] for x in range(w)] for y in range(h)],
            }
            if form != "off":  # Wy, gy = (E1y + Wy) / 2
                wv = [[ctx.val(c, "p3_warp") for c in row] for row in W]
                WY = [[ctx.cast((wv[_clip(y + 1, h)][x] - wv[_clip(y - 1, h)][x]) / 2, "p3_grad")
                       for x in range(w)] for y in range(h)]  # fmt: skip
                GY = [[ctx.cast((ay[y][x] + ctx.val(WY[y][x], "p3_grad")) / 2, "p3_gy")
                       for x in range(w)] for y in range(h)]  # fmt: skip
                yv = [[ctx.val(c, "p3_gy") for c in row] for row in GY]
            box = {}
            if form == "box":  # v from the box's 2x2 system, rv lines late; e + gy v
                vr = config.vertical_radius
                bprod = {"gg": (gv, gv), "ge": (gv, ev), "yy": (yv, yv), "gy": (gv, yv),
                         "ye": (yv, ev)}  # fmt: skip
                B = {}
                for q, (p1, p2) in bprod.items():
                    box[f"b{q}"] = [[ctx.cast(sum(p1[_clip(y + i, h)][_clip(x + j, w)]
                                                  * p2[_clip(y + i, h)][_clip(x + j, w)]
                                                  for i in range(-vr, vr + 1)
                                                  for j in range(-vr, vr + 1)), f"p3_b{q}")
                                     for x in range(w)] for y in range(h)]  # fmt: skip
                    B[q] = [[ctx.val(c, f"p3_b{q}") for c in row] for row in box[f"b{q}"]]
                box["bdet"] = [[ctx.cast(B["gg"][y][x] * B["yy"][y][x] - B["gy"][y][x] ** 2,
                                         "p3_bdet") for x in range(w)]
                               for y in range(h)]  # fmt: skip
                box["bnv"] = [[ctx.cast(B["gg"][y][x] * B["ye"][y][x]
                                        - B["gy"][y][x] * B["ge"][y][x], "p3_bnv")
                               for x in range(w)] for y in range(h)]  # fmt: skip
                f_bnv, f_bdet = fmt("p3_bnv").frac, fmt("p3_bdet").frac
                V = []
                for y in range(h):
                    vrow = []
                    for x in range(w):
                        dd, nn = box["bdet"][y][x], box["bnv"][y][x]
                        num, den = (-nn, dd) if dd > 0 else (0, 1)
                        vrow.append(ctx.divide(num, f_bnv, den, f_bdet, "p3_v")[0])
                    V.append(vrow)
                box["v"] = V
                box["ev"] = [[ctx.cast(ev[y][x] + yv[y][x] * ctx.val(V[max(y - vr, 0)][x], "p3_v"),
                                       "p3_ev") for x in range(w)] for y in range(h)]  # fmt: skip
                evv = [[ctx.val(c, "p3_ev") for c in row] for row in box["ev"]]
                products["ge"] = [[gv[y][x] * evv[y][x] for x in range(w)] for y in range(h)]
                products["ee"] = [[evv[y][x] * evv[y][x] for x in range(w)] for y in range(h)]
            if vertical:  # the three more products of the window's 2x2 system
                products["yy"] = [[yv[y][x] * yv[y][x] for x in range(w)] for y in range(h)]
                products["gy"] = [[gv[y][x] * yv[y][x] for x in range(w)] for y in range(h)]
                products["ye"] = [[yv[y][x] * ev[y][x] for x in range(w)] for y in range(h)]
            for name, prod in products.items():
                row_sum = [[ctx.cast(sum(win[abs(j)] * prod[y][_clip(x + j, w)]
                                         for j in range(-r, r + 1)), f"p3_r{name}")
                            for x in range(w)] for y in range(h)]  # fmt: skip
                rv = [[ctx.val(c, f"p3_r{name}") for c in row] for row in row_sum]
                col_sum = [[ctx.cast(sum(win[abs(j)] * rv[_clip(y + j, h)][x]
                                         for j in range(-r, r + 1)), f"p3_s{name}")
                            for x in range(w)] for y in range(h)]  # fmt: skip
                out[f"r{name}"], out[f"s{name}"] = row_sum, col_sum
            DU = []
            f_sge, f_sgg, f_du = fmt("p3_sge").frac, fmt("p3_sgg").frac, fmt("p3_du").frac
            f_nu, f_det = fmt("p3_nu").frac, fmt("p3_det").frac
            if vertical:  # det and u's numerator of the 2x2 system, exact, then cast
                S = {q: [[ctx.val(c, f"p3_s{q}") for c in row] for row in out[f"s{q}"]]
                     for q in ("gg", "ge", "yy", "gy", "ye")}  # fmt: skip
                out["det"] = [[ctx.cast(S["gg"][y][x] * S["yy"][y][x] - S["gy"][y][x] ** 2,
                                        "p3_det") for x in range(w)] for y in range(h)]  # fmt: skip
                out["nu"] = [[ctx.cast(S["yy"][y][x] * S["ge"][y][x]
                                       - S["gy"][y][x] * S["ye"][y][x], "p3_nu")
                              for x in range(w)] for y in range(h)]  # fmt: skip
            for y in range(h):
                drow = []
                for x in range(w):
                    gg, ge = out["sgg"][y][x], out["sge"][y][x]
                    if vertical:
                        dd, nn = out["det"][y][x], out["nu"][y][x]
                        num, den = (-nn, dd) if dd > 0 else (0, 1)
                        q, _ = ctx.divide(num, f_nu, den, f_det, "p3_du")
                    else:
                        num, den = (-ge, gg) if gg > 0 else (0, 1)
                        q, _ = ctx.divide(num, f_sge, den, f_sgg, "p3_du")
                    drow.append(q)
                    un = ctx.cast(ctx.val(u[y][x], "p3_u") + q * _scale(f_du), "p3_u")
                    u[y][x] = min(max(un, 0), UMAX[lv])
                DU.append(drow)
            if record:
                arrays = {"warp": W, "wx": WX, "g": G, "err": E, **out, "du": DU, "u": u}
                if form == "box":  # the box's taps of line y: the box rv lines up
                    box = {k: [q[max(y - vr, 0)] for y in range(h)] if k != "ev" else q
                           for k, q in box.items()}  # fmt: skip
                if form != "off":
                    arrays.update(wy=WY, gy=GY, **box)
                more = {"off": (), "window": _VERTICAL_TAPS, "box": _BOX_TAPS}[form]
                for t in _WARP_TAPS + more:
                    taps[f"{t}{k}"] = np.array(arrays[t], dtype=np.int64)
            sums = out
    # level 0: residual and gradient tests, inside, range
    assert sums is not None
    vertical = config.vertical_form == "window"
    names = (
        ("nv", "res", "rthr", "valid", "range") if vertical else ("res", "rthr", "valid", "range")
    )
    final = {t: np.zeros((m, n), dtype=np.int64) for t in names}
    f_fb = fmt("p3_fb").frac
    for y in range(m):
        for x in range(n):
            gg, ge, ee = sums["sgg"][y][x], sums["sge"][y][x], sums["see"][y][x]
            sgg, sge, see = ctx.val(gg, "p3_sgg"), ctx.val(ge, "p3_sge"), ctx.val(ee, "p3_see")
            solved = True
            if vertical:  # the 2x2 fit's residual times det: Σe² det - Σge nu - Σye nv
                sgy, sye = (
                    ctx.val(sums["sgy"][y][x], "p3_sgy"),
                    ctx.val(sums["sye"][y][x], "p3_sye"),
                )
                det, nu = ctx.val(sums["det"][y][x], "p3_det"), ctx.val(sums["nu"][y][x], "p3_nu")
                nv = ctx.cast(sgg * sye - sgy * sge, "p3_nv")
                final["nv"][y, x] = nv
                res = ctx.cast(see * det - sge * nu - sye * ctx.val(nv, "p3_nv"), "p3_res")
                rthr = ctx.cast(TR2 * det, "p3_res")
                solved = det > 0
            else:
                res = ctx.cast(see * sgg - sge * sge, "p3_res")
                rthr = ctx.cast(TR2 * sgg, "p3_res")
            uu = u[y][x]
            src = x - ctx.val(uu, "p3_u")
            gate = uu > 0 and uu >= UMIN
            num, den = (FB, uu) if gate else (0, 1)
            z, flag = ctx.divide(num, f_fb, den, f_u, "p3_range")
            ok = (gg >= TG2 and res <= rthr and 0 <= src <= n - 1 and gate and uu <= UMAX[0]
                  and not flag and 0 < z <= RMAX and solved)  # fmt: skip
            final["res"][y, x], final["rthr"][y, x] = res, rthr
            final["valid"][y, x] = int(ok)
            final["range"][y, x] = z if ok else RMAX
    taps.update(final)
    return ctx.result(taps)
