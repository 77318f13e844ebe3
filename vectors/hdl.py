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

__all__ = [
    "HDL_DIR",
    "HDL_SOURCES",
    "RANGE_INPUTS",
    "RANGE_REGISTER_PORTS",
    "RANGE_SOURCES",
    "RANGE_TAP_GROUPS",
    "ROWCOL_TAPS",
    "range_parameters",
    "range_registers",
    "rowcol_parameters",
    "rowcol_registers",
    "write_recip_rom",
]

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


# -- the range stage (hdl/p1_range.v) ---------------------------------------------------
RANGE_SOURCES = ("fx_cast_sized.v", "fx_divide.v", "p1_range.v")

#: Tap groups of ``p1_range`` in the order of their overflow-flag bits (``ovf_c``,
#: ``ovf_p``, ``ovf_q``), each with its valid port; the port of a tap is its name.
RANGE_TAP_GROUPS: dict[str, tuple[str, tuple[str, ...]]] = {
    "ovf_c": (
        "c_valid",
        ("xp", "yp", "c1", "a1", "b1", "k0", "k1", "k2", "vx", "vy", "wx", "wy", "w0"),
    ),
    "ovf_p": ("p_valid", ("gv", "num", "den", "v_sq", "g_sq", "g_thr")),
    "ovf_q": ("q_valid", ("range_q",)),
    "": ("m_valid", ("valid", "range")),
}

#: Stream inputs of ``p1_range`` (per stream ``e1_``/``e2_``) -> the front-end tap feeding it.
RANGE_INPUTS = {"s1": "col_s1", "ex": "ex", "s2": "col_s2"}

_RANGE_PREFIX = {
    "col_s1": "S1",
    "col_s2": "S2",
    "f_reg": "FR",
    "k_t_reg": "KT",
    "k_m_reg": "KM",
    "tg2_reg": "TG2",
    "coord": "CO",
    "c1": "C1",
    "grad_a": "GA",
    "grad_b": "GB",
    "k_rot": "KR",
    "geom_v": "V",
    "geom_w": "W",
    "gv": "GV",
    "num": "NUM",
    "den": "DEN",
    "range": "RNG",
    "v_sq": "VSQ",
    "grad_sq": "GSQ",
}
#: Signals of ``p1_range`` that are only read (stream inputs, host registers): no modes.
_RANGE_READ_ONLY = ("col_s1", "col_s2", "f_reg", "k_t_reg", "k_m_reg", "tg2_reg")

#: Register port of ``p1_range`` -> the manifest's register names (``FrameRegisters``);
#: ``m_raw`` packs the nine rotation terms, ``R00`` in the low bits.
RANGE_REGISTER_PORTS: dict[str, tuple[str, ...]] = {
    "cx_raw": ("cx",),
    "cy_raw": ("cy",),
    "f_raw": ("f",),
    "k3_raw": ("k3",),
    "k4_raw": ("k4",),
    "k5_raw": ("k5",),
    "m_raw": tuple(f"R{i}{c}" for i in range(3) for c in range(3)),
    "te_raw": ("T_E",),
    "tg2_raw": ("T_g^2",),
    "dmin_raw": ("min_denominator",),
    "rmax_raw": ("range_max",),
}


def range_parameters(config: P1Config, width: int, height: int, rom_file: str = "") -> dict:
    """Verilog parameters of ``p1_range`` for ``config`` and frames of ``width`` x ``height``
    pixels; ``rom_file``: the reciprocal seed ROM (``recip_rom.mem`` of a vector directory,
    or :func:`write_recip_rom`), needed by the reciprocal divider only."""
    params: dict = {
        "X_W": max(1, (int(width) - 1).bit_length()),
        "Y_W": max(1, (int(height) - 1).bit_length()),
        "DIVIDER": int(config.divider == "reciprocal"),
        "RECIP_L": config.recip_lut_bits,
        "RECIP_R": config.recip_bits,
    }
    if config.divider == "reciprocal":
        if not rom_file:
            raise ValueError("the reciprocal divider needs its seed ROM file (rom_file)")
        params["ROM_FILE"] = f'"{rom_file}"'
    ex = config.fmt(config.ex_signal)
    params |= {"EX_W": ex.word, "EX_F": ex.frac, "EX_S": int(ex.signed)}
    for signal, p in _RANGE_PREFIX.items():
        f = config.fmt(signal)
        params |= {f"{p}_W": f.word, f"{p}_F": f.frac, f"{p}_S": int(f.signed)}
        if signal not in _RANGE_READ_ONLY:
            params |= {f"{p}_Q": int(f.quant), f"{p}_O": int(f.overflow)}
    return params


def range_registers(config: P1Config, registers: dict) -> dict[str, int]:
    """Port values (unsigned words) of ``p1_range``'s host registers from a manifest's
    ``registers`` (name -> ``{"signal", "raw", ...}``: the raw codes the model used)."""
    out = {}
    for port, names in RANGE_REGISTER_PORTS.items():
        value = 0
        for k, name in enumerate(names):
            reg = registers[name]
            word = config.fmt(reg["signal"]).word
            value |= (int(reg["raw"]) & ((1 << word) - 1)) << (k * word)
        out[port] = value
    return out


def write_recip_rom(config: P1Config, path: str | Path) -> Path:
    """Write the reciprocal divider's seed ROM of ``config`` as ``$readmemh`` words (the
    table of ``rangefx.rtl_model.runtime.reciprocal_lut``, as the vectors' ``recip_rom``)."""
    from rangefx.rtl_model.runtime import reciprocal_lut

    words = reciprocal_lut(config.recip_lut_bits, config.recip_bits)
    digits = max(1, (int(words.max()).bit_length() + 3) // 4)
    p = Path(path)
    p.write_text("".join(f"{int(w):0{digits}x}\n" for w in words))
    return p
