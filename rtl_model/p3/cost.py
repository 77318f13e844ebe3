"""Hardware cost proxies of a P3 word-length config (SPEC §6, §12; docs/multiscale.md).

The same models as P1's and P2's (:mod:`rangefx.rtl_model.cost`).

Registers
    The normalisation (``normalise`` not ``"none"``): per stream and level the box's row
    and column sums and ``N`` (``p3_norm``), and the ``1/box`` register (``p3_nbox``). Per
    level (the levels run concurrently, one pixel per clock each): both streams'
    pyramid word (``p3_pix`` at level 0); per warp stage of each level: ``W``, ``Wx``,
    ``g``, ``e``, the three row passes' ``2 r + 1`` tap shift registers of their products
    and their sums, the three column sums, ``du``, ``u``; at level 0 ``ax`` once per
    level and the output stage (``res``, ``rthr``, ``range``); host registers: the
    ``r + 1`` window taps, ``T_g^2`` (a ``p3_sgg`` word), ``T_r^2``, ``fB``, ``u_max`` per
    level and ``u_min`` (``p3_u`` words), ``range_max`` (a ``p3_range`` word). The Keys ROM
    is counted as a memory (``2**keys_bits`` words of 4 weights). With ``vertical``: ``ay``
    once per level; per warp stage ``Wy``, ``gy``, the three more row passes' tap shift
    registers and sums, their column sums, ``det`` and ``nu``; ``nv`` at the output.
Buffers
    Every line buffer of the streaming schedule
    (:func:`~rangefx.rtl_model.p3.model.buffer_bits`): the normalisation's ``2 R`` lines
    per stream and level, the reduce's 4 lines per image, the E2 warp rows, the window's
    ``2 r`` lines of row sums and ``r`` lines of E1, E2 and ``u`` (the box form: its five
    exact row sums through ``2 rv`` lines,
    :func:`~rangefx.rtl_model.p3.model.box_row_bits`), the expand's coarse line, the
    coarse-to-fine delay lines (raw pixels, normalised as they leave). RAMB18: each
    buffer one memory of (lines x width) words.
DSP slices
    Per stream and level the normalisation's ``1/box`` times the box sum; per warp
    stage: the warp's 4 products, ``g^2``, ``g e``, ``e^2``, the window's ``r + 1``
    products per pass and product (the symmetric taps share one after a pre-add), the
    divider's; at level 0 ``Σe² Σg²``, ``(Σge)²``, ``T_r^2 Σg²`` and the
    range divider's. With ``vertical`` per warp stage ``gy²``, ``g gy``, ``gy e``, their
    row and column passes, two products each for ``det`` and ``nu``; at level 0 two
    for ``nv`` and ``Σe² det``, ``Σge nu``, ``Σye nv``, ``T_r^2 det`` in place of the
    1-D residual's three; the box form per warp stage ``gy²``, ``g gy``, ``gy e``
    (the box sums are adders), two products each for ``bdet`` and ``bnv``, ``gy v`` and
    the ``v`` divider's, and the 1-D residual's three at level 0.
"""

from __future__ import annotations

import math

from rangefx.golden.multiscale import streaming_schedule

from ..cost import CostReport, Multiplier, bram18_blocks, reciprocal_multipliers
from ..cost import operand_bits as _bits
from .config import P3Config
from .model import box_row_bits, buffer_bits, level_shapes

__all__ = ["config_cost", "multipliers", "register_bits"]


def _stages(config: P3Config, shape: tuple[int, int]) -> tuple[int, int]:
    """(levels built, warp stages in all levels) on ``shape`` images."""
    levels = len(level_shapes(config, shape))
    return levels, levels * config.warps


def _box_bits(config: P3Config) -> int:
    """Bits the box sum adds to a pixel: ``ceil(log2((2R + 1)²))``."""
    return math.ceil(math.log2((2 * config.normalise_radius + 1) ** 2))


