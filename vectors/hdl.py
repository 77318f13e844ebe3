"""Parameters of the Verilog row + column filter stage (``hdl/p1_rowcol.v``) from a config.

:func:`rowcol_parameters` turns a :class:`~rangefx.rtl_model.config.P1Config`
into the module's Verilog parameters (word, fraction bits, sign, quantisation and
overflow mode of each implemented signal); :func:`rowcol_registers` gives the raw codes
of the host registers ``pole_raw`` and ``bias_raw``. ``HDL_DIR`` locates the sources
in a source checkout. Importing this module is cheap (no numba), so the cocotb test
module that runs inside the simulator can use :data:`ROWCOL_TAPS`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the simulator process imports this module: keep numba out of it
    from rangefx.rtl_model.p1.config import P1Config

__all__ = ["HDL_DIR", "HDL_SOURCES", "ROWCOL_TAPS", "rowcol_parameters", "rowcol_registers"]

#: ``hdl/`` of the source checkout (the Verilog is not installed with the package).
HDL_DIR = Path(__file__).resolve().parent.parent / "hdl"
HDL_SOURCES = ("fx_cast.v", "p1_rowcol.v")

#: Tap (without ``e1.``/``e2.``) -> output port of ``p1_rowcol``.
ROWCOL_TAPS = {
    "bias_in": "bias_in",
    "row_state": "row_state",
    "row_r1": "row_r1",
    "row_r2": "row_r2",
    "col_state": "col_state",
    "col_s1": "col_s1",
    "col_s2": "col_s2",
}

_PREFIX = {
    "pix_in": "PIX",
    "bias_reg": "BREG",
    "pole_coef": "POLE",
    "bias_in": "B",
    "row_state": "P",
    "row_r1": "R1",
    "row_r2": "R2",
    "col_state": "Q",
    "col_s1": "S1",
    "col_s2": "S2",
}


def rowcol_parameters(config: P1Config, width: int) -> dict[str, int]:
    """Verilog parameters of ``p1_rowcol`` for ``config`` and lines of ``width`` pixels."""
    params = {
        "MAX_WIDTH": int(width),
        "ADDR_W": max(1, (int(width) - 1).bit_length()) + 1,
        "CONSISTENT": int(config.variant == "consistent"),
        "INIT_FIRST": int(config.init == "first"),
    }
    for signal, p in _PREFIX.items():
        f = config.fmt(signal)
        params |= {f"{p}_W": f.word, f"{p}_F": f.frac, f"{p}_S": int(f.signed)}
        if signal not in ("bias_reg", "pole_coef"):
            params |= {f"{p}_Q": int(f.quant), f"{p}_O": int(f.overflow)}
    return params


def rowcol_registers(config: P1Config) -> dict[str, int]:
    """Raw codes (unsigned words) of ``pole_raw`` and ``bias_raw``, as the host writes them."""
    pole, bias = config.fmt("pole_coef"), config.fmt("bias_reg")
    return {
        "pole_raw": pole.from_float(config.pole) & ((1 << pole.word) - 1),
        "bias_raw": bias.from_float(config.bias) & ((1 << bias.word) - 1),
    }
