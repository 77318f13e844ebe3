"""What the Verilog of P1 (``hdl/``) needs from a vector directory, read from it alone.

:func:`top_parameters` turns a vector directory's manifest (its config's formats and
design, shape and mode) into the Verilog parameters of ``hdl/p1_top.v``;
:func:`register_codes` gives the raw codes of the host registers the front end reads,
from the manifest's ``registers``. Neither imports the model (no numba): the cocotb bench
that runs inside the simulator (``hdl/test_p1_top.py``) uses this module, and a user's
bench needs nothing but the directory. ``HDL_DIR`` locates the sources in a checkout.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

__all__ = [
    "FRONTEND_TAPS",
    "HDL_DIR",
    "HDL_SOURCES",
    "OVERFLOW_CODES",
    "OVERFLOW_SIGNALS",
    "QUANT_CODES",
    "TOPLEVEL",
    "frontend_instances",
    "register_codes",
    "top_parameters",
]

#: ``hdl/`` of the source checkout (the Verilog is not installed with the package).
HDL_DIR = Path(__file__).resolve().parent.parent / "hdl"
HDL_SOURCES = (
    "fx_cast_sized.v",
    "p1_colfilt.v",
    "p1_div_restoring.v",
    "p1_div_recip.v",
    "p1_frontend.v",
    "p1_top.v",
)
TOPLEVEL = "p1_top"

#: Tap (without ``e1.``/``e2.``) -> (output port, its stage's valid port) of p1_frontend.
FRONTEND_TAPS: Mapping[str, tuple[str, str]] = {
    "bias_in": ("bias_in", "bias_v"),
    "row_r1": ("row_r1", "row_v"),
    "row_r2": ("row_r2", "row_v"),
    "row_state": ("row_state", "row_v"),
    "col_s1": ("col_s1", "col_v"),
    "col_s2": ("col_s2", "col_v"),
    "col_state": ("col_state", "col_v"),
    "ex": ("ex", "ex_v"),
    "col2_state": ("col2_state", "col_v"),
}
#: Signals whose overflows p1_frontend counts (output ``ovf_<signal>``).
OVERFLOW_SIGNALS = (
    "pix_in", "bias_in", "row_state", "row_r1", "row_r2", "col_state", "col_s1", "col_s2",
    "col2_state", "col2_out", "div_quot",
)  # fmt: skip

#: Codes of the quantisation and overflow modes in the Verilog (``hdl/fx_cast_sized.v``),
#: the values of ``rangefx.rtl_model.fixedpoint.Quant`` / ``Overflow`` (tested equal).
QUANT_CODES = {
    "TRN": 0, "TRN_ZERO": 1, "RND": 2, "RND_ZERO": 3, "RND_INF": 4, "RND_MIN_INF": 5,
    "RND_CONV": 6,
}  # fmt: skip
OVERFLOW_CODES = {"WRAP": 0, "SAT": 1, "SAT_ZERO": 2, "SAT_SYM": 3}

#: Verilog parameter prefix of each signal the front end implements.
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
    "col2_state": "Q2",
    "col2_out": "X2",
    "div_quot": "DQ",
}
_REGISTERS = ("bias_reg", "pole_coef")
_FORMAT = re.compile(r"^([su])(\d+)\.(-?\d+)$")


def _format(text: str) -> tuple[int, int, int]:
    """``"s20.10"`` -> (word, frac, signed)."""
    match = _FORMAT.match(text)
    if match is None:
        raise ValueError(f"format {text!r} is not like 's20.10'")
    sign, word, frac = match.groups()
    return int(word), int(frac), int(sign == "s")


def top_parameters(manifest: Mapping, rom_file: str | Path | None = None) -> dict[str, int | str]:
    """Verilog parameters of ``p1_top`` for a P1 vector directory's ``manifest``.

    ``rom_file``: the reciprocal divider's seed ROM (the directory's ``recip_rom.mem``),
    needed by the paper variant with the reciprocal divider.
    """
    if manifest.get("pipeline") != "p1":
        raise ValueError(f"the RTL implements P1, not {manifest.get('pipeline')!r}")
    parsed = manifest["config"]["parsed"]
    design, signals = parsed["design"], parsed["signals"]
    m, n = manifest["shape"]
    params: dict[str, int | str] = {
        "MOTION": int(manifest["mode"] == "motion"),
        "MAX_WIDTH": int(n),
        "ADDR_W": max(1, int(n).bit_length()),
        "MAX_PIXELS": int(m * n),
        "PADDR_W": max(1, int(m * n).bit_length()),
        "CONSISTENT": int(design["variant"] == "consistent"),
        "INIT_FIRST": int(design["init"] == "first"),
        "DIVIDER": int(design["divider"] == "reciprocal"),
        "RECIP_L": int(design["recip_lut_bits"]),
        "RECIP_R": int(design["recip_bits"]),
    }
    for signal, p in _PREFIX.items():
        spec = signals[signal]
        word, frac, signed = _format(spec["format"])
        params |= {f"{p}_W": word, f"{p}_F": frac, f"{p}_S": signed}
        if signal not in _REGISTERS:
            params |= {f"{p}_Q": QUANT_CODES[spec["quant"]], f"{p}_O": OVERFLOW_CODES[spec["overflow"]]}
    if rom_file is not None:
        params["ROM_FILE"] = f'"{Path(rom_file).resolve()}"'
    return params


def register_codes(manifest: Mapping) -> dict[str, int]:
    """Raw codes (unsigned words) of ``pole_raw`` and ``bias_raw`` from the manifest."""
    out = {}
    for port, name in (("pole_raw", "pole"), ("bias_raw", "bias")):
        reg = manifest["registers"][name]
        word, _frac, _signed = _format(reg["format"])
        out[port] = int(reg["raw"]) & ((1 << word) - 1)
    return out


def frontend_instances(manifest: Mapping) -> dict[str, str]:
    """Stream -> hierarchical name of its p1_frontend in ``p1_top``: stereo ``e1`` on
    ``fe0`` and ``e2`` on ``g_stereo.fe1``; motion both frames on ``fe0``."""
    if manifest["mode"] == "motion":
        return {"e1+e2": "fe0"}
    return {"e1": "fe0", "e2": "g_stereo.fe1"}
