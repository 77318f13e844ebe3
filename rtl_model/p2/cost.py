"""Hardware cost proxies of a P2 word-length config (SPEC §6, §10; docs/wordlength.md).

The same models as P1's (:mod:`rangefx.rtl_model.cost`): register bits summed over
every register of docs/p2_datapath.md, line-buffer bits as the model reports them, RAMB18
by the packing rule, DSP48E2 slices by tiling each multiplier's operand widths.

Registers
    One instance of every datapath signal of the input stage (``p2_pix`` twice: E1 and
    E2), of the backward-sweep engine and of the forward-pass engine (each engine is
    shared by its lanes: the lanes interleave in time, not in space, so its registers
    are not replicated), plus the host registers ``KA``, ``M``, ``c_min`` (a ``p2_c``
    word), ``S~_end`` (a ``p2_st`` word), ``T_D`` (a ``p2_d`` word) and ``RMAX`` (a ``p2_z``
    word). The per-lane state the engines carry between steps (``S~``, ``Q~`` in the
    sweep, ``e`` in the forward pass) takes one word per lane.
Buffers
    Ping-pong input line buffers (``d``, ``Ĝ``), two memories of ``lanes * width`` words,
    and one sweep buffer of ``lanes * width`` entries (``D`` and ``ΔĜ`` one bit wider than
    ``d``, ``Ĝ``; ``r``, ``S~``, ``Q~``: :func:`~rangefx.rtl_model.p2.model.sweep_entry_bits`),
    filled in alternating column order (:func:`~rangefx.rtl_model.p2.model.sweep_address`);
    every field of a buffer packed into one memory.
DSP slices
    ``KA (d_k + d_k+1)``, ``A^2``, ``c S~``, ``r S~``, ``S~ ΔĜ``, ``r h``; forward
    ``S~ u``, ``r w``, ``A λ``, ``A z``; the reciprocal divider's three products.
Calibrated area (``Pipeline.estimated_area``)
    LUT, FF, DSP and BRAM of the whole ``p2_top`` as Yosys synthesises it, as P1's: an
    intercept plus a slope per proxy term of :data:`AREA_FEATURES` (:func:`area_terms`),
    fitted per target by ``python -m rangefx.tools.studies.calibrate --pipeline p2
    --write`` into ``synth_calibration.toml`` beside this file.
"""

from __future__ import annotations

from ..cost import (
    CostReport,
    Multiplier,
    bram18_blocks,
    reciprocal_multipliers,
    restoring_cells,
    sum_bits,
)
from ..cost import operand_bits as _bits
from ..fixedpoint import FixedFormat
from .config import P2_SIGNALS, P2Config
from .model import buffer_bits, sweep_entry_bits

__all__ = [
    "AREA_FEATURES",
    "CALIBRATION_CONFIGS",
    "area_terms",
    "config_cost",
    "multipliers",
    "register_bits",
]

#: Area class of the synthesis -> the proxy terms (:func:`area_terms` keys) it is fitted on.
AREA_FEATURES: dict[str, tuple[str, ...]] = {
    "lut": ("register_bits", "restoring_cells"),
    "ff": ("register_bits", "restoring_cells"),
    "dsp": ("dsp",),
    "bram": ("bram18", "recip_roms"),
}
#: The configs the calibration synthesises (``Pipeline.calibration_configs``): fitted on
#: the default, the hand-narrowed config, more lanes and the restoring divider; held out:
#: their combinations and a shorter reciprocal.
_NARROWED = "tools/studies/sweeps/p2_hand_narrowed.toml"
CALIBRATION_CONFIGS: dict[str, tuple[str | None, dict, bool]] = {
    "default": (None, {}, True),
    "narrowed": (_NARROWED, {}, True),
    "default-lanes16": (None, {"lanes": 16}, True),
    "default-restoring": (None, {"divider": "restoring"}, True),
    "narrowed-lanes16": (_NARROWED, {"lanes": 16}, False),
    "narrowed-restoring": (_NARROWED, {"divider": "restoring"}, False),
    "default-lanes24": (None, {"lanes": 24}, False),
    "narrowed-recip16": (_NARROWED, {"recip_bits": 16}, False),
}