def register_bits(config: P3Config, shape: tuple[int, int]) -> int:
    """Register bits of the datapath (see the module docstring)."""
    f = {k: v.word for k, v in config.formats.items()}
    levels, stages = _stages(config, shape)
    taps = 2 * config.radius + 1
    total = 2 * f["p3_pix"] + 2 * (levels - 1) * f["p3_pyr"] + levels * f["p3_grad"]
    if config.normalise != "none":  # per stream and level: row + column sums, N
        box = 2 * (f["p3_pyr"] + _box_bits(config)) + f["p3_norm"]
        total += 2 * levels * box + f["p3_nbox"]
    per_stage = f["p3_warp"] + f["p3_grad"] + f["p3_g"] + f["p3_e"] + f["p3_du"] + f["p3_u"]
    products = 2 * f["p3_g"] + f["p3_g"] + f["p3_e"] + 2 * f["p3_e"]
    per_stage += taps * products
    per_stage += sum(f[s] for s in ("p3_rgg", "p3_rge", "p3_ree", "p3_sgg", "p3_sge", "p3_see"))
    total += stages * per_stage
    if config.vertical_form == "box":  # ay; per stage Wy, gy, the box, bdet, bnv, v, ev
        total += levels * f["p3_grad"]
        vstage = f["p3_grad"] + f["p3_gy"] + f["p3_bdet"] + f["p3_bnv"] + f["p3_v"] + f["p3_ev"]
        vstage += sum(f[s] for s in ("p3_bgg", "p3_bge", "p3_byy", "p3_bgy", "p3_bye"))
        # the row pass's 2 rv + 1 tap shift registers of the five exact products
        prod = 2 * f["p3_g"] + f["p3_g"] + f["p3_e"] + 2 * f["p3_gy"] + f["p3_g"] + f["p3_gy"]
        vstage += (2 * config.vertical_radius + 1) * (prod + f["p3_gy"] + f["p3_e"])
        total += stages * vstage
    elif config.vertical:
        total += levels * f["p3_grad"] + f["p3_nv"]
        vstage = f["p3_grad"] + f["p3_gy"] + f["p3_det"] + f["p3_nu"]
        gy = f["p3_gy"]
        vstage += taps * (2 * gy + f["p3_g"] + gy + gy + f["p3_e"])
        vstage += sum(f[s] for s in ("p3_ryy", "p3_rgy", "p3_rye", "p3_syy", "p3_sgy", "p3_sye"))
        total += stages * vstage
    total += 2 * f["p3_res"] + f["p3_range"]
    total += (config.radius + 1) * f["p3_win"] + f["p3_sgg"] + f["p3_tr2"] + f["p3_fb"]
    total += (levels + 1) * f["p3_u"] + f["p3_range"]
    return total


def multipliers(config: P3Config, shape: tuple[int, int]) -> list[Multiplier]:
    """Every multiplier of the datapath with its operand widths."""
    f = config.formats
    _, stages = _stages(config, shape)
    pix = max(_bits(f["p3_pix"]), _bits(f["p3_pyr"]))
    if config.normalise != "none":
        pix = _bits(f["p3_norm"])
    g, e, win = _bits(f["p3_g"]), _bits(f["p3_e"]), _bits(f["p3_win"])
    taps = config.radius + 1
    muls = [
        Multiplier("warp: keys * E2", _bits(f["p3_keys"]), pix, 4 * stages),
        Multiplier("g^2", g, g, stages),
        Multiplier("g e", g, e, stages),
        Multiplier("e^2", e, e, stages),
        Multiplier("row pass: w * g^2", win, 2 * g + 1, taps * stages),
        Multiplier("row pass: w * g e", win, g + e + 1, taps * stages),
        Multiplier("row pass: w * e^2", win, 2 * e + 1, taps * stages),
        Multiplier("column pass: w * rgg", win, _bits(f["p3_rgg"]) + 1, taps * stages),
        Multiplier("column pass: w * rge", win, _bits(f["p3_rge"]) + 1, taps * stages),
        Multiplier("column pass: w * ree", win, _bits(f["p3_ree"]) + 1, taps * stages),
    ]
    b = {s: _bits(f[s]) for s in ("p3_sgg", "p3_sge", "p3_see", "p3_syy", "p3_sgy", "p3_sye",
                                  "p3_det", "p3_nu", "p3_nv", "p3_tr2")}  # fmt: skip
    if config.vertical_form == "box":
        gy, bx = _bits(f["p3_gy"]), {s: _bits(f[s]) for s in ("p3_bgg", "p3_bge", "p3_byy",
                                                               "p3_bgy", "p3_bye")}  # fmt: skip
        muls += [
            Multiplier("gy^2", gy, gy, stages),
            Multiplier("g gy", g, gy, stages),
            Multiplier("gy e", gy, e, stages),
            Multiplier("bdet: bgg * byy", bx["p3_bgg"], bx["p3_byy"], stages),
            Multiplier("bdet: bgy^2", bx["p3_bgy"], bx["p3_bgy"], stages),
            Multiplier("bnv: bgg * bye", bx["p3_bgg"], bx["p3_bye"], stages),
            Multiplier("bnv: bgy * bge", bx["p3_bgy"], bx["p3_bge"], stages),
            Multiplier("ev: gy * v", gy, _bits(f["p3_v"]), stages),
            Multiplier("res: see * sgg", b["p3_see"], b["p3_sgg"]),
            Multiplier("res: sge^2", b["p3_sge"], b["p3_sge"]),
            Multiplier("rthr: T_r^2 * sgg", b["p3_tr2"], b["p3_sgg"]),
        ]
    elif config.vertical:
        gy = _bits(f["p3_gy"])
        muls += [
            Multiplier("gy^2", gy, gy, stages),
            Multiplier("g gy", g, gy, stages),
            Multiplier("gy e", gy, e, stages),
            Multiplier("row pass: w * gy^2", win, 2 * gy + 1, taps * stages),
            Multiplier("row pass: w * g gy", win, g + gy + 1, taps * stages),
            Multiplier("row pass: w * gy e", win, gy + e + 1, taps * stages),
            Multiplier("column pass: w * ryy", win, _bits(f["p3_ryy"]) + 1, taps * stages),
            Multiplier("column pass: w * rgy", win, _bits(f["p3_rgy"]) + 1, taps * stages),
            Multiplier("column pass: w * rye", win, _bits(f["p3_rye"]) + 1, taps * stages),
            Multiplier("det: sgg * syy", b["p3_sgg"], b["p3_syy"], stages),
            Multiplier("det: sgy^2", b["p3_sgy"], b["p3_sgy"], stages),
            Multiplier("nu: syy * sge", b["p3_syy"], b["p3_sge"], stages),
            Multiplier("nu: sgy * sye", b["p3_sgy"], b["p3_sye"], stages),
            Multiplier("nv: sgg * sye", b["p3_sgg"], b["p3_sye"]),
            Multiplier("nv: sgy * sge", b["p3_sgy"], b["p3_sge"]),
            Multiplier("res: see * det", b["p3_see"], b["p3_det"]),
            Multiplier("res: sge * nu", b["p3_sge"], b["p3_nu"]),
            Multiplier("res: sye * nv", b["p3_sye"], b["p3_nv"]),
            Multiplier("rthr: T_r^2 * det", b["p3_tr2"], b["p3_det"]),
        ]
    else:
        muls += [
            Multiplier("res: see * sgg", b["p3_see"], b["p3_sgg"]),
            Multiplier("res: sge^2", b["p3_sge"], b["p3_sge"]),
            Multiplier("rthr: T_r^2 * sgg", b["p3_tr2"], b["p3_sgg"]),
        ]
    if config.normalise != "none":
        box = max(_bits(f["p3_pix"]), _bits(f["p3_pyr"])) + _box_bits(config)
        levels = len(level_shapes(config, shape))
        muls.append(Multiplier("normalise: 1/box * box sum", _bits(f["p3_nbox"]), box, 2 * levels))
    if config.divider == "reciprocal":
        num = b["p3_nu"] if config.vertical_form == "window" else b["p3_sge"]
        muls += reciprocal_multipliers(config.recip_bits, "divider du", num, stages)
        if config.vertical_form == "box":
            bnv = _bits(f["p3_bnv"])
            muls += reciprocal_multipliers(config.recip_bits, "divider v", bnv, stages)
        muls += reciprocal_multipliers(config.recip_bits, "divider range", _bits(f["p3_fb"]), 1)
    return muls


