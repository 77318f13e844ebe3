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
    is counted as a memory (``2**keys_bits`` words of 4 weights).
Buffers
    Every line buffer of the streaming schedule
    (:func:`~rangefx.rtl_model.p3.model.buffer_bits`): the normalisation's ``2 R`` lines
    per stream and level, the reduce's 4 lines per image, the E2 warp rows, the window's
    ``2 r`` lines of row sums and ``r`` lines of E1, E2 and ``u``, the expand's coarse
    line, the coarse-to-fine delay lines (raw pixels, normalised as they leave). RAMB18:
    each buffer one memory of (lines x width) words.
DSP slices
    Per stream and level the normalisation's ``1/box`` times the box sum; per warp
    stage: the warp's 4 products, ``g^2``, ``g e``, ``e^2``, the window's ``r + 1``
    products per pass and product (the symmetric taps share one after a pre-add), the
    divider's; at level 0 ``Σe² Σg²``, ``(Σge)²``, ``T_r^2 Σg²`` and the
    range divider's.
"""

from __future__ import annotations

import math

from rangefx.golden.multiscale import streaming_schedule

from ..cost import CostReport, Multiplier, bram18_blocks, reciprocal_multipliers
from ..cost import operand_bits as _bits
from .config import P3Config
from .model import buffer_bits, level_shapes

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
        Multiplier("res: see * sgg", _bits(f["p3_see"]), _bits(f["p3_sgg"])),
        Multiplier("res: sge^2", _bits(f["p3_sge"]), _bits(f["p3_sge"])),
        Multiplier("rthr: T_r^2 * sgg", _bits(f["p3_tr2"]), _bits(f["p3_sgg"])),
    ]
    if config.normalise != "none":
        box = max(_bits(f["p3_pix"]), _bits(f["p3_pyr"])) + _box_bits(config)
        levels = len(level_shapes(config, shape))
        muls.append(Multiplier("normalise: 1/box * box sum", _bits(f["p3_nbox"]), box, 2 * levels))
    if config.divider == "reciprocal":
        muls += reciprocal_multipliers(config.recip_bits, "divider du", _bits(f["p3_sge"]), stages)
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
        bram += config.warps * bram18_blocks(n_l, 2 * r * rows)
        bram += config.warps * bram18_blocks(n_l, r * (2 * pix + u))
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