#: Host registers held in a datapath signal's format: signal -> extra words.
_HOST_WORDS = {"p2_c": 1, "p2_st": 1, "p2_d": 1, "p2_z": 1}
#: Per-lane state of the engines.
_LANE_STATE = ("p2_st", "p2_q", "p2_e")


def register_bits(config: P2Config) -> int:
    """Register bits of the datapath (see the module docstring)."""
    f = config.formats
    lanes = config.effective_lanes()
    total = 0
    for name in P2_SIGNALS:
        count = 2 if name == "p2_pix" else 1
        count += _HOST_WORDS.get(name, 0)
        if name in _LANE_STATE:
            count += lanes - 1
        total += count * f[name].word
    return total


def _widened(fmt: FixedFormat) -> FixedFormat:
    """``fmt`` one bit wider and signed: a sum or difference of two samples."""
    return FixedFormat(True, _bits(fmt) + 1, fmt.frac)


def multipliers(config: P2Config) -> list[Multiplier]:
    """Every multiplier of docs/p2_datapath.md with its operand widths."""
    f = config.formats
    dsum, dg = _widened(f["p2_d"]), _widened(f["p2_ghat"])
    u_bits = sum_bits(f["p2_e"], dg)
    st, r, a = _bits(f["p2_st"]), _bits(f["p2_r"]), _bits(f["p2_a"])
    muls = [
        Multiplier("A: KA * (d_k + d_k+1)", _bits(f["p2_ka_reg"]), _bits(dsum)),
        Multiplier("c: A^2", a, a),
        Multiplier("den: c * S~", _bits(f["p2_c"]), st),
        Multiplier("S~: r * S~", r, st),
        Multiplier("h: S~ * dG", st, _bits(dg)),
        Multiplier("Q~: r * h", r, _bits(f["p2_h"])),
        Multiplier("w: S~ * u", st, u_bits),
        Multiplier("lambda: r * w", r, _bits(f["p2_w"])),
        Multiplier("z: A * lambda", a, _bits(f["p2_lam"])),
        Multiplier("e: A * z", a, _bits(f["p2_z"])),
    ]
    if config.divider == "reciprocal":
        muls += reciprocal_multipliers(config.recip_bits, "divider 1 / den", 2, 1)
    return muls


def config_cost(config: P2Config, shape: tuple[int, int], mode: str = "stereo") -> CostReport:
    """Cost proxies of ``config`` on ``shape`` = (height, width) stereo images."""
    if mode != "stereo":
        raise ValueError(f"P2 models stereo mode only, not {mode!r}")
    _, n = shape
    f = config.formats
    lanes = config.effective_lanes()
    bits = buffer_bits(config, n)
    depth = lanes * n
    lb_word = f["p2_d"].word + f["p2_ghat"].word
    sweep_word = sweep_entry_bits(config)
    bram = 2 * bram18_blocks(depth, lb_word) + bram18_blocks(depth, sweep_word)
    return CostReport(
        register_bits=register_bits(config),
        line_buffer_bits=bits["line_buffer_bits"] + bits["sweep_buffer_bits"],
        frame_store_bits=0,
        bram18=bram,
        dsp=sum(m.dsp for m in multipliers(config)),
    )


def area_terms(config: P2Config, shape: tuple[int, int], mode: str = "stereo") -> dict[str, int]:
    """The proxy terms the area calibration fits on: :func:`config_cost`'s and
    ``restoring_cells``, the restoring divider's quotient bits x divisor bits (``r = 1 /
    den``; 0 with the reciprocal divider) and ``recip_roms``, the reciprocal divider's seed
    ROM (1, else 0)."""
    terms = config_cost(config, shape, mode).as_dict()
    f = config.formats
    cells = (
        restoring_cells(f["p2_r"].word, f["p2_den"].word) if config.divider == "restoring" else 0
    )
    roms = 1 if config.divider == "reciprocal" else 0
    return terms | {"restoring_cells": cells, "recip_roms": roms}
