"""Hardware cost proxies of a P1 word-length config (SPEC §6, §10).

Pure functions of the config, the image size and the mode (stereo / motion): no run of
the model is needed, so the optimiser can rank candidates before running them.

Models (stated here, reported in ``docs/wordlength.md``):

Register bits
    The sum of word lengths over every *instance* of a signal in the datapath of
    ``docs/p1_datapath.md`` (:data:`REGISTER_INSTANCES`): per stream the stream signals
    (two streams in stereo, one in motion), once the range-stage signals (``xp`` and
    ``yp`` are two ``coord`` registers, ``k0..k2`` three ``k_rot``, ...), and the host
    registers (``cx``, ``cy``, ``f``, ``k3..k5``, the nine rotation terms, ``T_E``,
    ``T_g^2``, ``DMIN``, ``RMAX``, pole, bias). Pipeline-balancing registers are not
    counted (they scale with the same word lengths).
Line buffer / frame store bits
    As the model reports them (``run_p1``): per stream, width x the column-filter state
    word (plus ``col2_state`` in the ``consistent`` variant); in motion mode a frame
    store of height x width words of ``col_s1 + ex + col_s2`` bits.
BRAM18 count
    Packing rule: every line buffer (per stream, per column filter) is its own memory of
    ``depth = width`` words; the frame store is one memory of ``height * width`` words of
    the concatenated fields. A memory of depth ``D`` and word ``W`` takes
    ``min over aspect (d, w) of ceil(D / d) * ceil(W / w)`` RAMB18 blocks, the aspects
    being those of a Xilinx 18 Kbit block RAM (16K x 1, 8K x 2, 4K x 4, 2K x 9, 1K x 18,
    512 x 36).
DSP slices
    Every multiplier of ``docs/p1_datapath.md`` (:func:`multipliers`) with its operand
    widths in two's complement bits (an unsigned operand of ``W`` bits takes ``W + 1``),
    tiled on 27 x 18 signed multipliers (DSP48E2): ``min(ceil(a/27) ceil(b/18),
    ceil(a/18) ceil(b/27))`` slices for an ``a x b`` product. Products of two per-frame
    constants (``f k4``, ``f k5``) are hoisted to the host and cost none. The restoring
    divider uses no multiplier; the reciprocal divider three (``mR y0``, ``y0 e``,
    ``|N| y1``). Pre-adders, the product with the pole written as shifts, and LUT
    multipliers for tiny widths are not modelled: this is an upper-bound-style proxy.
``cost_bits``
    The scalar the optimiser minimises: register bits + line-buffer bits + frame-store
    bits.
Calibrated area (``Pipeline.estimated_area``)
    LUT, FF, DSP and BRAM of the whole ``p1_top`` as Yosys synthesises it, each an
    intercept plus a slope per proxy term of :data:`AREA_FEATURES` (:func:`area_terms`:
    LUT and FF on the register bits and the restoring dividers' cells, DSP on the DSP
    slices, BRAM on the RAMB18 and the reciprocal seed ROMs), fitted per target by ``python -m
    rangefx.tools.studies.calibrate --pipeline p1 --write`` and stored in
    ``synth_calibration.toml`` beside this file with the commit and hash of the RTL.
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
from .config import P1Config
from .model import buffer_bits, frame_store_word, line_buffer_words

__all__ = [
    "AREA_FEATURES",
    "CALIBRATION_CONFIGS",
    "REGISTER_INSTANCES",
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
#: the default and three narrowed configs of both variants and dividers; held out: the
#: direct filter form, another optimised config and the restoring divider elsewhere.
_SWEEPS = "tools/studies/sweeps/"
CALIBRATION_CONFIGS: dict[str, tuple[str | None, dict, bool]] = {
    "default": (None, {}, True),
    "lab-optimised": (_SWEEPS + "p1_lab_optimised_1pct.toml", {}, True),
    "default-consistent": (None, {"variant": "consistent"}, True),
    "lab-runway-optimised": (_SWEEPS + "p1_lab_runway_optimised_1pct.toml", {}, True),
    "default-restoring": (None, {"divider": "restoring"}, True),
    "default-direct": (None, {"filter_form": "direct"}, False),
    "motorcycle-margin50": (_SWEEPS + "p1_lab_runway_motorcycle_margin50_1pct.toml", {}, False),
    "lab-optimised-restoring": (_SWEEPS + "p1_lab_optimised_1pct.toml",
                                {"divider": "restoring"}, False),
    "consistent-restoring": (None, {"variant": "consistent", "divider": "restoring"}, False),
}  # fmt: skip

#: Signal -> (instances per stream, instances in the range stage + host registers).
REGISTER_INSTANCES: dict[str, tuple[int, int]] = {
    "pix_in": (1, 0),
    "bias_in": (1, 0),
    "row_state": (1, 0),
    "row_r1": (1, 0),
    "row_r2": (1, 0),
    "col_state": (1, 0),  # the value read from the line buffer
    "col_s1": (1, 0),
    "col_s2": (1, 0),
    "col2_state": (1, 0),  # consistent only
    "col2_out": (1, 0),  # consistent only
    "div_quot": (1, 0),  # paper only
    "bias_reg": (0, 1),
    "pole_coef": (0, 1),
    "c1": (0, 2),  # c1 and the threshold register T_E
    "grad_a": (0, 1),
    "grad_b": (0, 1),
    "coord": (0, 4),  # xp, yp, cx, cy
    "f_reg": (0, 1),
    "k_t_reg": (0, 3),
    "k_m_reg": (0, 9),
    "k_rot": (0, 3),
    "geom_v": (0, 2),
    "geom_w": (0, 3),
    "gv": (0, 1),
    "num": (0, 1),
    "den": (0, 2),  # den and DMIN
    "range": (0, 2),  # quotient and RMAX
    "v_sq": (0, 1),
    "tg2_reg": (0, 1),
    "grad_sq": (0, 2),  # g_sq and g_thr
}
_PAPER_ONLY = ("div_quot",)
_CONSISTENT_ONLY = ("col2_state", "col2_out")


def _used(config: P1Config, name: str) -> bool:
    if config.variant == "paper":
        return name not in _CONSISTENT_ONLY
    return name not in _PAPER_ONLY


def register_bits(config: P1Config, mode: str = "stereo") -> int:
    """Register bits of the datapath (see the module docstring)."""
    streams = _streams(mode)
    total = 0
    for name, (per_stream, once) in REGISTER_INSTANCES.items():
        if _used(config, name):
            total += (per_stream * streams + once) * config.formats[name].word
    return total


def _streams(mode: str) -> int:
    if mode not in ("stereo", "motion"):
        raise ValueError(f"unknown P1 mode {mode!r}; choose 'stereo' or 'motion'")
    return 2 if mode == "stereo" else 1


def _divider_muls(config: P1Config, name: str, n_bits: int, count: int) -> list[Multiplier]:
    if config.divider == "restoring":
        return []
    return reciprocal_multipliers(config.recip_bits, name, n_bits, count)


def multipliers(config: P1Config, mode: str = "stereo") -> list[Multiplier]:
    """Every multiplier of docs/p1_datapath.md with its operand widths."""
    s = _streams(mode)
    f = config.formats
    c = _bits(f["pole_coef"])
    # the shift filter form applies the pole 2^-k by wiring: no filter multiplier
    direct = config.filter_form == "direct"
    muls = []
    if direct:
        muls += [
            Multiplier("row filter: C * (b - p)", c, sum_bits(f["bias_in"], f["row_state"]), s),
            Multiplier("column filter: C * (r1 - q)", c, sum_bits(f["row_r1"], f["col_state"]), s),
        ]
    if config.variant == "paper":
        muls.append(Multiplier("x-derivative: s1 * r2", _bits(f["col_s1"]), _bits(f["row_r2"]), s))
        n_bits = f["col_s1"].word + f["row_r2"].word  # magnitude of the product
        muls += _divider_muls(config, "divider s1 r2 / r1", n_bits, s)
    elif direct:
        muls.append(
            Multiplier(
                "column filter on r2: C * (r2 - q2)",
                c,
                sum_bits(f["row_r2"], f["col2_state"]),
                s,
            )
        )
    co, km, kt, kr = _bits(f["coord"]), _bits(f["k_m_reg"]), _bits(f["k_t_reg"]), _bits(f["k_rot"])
    fr, a, b, c1 = _bits(f["f_reg"]), _bits(f["grad_a"]), _bits(f["grad_b"]), _bits(f["c1"])
    gvb, vb, wb = _bits(f["geom_v"]), _bits(f["geom_v"]), _bits(f["geom_w"])
    muls += [
        Multiplier("k_i: M_i1 * xp, M_i2 * yp", km, co, 6),
        Multiplier("v: f * k4, f * k5 (per frame)", fr, kt, 2, hoisted=True),
        Multiplier("v: xp * k3, yp * k3", co, kt, 2),
        Multiplier("w: f * k1, f * k2", fr, kr, 2),
        Multiplier("w: xp * k0, yp * k0", co, kr, 2),
        Multiplier("gv: a1 * vx", a, vb),
        Multiplier("gv: b1 * vy", b, vb),
        Multiplier("num: k3 * c1", kt, c1),
        Multiplier("den: a1 * wx", a, wb),
        Multiplier("den: b1 * wy", b, wb),
        Multiplier("den: c1 * w0", c1, wb),
        Multiplier("v_sq: vx^2, vy^2", gvb, gvb, 2),
        Multiplier("g_sq: gv^2", _bits(f["gv"]), _bits(f["gv"])),
        Multiplier("g_thr: T_g^2 * v_sq", _bits(f["tg2_reg"]), _bits(f["v_sq"])),
    ]
    muls += _divider_muls(config, "range divider num / den", f["num"].word, 1)
    return muls


def config_cost(config: P1Config, shape: tuple[int, int], mode: str = "stereo") -> CostReport:
    """Cost proxies of ``config`` on ``shape`` = (height, width) images in ``mode``; the
    buffers are the model's own (:func:`rangefx.rtl_model.p1.model.buffer_bits`)."""
    m, n = shape
    streams = _streams(mode)
    bits = buffer_bits(config, shape, mode)
    bram = streams * sum(bram18_blocks(n, w) for w in line_buffer_words(config))
    if mode == "motion":
        bram += bram18_blocks(m * n, frame_store_word(config))
    return CostReport(
        register_bits=register_bits(config, mode),
        line_buffer_bits=bits["line_buffer_bits"],
        frame_store_bits=bits["frame_store_bits"],
        bram18=bram,
        dsp=sum(mul.dsp for mul in multipliers(config, mode)),
    )


def area_terms(config: P1Config, shape: tuple[int, int], mode: str = "stereo") -> dict[str, int]:
    """The proxy terms the area calibration fits on: :func:`config_cost`'s and
    ``restoring_cells``, the restoring dividers' quotient bits x divisor bits (the
    ``paper`` variant's ``s1 r2 / r1`` per stream, the range stage's ``num / den``; 0
    with the reciprocal divider, whose area is its products and seed ROM) and
    ``recip_roms``, the reciprocal dividers' seed ROMs (a block RAM each on ECP5, LUTs on
    xcup; the proxy's RAMB18 count only the line buffers)."""
    terms = config_cost(config, shape, mode).as_dict()
    dividers = 1 + (_streams(mode) if config.variant == "paper" else 0)
    roms = dividers if config.divider == "reciprocal" else 0
    cells = 0
    if config.divider == "restoring":
        f = config.formats
        if config.variant == "paper":
            cells += restoring_cells(f["div_quot"].word, f["row_r1"].word, _streams(mode))
        cells += restoring_cells(f["range"].word, f["den"].word)
    return terms | {"restoring_cells": cells, "recip_roms": roms}
