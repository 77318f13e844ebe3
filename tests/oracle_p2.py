"""Independent, deliberately slow test oracle of the P2 datapath (issue 5).

Written from ``docs/p2_datapath.md`` only: it shares nothing with the numba kernels of
``rangefx.rtl_model.p2`` but the word-length config (:class:`P2Config`). Signal values
are :class:`apytypes.APyFixed` (exact arithmetic, growing word length); every cast goes
through the apytypes-based :func:`oracle_p1.cast_exact`, and the divider is the P1
oracle's bit-level restoring loop or LUT + Newton reciprocal. Registers are computed here
from the float64 settings by the rules of the page. Python loops per pixel: small
images only.
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
    fraction_of,
    reciprocal_lut,
    reciprocal_value,
    reg_raw,
    restoring_value,
)

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.riccati import RiccatiConfig
from rangefx.rtl_model.p2.config import P2Config
from rangefx.rtl_model.runtime import divider_latency

__all__ = ["TAPS", "oracle_p2", "oracle_p2_cycles"]

TAPS = (
    "d", "g_hat", "a", "c", "den", "r", "s", "h", "q", "w", "lam", "z", "e", "valid", "range",
)  # fmt: skip


@dataclass
class _Sig:
    raw: int
    v: APyFixed


class _Ctx(SignalLog):
    config: P2Config

    def sig(self, raw: int, name: str) -> _Sig:
        return _Sig(raw, apy_value(raw, self.config.fmt(name).frac))

    def cast(self, v: APyFixed | int, name: str, *, log: bool = True) -> _Sig:
        n, f = (v, 0) if isinstance(v, int) else exact_parts(v)
        if log:
            self.log(name, fraction_of(n, f))
        raw, acted = cast_exact(n, f, self.config.fmt(name))
        self.overflows[name] += acted
        return self.sig(raw, name)

    def reciprocal(self, den: _Sig) -> _Sig:
        """``r = divide(1, den, p2_r)`` with the configured P1 divider model."""
        cfg = self.config
        fmt, fd = cfg.fmt("p2_r"), cfg.fmt("p2_den").frac
        if den.raw == 0:  # not a cast: nothing logged, one overflow
            self.overflows["p2_r"] += 1
            return self.sig(divide_by_zero_code(1, fmt), "p2_r")
        self.log("p2_r", Fraction(math.ldexp(1.0 / float(den.raw), fd)))
        if cfg.divider == "restoring":
            m, f = restoring_value(1, 0, den.raw, fd, fmt)
        else:
            lut = reciprocal_lut(cfg.recip_lut_bits, cfg.recip_bits)
            m, f = reciprocal_value(1, 0, den.raw, fd, lut, cfg.recip_lut_bits, cfg.recip_bits)
        return self.cast(apy_value(m, f), "p2_r", log=False)


def oracle_p2(
    image1: np.ndarray,
    image2: np.ndarray,
    camera: PinholeCamera,
    motion: MotionIncrement,
    config: P2Config,
    riccati: RiccatiConfig,
) -> OracleResult:
    """Run the P2 datapath of ``docs/p2_datapath.md`` on a small stereo pair."""
    ctx = _Ctx(config)
    fmt = config.fmt
    # registers (host, float64 -> register format; neither logged nor counted)
    fwd, right, down = motion.camera_displacement
    assert right != 0 and fwd == 0 and down == 0
    dx = -float(right)  # camera 2 at +b: eq 8 with dx = -b (SPEC §9)
    ratio = riccati.alpha / riccati.beta
    KA = ctx.sig(reg_raw(1.0 / (camera.f_px * dx), fmt("p2_ka_reg")), "p2_ka_reg")
    M = ctx.sig(reg_raw(ratio, fmt("p2_m_reg")), "p2_m_reg")
    CMIN = ctx.sig(reg_raw(config.kappa_min / ratio, fmt("p2_c")), "p2_c")
    st = fmt("p2_st")
    gamma_t = riccati.gamma / (riccati.beta * riccati.pixel_pitch)
    S_END = ctx.sig(reg_raw(min(gamma_t, (2**st.word - 1) * 2.0**-st.frac), st), "p2_st")
    TD = math.ceil(Fraction(2) * Fraction(riccati.threshold_e) * Fraction(2) ** fmt("p2_d").frac)
    RMAX = ctx.sig(reg_raw(riccati.range_max, fmt("p2_z")), "p2_z")
    one = apy_value(1, 0)

    im1, im2 = np.asarray(image1), np.asarray(image2)
    m, n = im1.shape
    taps = {k: np.zeros((m, n), dtype=np.int64) for k in TAPS}
    for j in range(m):
        d: list[_Sig] = []
        g: list[_Sig] = []
        for i in range(n):  # input stage: line buffer
            x1 = ctx.cast(int(im1[j, i]), "p2_pix")
            x2 = ctx.cast(int(im2[j, i]), "p2_pix")
            d.append(ctx.cast(x1.v - x2.v, "p2_d"))
            g.append(ctx.cast(x1.v + x2.v, "p2_ghat"))
        # backward sweep
        s1, q1 = S_END, ctx.sig(0, "p2_q")
        step: dict[int, tuple[_Sig, _Sig, _Sig, _Sig]] = {}
        taps["s"][j, n - 1] = s1.raw
        for k in range(n - 2, -1, -1):
            dsum = d[k].v + d[k + 1].v
            dg = g[k + 1].v - g[k].v
            a = ctx.cast(KA.v * dsum, "p2_a")
            c = ctx.cast(a.v * a.v, "p2_c")
            if c.raw < CMIN.raw:  # the floor on c (kappa_min)
                c = CMIN
            den = ctx.cast(one + c.v * s1.v, "p2_den")
            r = ctx.reciprocal(den)
            s0 = ctx.cast(M.v + r.v * s1.v, "p2_st")
            h = ctx.cast(q1.v - s1.v * dg, "p2_h")
            q0 = ctx.cast(r.v * h.v, "p2_q")
            step[k] = (a, r, s1, q1)
            for key, sg in (("a", a), ("c", c), ("den", den), ("r", r), ("s", s0), ("h", h),
                            ("q", q0)):  # fmt: skip
                taps[key][j, k] = sg.raw
            s1, q1 = s0, q0
        # forward pass
        e = ctx.sig(0, "p2_e")
        for k in range(n - 1):
            a, r, sk1, qk1 = step[k]
            u = e.v - (g[k + 1].v - g[k].v)
            w = ctx.cast(sk1.v * u + qk1.v, "p2_w")
            lam = ctx.cast(r.v * w.v, "p2_lam")
            z = ctx.cast(-(a.v * lam.v), "p2_z")
            e = ctx.cast(u + a.v * z.v, "p2_e")
            ok = abs(d[k].raw + d[k + 1].raw) >= TD and 0 < z.raw <= RMAX.raw
            taps["w"][j, k], taps["lam"][j, k], taps["z"][j, k] = w.raw, lam.raw, z.raw
            taps["e"][j, k + 1] = e.raw
            taps["valid"][j, k] = int(ok)
            taps["range"][j, k] = z.raw if ok else RMAX.raw
        taps["range"][j, n - 1] = RMAX.raw
        for i in range(n):
            taps["d"][j, i], taps["g_hat"][j, i] = d[i].raw, g[i].raw
    return ctx.result(taps)


def oracle_p2_cycles(in_cycles: np.ndarray, config: P2Config) -> dict[str, np.ndarray]:
    """The cycle of every sample of every tap, restated from docs/p2_datapath.md
    ("Hardware") unit by unit: the input stage, the sweep engine's slots (line-buffer read,
    A, c, then the loop: den, the divider, S~ and Q~ written back), the forward engine's
    slots (sweep-buffer read, e operand, w, λ/β, z, threshold, output register) and the
    controllers that start each group's sweep and forward pass. The one sweep buffer holds
    entry (lane, column k) of an even group at word lane n + k, of an odd one at lane n +
    n - 1 - k; a write there lands a clock edge after a read of the same word issued in
    the same cycle (both addresses registered once), so each write comes at least one
    cycle after the previous group's forward read of its word. Raises ``ValueError`` where
    a group's input would overwrite a line buffer its sweep still reads, or a forward read
    would come before its entry is written."""
    m, n = in_cycles.shape
    # P2's divider: the reciprocal one pipelined (PIPE = 2: + 14, its products' operands
    # in the DSPs' input registers and the cast's rounded value registered), reduced to
    # 1/den (UNIT = 1: - 6), den registered again and the normalising shift in two stages
    # (NORM = 1: + 2), docs/p2_datapath.md "Timing"; the restoring one as declared
    t_div = divider_latency(config.divider, config.fmt("p2_r").word)
    t_div += 14 - 6 + 2 if config.divider == "reciprocal" else 0
    mul = 4  # hdl/fx_pipe.v fx_mul_pipe IREG = 1: operands in the DSP, products, pairs, sum
    ram = 5  # a block RAM read: address, the blocks' reads, registered, ORed in fours, all
    # backward loop: operand register, c S~ (mul), + 1, cast den; the divider; r
    # registered; r S~ (mul), + M, cast S~ registered, into the lane's state
    t_b = 1 + mul + 1 + 1 + t_div + 1 + mul + 1 + 1 + 1
    # forward loop: u; S~ u (mul), + Q~, cast w; r w (mul), its rounded value registered,
    # cast lam; (-a) lam (mul), rounded, cast z; a z (mul), + u, cast e registered into
    # the lane's state; the e operand register
    t_f = 1 + mul + 1 + 1 + mul + 1 + 1 + mul + 1 + 1 + mul + 1 + 1 + 1 + 1
    entry = ram + 1 + mul + 1 + mul + 1 + 1  # read, D, KA D, cast a, a^2, cast, max C_MIN
    w_at = ram + 1 + mul + 1 + 1  # after a forward slot's read: u, S~ u, + Q~, cast
    lam_at, z_at = w_at + mul + 2, w_at + 2 * (mul + 2)  # each: rounded, then cast
    out_at = z_at + 1 + 1  # threshold compare, output register
    lanes = config.lanes or max(t_b, t_f)
    p_b, p_f = max(lanes, t_b), max(lanes, t_f)  # periods per column: one slot per lane
    sweep_len, fwd_len = n * p_b, n * p_f  # n slots per lane (the first loads S~_end)
    out = {k: np.zeros((m, n), dtype=np.int64) for k in ("pix_in", *TAPS)}
    sweep_end = fwd_end = -(10**18)  # the engines are free from these cycles on
    last_reads: list[int] = []  # per group: its sweep's last line-buffer read
    read_at: dict[int, int] = {}  # sweep-buffer word -> the last group's forward read of it

    def word(lane: int, k: int, g: int) -> int:
        return lane * n + (k if g % 2 == 0 else n - 1 - k)

    for g in range(-(-m // lanes)):
        lines = range(g * lanes, min(m, (g + 1) * lanes))
        # the line buffer bank of group g is that of group g - 2: its sweep must be done
        if g >= 2 and int(in_cycles[lines[0], 0]) + 2 <= last_reads[g - 2]:
            raise ValueError(f"group {g} overwrites the line buffer of group {g - 2}")
        d_written = int(in_cycles[lines[-1], n - 1]) + 2  # cast, then the d/Ĝ adders
        sweep = max(d_written + 1, sweep_end)  # the read after the last write
        # each sweep-buffer write (lane, column k <= n - 2, at the slot's write-back) one
        # cycle after the previous group's forward read of its word, if any
        delay = 0
        for lane in range(len(lines)):
            for k in range(n - 1):
                write = sweep + (n - 1 - k) * p_b + lane + entry + t_b
                if word(lane, k, g) in read_at:
                    delay = max(delay, read_at[word(lane, k, g)] + 1 - write)
        sweep += delay
        sweep_end = sweep + sweep_len
        fwd = max(sweep_end + t_b, fwd_end)
        fwd_end = fwd + fwd_len
        last_reads.append(sweep + (n - 1) * p_b + lanes - 1)  # lane L - 1, column 0
        for lane in range(len(lines)):
            for k in range(n):  # column n - 1's read is issued too (its output zeroed)
                read = fwd + k * p_f + lane
                if k < n - 1 and read <= sweep + (n - 1 - k) * p_b + lane + entry + t_b:
                    raise ValueError(f"group {g} reads column {k} before it is written")
                read_at[word(lane, k, g)] = read
        for lane, j in enumerate(lines):
            for i in range(n):
                out["pix_in"][j, i] = in_cycles[j, i]
                out["d"][j, i] = out["g_hat"][j, i] = in_cycles[j, i] + 2
                slot = sweep + (n - 1 - i) * p_b + lane  # column i's line-buffer read
                write_back = slot + entry + t_b  # to the loop entry, then the loop
                for k in ("a", "c", "den", "r", "s", "h", "q"):
                    out[k][j, i] = write_back
                read = fwd + i * p_f + lane  # column i's sweep-buffer read
                out["e"][j, i] = read + ram  # the e operand beside the RAM's output
                out["w"][j, i], out["lam"][j, i] = read + w_at, read + lam_at
                out["z"][j, i] = read + z_at
                out["valid"][j, i] = out["range"][j, i] = read + out_at
    return out