def config_cost(config: P3Config, shape: tuple[int, int], mode: str = "stereo") -> CostReport:
    """Cost proxies of ``config`` on ``shape`` = (height, width) stereo images."""
    if mode != "stereo":
        raise ValueError(f"P3 models stereo mode only, not {mode!r}")
    m, n = shape
    f = config.formats
    sched = streaming_schedule(config.multiscale(), n, m)
    u = f["p3_u"].word
    rows = f["p3_rgg"].word + f["p3_rge"].word + f["p3_ree"].word
    bram = bram18_blocks(1 << config.keys_bits, 4 * f["p3_keys"].word)
    normalised = config.normalise != "none"
    for lv in sched["levels"]:
        level, n_l = lv["level"], lv["width"]
        raw = f["p3_pix"].word if level == 0 else f["p3_pyr"].word
        pix = f["p3_norm"].word if normalised else raw  # what the warps read
        parent = f["p3_pix"].word if level == 1 else f["p3_pyr"].word
        if normalised:
            bram += 2 * bram18_blocks(n_l, 2 * config.normalise_radius * raw)
        n_parent = -(-n // 2 ** max(level - 1, 0))
        r = config.radius
        if level:
            bram += 2 * bram18_blocks(n_parent, 4 * (parent + 4))
        v = int(bool(config.vertical))
        bram += config.warps * bram18_blocks(n_l, 2 * r * rows)
        bram += config.warps * bram18_blocks(n_l, (r + v) * (2 * pix + u))
        if v:  # E1's and W's column-difference lines, g and e waiting for gy, the row sums
            vrows = f["p3_ryy"].word + f["p3_rgy"].word + f["p3_rye"].word
            if config.vertical_form == "box":  # five exact box row sums of 2 rv lines
                vrows = box_row_bits(config)
            bram += bram18_blocks(n_l, 2 * pix)
            bram += config.warps * bram18_blocks(
                n_l, 2 * f["p3_warp"].word + f["p3_g"].word + f["p3_e"].word
            )
            lines = 2 * config.vertical_radius if config.vertical_form == "box" else 2 * r
            bram += config.warps * bram18_blocks(n_l, lines * vrows)
        if lv["delay_lines"]:
            if lv["buffer_words"]["coarse_delay"]:  # raw pixels: normalised as they leave
                bram += 2 * bram18_blocks(lv["buffer_words"]["coarse_delay"] // 2, raw)
            bram += bram18_blocks(-(-n_l // 2), u)
    return CostReport(
        register_bits=register_bits(config, shape),
        line_buffer_bits=sum(buffer_bits(config, shape).values()),
        frame_store_bits=0,
        bram18=bram,
        dsp=sum(mul.dsp for mul in multipliers(config, shape)),
    )
