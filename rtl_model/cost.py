"""Hardware cost primitives shared by every pipeline's cost model (SPEC §6, §10).

The block-RAM packing rule, the DSP tiling rule, one multiplier, and the one cost
report type. Each pipeline's ``cost`` module lists its registers, buffers and
multipliers with these; ``docs/wordlength.md`` states the models.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .config import exact_bits
from .fixedpoint import FixedFormat

__all__ = [
    "BRAM18_ASPECTS",
    "CostReport",
    "Multiplier",
    "bram18_blocks",
    "dsp_slices",
    "estimate_area",
    "load_area_calibration",
    "operand_bits",
    "reciprocal_multipliers",
    "restoring_cells",
    "sum_bits",
]

#: (depth, width) aspects of one RAMB18 (18 Kbit; the x9/x18/x36 widths use parity bits).
BRAM18_ASPECTS: tuple[tuple[int, int], ...] = (
    (16384, 1),
    (8192, 2),
    (4096, 4),
    (2048, 9),
    (1024, 18),
    (512, 36),
)
#: Signed operand widths of one DSP48E2 multiplier.
DSP_A, DSP_B = 27, 18


def operand_bits(fmt: FixedFormat) -> int:
    """Two's complement bits of a multiplier operand holding ``fmt``."""
    return fmt.word if fmt.signed else fmt.word + 1


def sum_bits(*fmts: FixedFormat) -> int:
    """Bits of the exact sum/difference of ``fmts`` (the adder feeding a product)."""
    return exact_bits(tuple((f,) for f in fmts))


def bram18_blocks(depth: int, width: int) -> int:
    """RAMB18 blocks of one memory of ``depth`` words of ``width`` bits (best aspect)."""
    if depth <= 0 or width <= 0:
        return 0
    return min(math.ceil(depth / d) * math.ceil(width / w) for d, w in BRAM18_ASPECTS)


def dsp_slices(a_bits: int, b_bits: int) -> int:
    """DSP48E2 slices (27 x 18 signed) of an ``a_bits x b_bits`` signed product."""
    if a_bits <= 0 or b_bits <= 0:
        return 0
    return min(
        math.ceil(a_bits / DSP_A) * math.ceil(b_bits / DSP_B),
        math.ceil(a_bits / DSP_B) * math.ceil(b_bits / DSP_A),
    )


@dataclass(frozen=True)
class Multiplier:
    """One multiplier of a datapath: operand widths (signed bits) and count."""

    name: str
    a_bits: int
    b_bits: int
    count: int = 1
    hoisted: bool = False  # product of per-frame constants: computed by the host

    def __post_init__(self) -> None:
        if self.a_bits < 1 or self.b_bits < 1 or self.count < 1:
            raise ValueError(f"multiplier {self.name!r}: widths and count must be >= 1")

    @property
    def dsp(self) -> int:
        return 0 if self.hoisted else self.count * dsp_slices(self.a_bits, self.b_bits)


def reciprocal_multipliers(recip_bits: int, name: str, n_bits: int, count: int) -> list[Multiplier]:
    """The reciprocal divider's three products (``mR y0``, ``y0 e``, ``|N| y1``): ``mR`` in
    [1, 2) and ``y0``, ``y1`` ~ 1/m with ``R`` fraction bits take R + 1 magnitude bits
    plus a sign, ``e = 2^(R+1) - t`` R + 2 bits, ``|N|`` its magnitude bits."""
    r = recip_bits
    return [
        Multiplier(f"{name}: mR * y0", r + 2, r + 2, count),
        Multiplier(f"{name}: y0 * e", r + 2, r + 3, count),
        Multiplier(f"{name}: |N| * y1", n_bits, r + 2, count),
    ]


@dataclass(frozen=True)
class CostReport:
    """Cost proxies of one config at one image size and mode.

    ``line_buffer_bits`` counts every buffer a line deep (filter line buffers, input and
    sweep line buffers), ``frame_store_bits`` a frame store.
    """

    register_bits: int
    line_buffer_bits: int
    frame_store_bits: int
    bram18: int
    dsp: int

    @property
    def cost_bits(self) -> int:
        """The scalar the optimiser minimises: registers + line buffers + frame store."""
        return self.register_bits + self.line_buffer_bits + self.frame_store_bits

    def as_dict(self) -> dict[str, int]:
        return {
            "cost_bits": self.cost_bits,
            "register_bits": self.register_bits,
            "line_buffer_bits": self.line_buffer_bits,
            "frame_store_bits": self.frame_store_bits,
            "bram18": self.bram18,
            "dsp": self.dsp,
        }


def restoring_cells(quotient_bits: int, divisor_bits: int, count: int = 1) -> int:
    """Cells of ``count`` restoring dividers (``hdl/fx_divide.v``): one conditional
    subtraction of the divisor's width per quotient bit, each with its remainder
    register, so area grows as quotient bits x divisor bits (the reciprocal divider's is
    its three products and seed ROM instead)."""
    return count * quotient_bits * divisor_bits


def load_area_calibration(path: str | Path) -> dict[str, Any]:
    """A pipeline's area calibration file (``rtl_model/<pipeline>/synth_calibration.toml``,
    written by ``python -m rangefx.tools.studies.calibrate --write``): ``meta`` (the RTL's
    commit and hash, Yosys, the configs fitted on and held out) and ``targets`` {target:
    {area class: {``intercept``, proxy term: coefficient, ...}}}."""
    with open(path, "rb") as fh:
        return tomllib.load(fh)


def estimate_area(
    terms: Mapping[str, float], coefficients: Mapping[str, Mapping[str, float]]
) -> dict[str, int]:
    """Each area class of ``coefficients`` ({class: {``intercept``: c, term: slope, ...}})
    as ``round(max(0, c + sum of slope * terms[term]))``."""
    out = {}
    for cls, coef in coefficients.items():
        value = coef.get("intercept", 0.0)
        value += sum(k * terms[t] for t, k in coef.items() if t != "intercept")
        out[cls] = max(0, round(value))
    return out
