"""What the Verilog of P1 (``hdl/``) needs from a vector directory, read from it alone.

:func:`top_parameters` turns a vector directory's manifest (its config's formats and
design, shape and mode) into the Verilog parameters of ``hdl/p1_top.v``;
:func:`register_codes` gives the raw codes of the host registers the front end reads,
from the manifest's ``registers``. Neither imports the model (no numba): the cocotb bench
that runs inside the simulator (``hdl/test_top.py``) uses this module, and a user's
bench needs nothing but the directory. ``HDL_DIR`` locates the sources in a checkout.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .formats import read_mem, write_mem

if TYPE_CHECKING:  # the simulator process imports this module: keep numba out of it
    from rangefx.rtl_model.p1.config import P1Config

__all__ = [
    "FRONTEND_SOURCES",
    "FRONTEND_TAPS",
    "HDL_DIR",
    "HDL_SOURCES",
    "OVERFLOW_CODES",
    "OVERFLOW_SIGNALS",
    "QUANT_CODES",
    "RANGE_INPUTS",
    "RANGE_REGISTER_PORTS",
    "RANGE_SOURCES",
    "RANGE_TAP_GROUPS",
    "TOPLEVEL",
    "Beat",
    "bench_header",
    "config_top_parameters",
    "frontend_instances",
    "frontend_parameters",
    "range_parameters",
    "range_registers",
    "read_stream_mem",
    "register_codes",
    "register_port_widths",
    "rtl_files",
    "stream_entries",
    "top_parameters",
    "write_dump",
    "write_recip_rom",
]

#: ``hdl/`` of the source checkout (the Verilog is not installed with the package).
HDL_DIR = Path(__file__).resolve().parent.parent / "hdl"
#: One stream's front end (p1_frontend), and with the top (p1_top).
FRONTEND_SOURCES = ("fx_cast_sized.v", "fx_pipe.v", "fx_divide.v", "p1_colfilt.v", "p1_frontend.v")
HDL_SOURCES = (*FRONTEND_SOURCES, "p1_range.v", "p1_top.v")


_INCLUDE = re.compile(r'^\s*`include\s+"([^"]+)"', re.M)


def rtl_files(sources: Sequence[str]) -> tuple[Path, ...]:
    """The files of ``hdl/`` that a design of ``sources`` reads: the sources and the
    headers they `` `include`` (transitively, each once), in that order. Cache keys and
    the RTL identity hash these, so a change to another pipeline's header does not
    invalidate them."""
    files: list[Path] = []
    todo = [HDL_DIR / s for s in sources]
    while todo:
        path = todo.pop(0)
        if path in files:
            continue
        files.append(path)
        todo.extend(HDL_DIR / h for h in _INCLUDE.findall(path.read_text()))
    return tuple(files)


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


def _pole_shift(design: Mapping) -> int:
    """``POLE_K`` of the filters: ``k`` of the pole ``2^-k`` in the ``shift`` filter form,
    ``-1`` (multiply by the pole register) in the ``direct`` form."""
    if design.get("filter_form", "direct") != "shift":
        return -1
    return 1 - math.frexp(float(design["pole"]))[1]


def top_parameters(
    manifest: Mapping, rom_file: str | Path | None = None, *, with_range: bool = True
) -> dict[str, int | str]:
    """Verilog parameters of ``p1_top`` for a P1 vector directory's ``manifest``.

    ``rom_file``: the reciprocal divider's seed ROM (the directory's ``recip_rom.mem``),
    needed by the reciprocal divider. The front end's come from the manifest's parsed
    config alone; the range stage's (``with_range``) from :func:`range_parameters` of the
    config its TOML describes (the model's config type: not for the simulator process).
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
        "POLE_K": _pole_shift(design),
    }
    for signal, p in _PREFIX.items():
        spec = signals[signal]
        word, frac, signed = _format(spec["format"])
        params |= {f"{p}_W": word, f"{p}_F": frac, f"{p}_S": signed}
        if signal not in _REGISTERS:
            params |= {
                f"{p}_Q": QUANT_CODES[spec["quant"]],
                f"{p}_O": OVERFLOW_CODES[spec["overflow"]],
            }
    if rom_file is not None:
        params["ROM_FILE"] = f'"{Path(rom_file).resolve()}"'
    if with_range:
        from rangefx.rtl_model.registry import get_pipeline

        config = get_pipeline("p1").config_from_toml(manifest["config"]["toml"], "manifest")
        rom = str(Path(rom_file).resolve()) if rom_file is not None else ""
        params |= range_parameters(config, n, m, rom_file=rom)
    return params


#: Parameters of p1_top that p1_frontend does not have.
_TOP_ONLY = ("MOTION", "MAX_PIXELS", "PADDR_W")


def frontend_parameters(config: P1Config, width: int, rom_file: str | Path = "") -> dict:
    """Verilog parameters of one ``p1_frontend`` for ``config`` and lines of ``width``
    pixels (the synthesis of one stream); ``rom_file`` as in :func:`top_parameters`."""
    import tomllib

    manifest = {
        "pipeline": "p1",
        "mode": "stereo",
        "shape": [1, int(width)],
        "config": {"parsed": tomllib.loads(config.to_toml())},
    }
    params = top_parameters(manifest, rom_file or None, with_range=False)
    return {k: v for k, v in params.items() if k not in _TOP_ONLY}


def register_codes(manifest: Mapping) -> dict[str, int]:
    """Raw codes (unsigned words) of every host register port of ``p1_top`` from the
    manifest's ``registers``: ``pole_raw``, ``bias_raw`` and the range stage's."""
    out = _range_register_ports(manifest["registers"])
    for port, name in (("pole_raw", "pole"), ("bias_raw", "bias")):
        reg = manifest["registers"][name]
        word, _frac, _signed = _format(reg["format"])
        out[port] = int(reg["raw"]) & ((1 << word) - 1)
    return out


def register_port_widths(params: Mapping[str, int | str]) -> dict[str, int]:
    """Bits of every host register port of ``p1_top`` (:func:`register_codes`' ports) for
    its Verilog parameters ``params``."""
    w = {k: int(v) for k, v in params.items() if k.endswith("_W")}
    return {"pole_raw": w["POLE_W"], "bias_raw": w["BREG_W"], "cx_raw": w["CO_W"],
            "cy_raw": w["CO_W"], "f_raw": w["FR_W"], "k3_raw": w["KT_W"], "k4_raw": w["KT_W"],
            "k5_raw": w["KT_W"], "m_raw": 9 * w["KM_W"], "te_raw": w["C1_W"],
            "tg2_raw": w["TG2_W"], "dmin_raw": w["DEN_W"], "rmax_raw": w["RNG_W"]}  # fmt: skip


def config_top_parameters(
    config: P1Config, shape: tuple[int, int], mode: str = "stereo", rom_file: str | Path = ""
) -> dict[str, int | str]:
    """Verilog parameters of ``p1_top`` for ``config`` on frames of ``shape`` = (height,
    width) in ``mode`` (stereo or motion), without a vector directory (synthesis, timing);
    ``rom_file`` as in :func:`top_parameters`."""
    m, n = (int(v) for v in shape)
    params: dict[str, int | str] = {
        "MOTION": int(mode == "motion"),
        "MAX_PIXELS": m * n,
        "PADDR_W": max(1, (m * n).bit_length()),
    }
    params |= frontend_parameters(config, n, rom_file)
    return params | range_parameters(config, n, m, rom_file=str(rom_file))


def frontend_instances(manifest: Mapping) -> dict[str, str]:
    """Stream -> hierarchical name of its p1_frontend in ``p1_top``: stereo ``e1`` on
    ``fe0`` and ``e2`` on ``g_stereo.fe1``; motion both frames on ``fe0``."""
    if manifest["mode"] == "motion":
        return {"e1+e2": "fe0"}
    return {"e1": "fe0", "e2": "g_stereo.fe1"}


def bench_header(
    manifest: Mapping, rom_file: str | Path | None, lead: int, overrides: Mapping[str, int] = {}
) -> str:
    """``bench.vh`` of the plain Verilog bench ``hdl/tb_top.v`` for a P1 vector directory:
    the design's parameters, the register codes, the sizes, and the statements that dump
    every front-end tap in its stage's valid cycles and the overflow counters
    (``overrides`` replace parameters, as a mutation test does)."""
    params = top_parameters(manifest, rom_file) | dict(overrides)
    regs = register_codes(manifest)
    depth = max(int(e["count"]) for e in stream_entries(manifest))
    out_w = int(params["RNG_W"]) + 1
    taps, counts = [], []
    for k, inst in enumerate(frontend_instances(manifest).values()):
        for tap, (port, valid) in FRONTEND_TAPS.items():
            if tap == "col2_state" and not params["CONSISTENT"]:
                continue
            taps.append(f'if (dut.{inst}.{valid}) $fwrite(fd, "T {k} {tap} %0d %h\\n", '
                        f"cycle, dut.{inst}.{port});")  # fmt: skip
        for signal in OVERFLOW_SIGNALS:
            counts.append(f'$fwrite(fd, "O {k} {signal} %0d\\n", dut.{inst}.ovf_{signal});')
    for ovf, (vport, names) in RANGE_TAP_GROUPS.items():
        for tap in names:
            taps.append(f'if (dut.u_range.{vport}) $fwrite(fd, "T R {tap} %0d %h\\n", '
                        f"cycle, dut.u_range.{tap});")  # fmt: skip
        if ovf:
            taps.append(f'if (dut.u_range.{vport}) $fwrite(fd, "G {ovf} %h\\n", '
                        f"dut.u_range.{ovf});")  # fmt: skip
    widths = register_port_widths(params)
    ports = ", ".join(f".{p}({w}'h{regs[p]:x})" for p, w in widths.items())
    latency = int(manifest["latency"]["total"])
    flags = ("line_too_long", "align_error", "frame_too_big")
    return _tb_header(TOPLEVEL, params, params["PIX_W"], out_w, depth, depth + latency + 8, lead,
                      ports, taps, counts, flags)  # fmt: skip


def _tb_header(
    top: str, params: Mapping, pix_w: int | str, out_w: int, depth: int, cycles: int,
    lead: int, ports: str, taps: Sequence[str], counts: Sequence[str], flags: Sequence[str],
) -> str:  # fmt: skip
    """``bench.vh`` of the plain Verilog bench ``hdl/tb_top.v``: the top and its parameters,
    the sizes, the register ports, the tap and counter dump statements, the three flags."""
    flag_ports = ", ".join(f".{f}(flag[{k}])" for k, f in enumerate(flags))
    flag_lines = " ".join(f'$fwrite(fd, "F {f} %0d\\n", flag[{k}]);' for k, f in enumerate(flags))
    body = [
        f"// generated by rangefx (rangefx.vectors.hdl) from a vector directory: {top}",
        f"`define TB_TOP {top}",
        "`define TB_PARAMS " + ", ".join(f".{k}({v})" for k, v in params.items()),
        f"`define TB_PIX_W {pix_w}",
        f"`define TB_OUT_W {out_w}",
        f"`define TB_STREAM_DEPTH {depth}",
        f"`define TB_CYCLES {cycles}",
        f"`define TB_LEAD {int(lead)}",
        f"`define TB_REGISTERS {ports}",
        f"`define TB_FLAG_PORTS {flag_ports}",
        "`define TB_TAPS " + " ".join(taps),
        "`define TB_COUNTS " + " ".join(counts),
        f"`define TB_FLAGS {flag_lines}",
    ]
    return "\n".join(body) + "\n"


Samples = Mapping[str, Sequence[tuple[int, int | None]]]
#: One AXI4-Stream output beat: (cycle, TDATA or None for x/z bits, TUSER, TLAST).
Beat = tuple[int, int | None, int, int]


def stream_entries(manifest: Mapping) -> list[dict]:
    """The input streams' ``.stream.mem`` entries, in the order of the DUT's inputs s0,
    s1: the stimulus both simulators read (``$readmemh`` text, one word per cycle)."""
    entries = [e for e in manifest["files"] if e["kind"] == "stream" and e["path"].endswith(".mem")]
    return sorted(entries, key=lambda e: e["tap"])


def read_stream_mem(path: Path, word: int) -> dict[str, np.ndarray]:
    """A ``.stream.mem`` file's words {sof, eol, valid, data} as arrays ``valid``,
    ``data`` (unsigned codes), ``sof``, ``eol``, one per cycle.

    Raises
    ------
    ValueError
        The file is unreadable or holds a word that is not hexadecimal (named).
    """
    try:
        words = read_mem(Path(path).read_bytes())
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror}") from None
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    if any(w is None for w in words):
        raise ValueError(f"{path}: holds x/z words")
    w = np.array(words, dtype=np.int64)
    return {"valid": (w >> word) & 1, "data": w & ((1 << word) - 1),
            "sof": (w >> (word + 2)) & 1, "eol": (w >> (word + 1)) & 1}  # fmt: skip


def write_dump(
    dump: Path,
    vec: Path,
    manifest: Mapping,
    samples: Samples,
    inputs: Sequence[int],
    beats: Sequence[Beat],
    overflows: Mapping[str, int | None],
    flags: Mapping[str, int | None],
    cycles: int,
) -> None:
    """Write a bench's observations on the vectors ``vec`` as the dump that
    :func:`rangefx.vectors.replay.compare` reads.

    ``samples``: ``"<stream>.<tap>"`` -> (cycle, code or None for x/z) per sample, the
    stream being ``e1``, ``e2`` or, in motion mode, ``e1+e2`` (frame 1 is E1, frame 2 E2);
    a range-stage tap has no prefix;
    ``inputs``: the cycle of every beat of the first input stream, in the bench's count;
    its offset from the stream file's first beat is taken off every cycle, and every
    beat must then be in its file's cycle (else ``AssertionError``). ``beats``: the
    AXI4-Stream output, one :data:`Beat` per output beat. ``overflows`` and ``flags``:
    ``None`` where the RTL gave x/z bits (stored as -1: a mismatch). Files:
    ``<tap>.mem``, ``taps.npz`` (``<tap>.value``, ``<tap>.cycle``), ``m_axis.npz``
    (``words`` as decimal text, -1 for x/z; ``cycles``; ``line_lengths``; ``first_tuser``),
    ``status.json``.
    """
    m, n = manifest["shape"]
    first = stream_entries(manifest)[0]
    expected = _valid_cycles(vec, first)
    got = np.asarray(inputs, dtype=np.int64)
    offset = int(got[0] - expected[0]) if got.size else 0
    if not np.array_equal(got - offset, expected):
        k = min(got.size, expected.size)
        diff = np.flatnonzero(got[:k] - offset != expected[:k])
        at = int(diff[0]) if diff.size else k
        if diff.size:
            what = f"beat {at} in cycle {int(got[at] - offset)}, the file's in {expected[at]}"
        else:
            what = f"beats from {k} on missing or extra"
        raise AssertionError(
            f"the bench did not reproduce the timing of {first['path']}: {got.size} beats "
            f"against the file's {expected.size}; first difference: {what}"
        )
    words = {e["tap"]: int(e["word"]) for e in manifest["files"]}
    arrays = {}
    for name, rows in samples.items():
        stream, _, base = name.rpartition(".")
        if stream == "e1+e2":
            parts = {"e1.": rows[: m * n], "e2.": rows[m * n :]}
        else:
            parts = {f"{stream}." if stream else "": rows}  # "": a range-stage tap
        for prefix, rs in parts.items():
            tap = f"{prefix}{base}"
            arrays[f"{tap}.cycle"] = np.array([c for c, _v in rs], dtype=np.int64) - offset
            arrays[f"{tap}.value"] = np.array([-1 if v is None else v for _c, v in rs], np.int64)
            (dump / f"{tap}.mem").write_text(_mem_text(tap, rs, words.get(tap, 64)))
    np.savez(dump / "taps.npz", **arrays)
    lines, current = [], []
    for beat in beats:
        current.append(beat)
        if beat[3]:
            lines.append(current)
            current = []
    if current:
        lines.append(current)  # a last line without TLAST
    np.savez(
        dump / "m_axis.npz",
        words=np.array([str(-1 if w is None else w) for _c, w, _u, _l in beats]),  # > 64 bits
        cycles=np.array([c for c, _w, _u, _l in beats], dtype=np.int64) - offset,
        line_lengths=np.array([len(line) for line in lines], dtype=np.int64),
        first_tuser=np.array([line[0][2] for line in lines], dtype=np.int64),
    )

    def known(v: int | None) -> int:
        return -1 if v is None else int(v)

    status = {"overflows": {k: known(v) for k, v in overflows.items()},
              **{k: known(v) for k, v in flags.items()}, "cycles": int(cycles),
              "input_beats": int(got.size), "stream_offset": offset}  # fmt: skip
    (dump / "status.json").write_text(json.dumps(status, indent=1) + "\n")


def _valid_cycles(vec: Path, entry: Mapping) -> np.ndarray:
    """Cycles of the valid beats of a vector directory's stream file (``.stream.mem``)."""
    valid = read_stream_mem(vec / entry["path"], int(entry["word"]))["valid"]
    return np.flatnonzero(valid).astype(np.int64)


def _mem_text(tap: str, rows: Sequence[tuple[int, int | None]], word: int) -> str:
    """``$readmemh`` dump of a tap (``x`` words where the DUT gave x/z bits)."""
    known = np.array([0 if v is None else v for _c, v in rows], dtype=np.int64)
    lines = write_mem(known, word, f"{tap}: RTL dump, {len(rows)} samples").decode().splitlines()
    for k, (_c, v) in enumerate(rows):
        if v is None:
            lines[k + 1] = "x" * ((word + 3) // 4)
    return "\n".join(lines) + "\n"


# -- the range stage (hdl/p1_range.v) ---------------------------------------------------
RANGE_SOURCES = ("fx_cast_sized.v", "fx_pipe.v", "fx_divide.v", "p1_range.v")

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


def range_registers(config: P1Config, registers: Mapping) -> dict[str, int]:
    """Port values (unsigned words) of ``p1_range``'s host registers from a manifest's
    ``registers`` (name -> ``{"signal", "format", "raw", ...}``: the raw codes the model
    used, in the formats of ``config``, which the entries carry)."""
    return _range_register_ports(registers)


def _range_register_ports(registers: Mapping) -> dict[str, int]:
    out = {}
    for port, names in RANGE_REGISTER_PORTS.items():
        value = 0
        for k, name in enumerate(names):
            reg = registers[name]
            word = _format(reg["format"])[0]
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


# -- P2 (hdl/p2_top.v) -------------------------------------------------------------------
P2_SOURCES = ("fx_cast_sized.v", "fx_pipe.v", "fx_divide.v", "p2_top.v")
P2_TOPLEVEL = "p2_top"

#: Verilog parameter prefix of each P2 signal (``hdl/p2_params.vh``).
P2_PREFIX = {
    "p2_pix": "PIX", "p2_d": "D", "p2_ghat": "G", "p2_ka_reg": "KA", "p2_a": "A", "p2_c": "C",
    "p2_m_reg": "MR", "p2_st": "ST", "p2_den": "DEN", "p2_r": "R", "p2_h": "H", "p2_q": "Q",
    "p2_w": "W", "p2_lam": "LAM", "p2_z": "Z", "p2_e": "E",
}  # fmt: skip

#: Tap -> (register of ``p2_top``, its valid strobe): every tap is one register's output.
P2_TAP_PORTS: Mapping[str, tuple[str, str]] = {
    "d": ("d2", "v2"),
    "g_hat": ("g2", "v2"),
    "a": ("wb_a", "wb_v"),
    "c": ("wb_c", "wb_v"),
    "den": ("wb_den", "wb_v"),
    "r": ("wb_r", "wb_v"),
    "s": ("s_wb", "wb_v"),
    "h": ("wb_h", "wb_v"),
    "q": ("q_wb", "wb_v"),
    "e": ("e_op", "tap_e_v"),
    "w": ("w6", "tap_w_v"),
    "lam": ("lam_f", "tap_lam_v"),
    "z": ("z_f", "tap_z_v"),
    "valid": ("m_axis_tdata[Z_W]", "m_axis_tvalid"),
    "range": ("m_axis_tdata[Z_W-1:0]", "m_axis_tvalid"),
}

#: Overflow counter of ``p2_top`` -> the signal it counts.
P2_OVERFLOW_PORTS = {f"ovf_{s.removeprefix('p2_')}": s
                     for s in P2_PREFIX if s not in ("p2_ka_reg", "p2_m_reg")}  # fmt: skip

#: Host register port of ``p2_top`` -> the manifest's register name.
P2_REGISTER_PORTS = {"ka_raw": "KA", "m_raw": "M", "cmin_raw": "c_min", "send_raw": "S_end",
                     "td_raw": "T_D", "rmax_raw": "range_max"}  # fmt: skip

#: The flags ``p2_top`` raises (sticky).
P2_FLAGS = ("line_too_long", "align_error", "overrun")


def p2_parameters(manifest: Mapping, rom_file: str | Path | None = None) -> dict[str, int | str]:
    """Verilog parameters of ``p2_top`` for a P2 vector directory's ``manifest``: the
    frame size, the lanes, the divider and its latency (``rtl_model/p2/config.py
    divider_latency_p2``, the one place the model reads it from) and every signal's format
    and modes."""
    from rangefx.rtl_model.p2.config import default_lanes, divider_latency_p2

    if manifest.get("pipeline") != "p2":
        raise ValueError(f"p2_top implements P2, not {manifest.get('pipeline')!r}")
    parsed = manifest["config"]["parsed"]
    design, signals = parsed["design"], parsed["signals"]
    m, n = manifest["shape"]
    r_word = _format(signals["p2_r"]["format"])[0]
    t_div = divider_latency_p2(design["divider"], r_word)
    lanes = int(design.get("lanes", 0)) or default_lanes(design["divider"], r_word)
    params: dict[str, int | str] = {
        "WIDTH": int(n), "HEIGHT": int(m), "LANES": lanes, "T_DIV": t_div,
        "DIVIDER": int(design["divider"] == "reciprocal"),
        "RECIP_L": int(design["recip_lut_bits"]), "RECIP_R": int(design["recip_bits"]),
    }  # fmt: skip
    for signal, p in P2_PREFIX.items():
        spec = signals[signal]
        word, frac, signed = _format(spec["format"])
        params |= {f"{p}_W": word, f"{p}_F": frac, f"{p}_S": signed,
                   f"{p}_Q": QUANT_CODES[spec.get("quant", "TRN")],
                   f"{p}_O": OVERFLOW_CODES[spec.get("overflow", "WRAP")]}  # fmt: skip
    if rom_file is not None:
        params["ROM_FILE"] = f'"{Path(rom_file).resolve()}"'
    return params


def p2_register_codes(manifest: Mapping, params: Mapping[str, int | str]) -> dict[str, tuple]:
    """Port -> (bits, unsigned code) of every host register of ``p2_top`` from the
    manifest's ``registers`` (``T_D`` is compared with |d_k + d_k+1|: two bits wider
    than ``p2_d``)."""
    widths = {"ka_raw": params["KA_W"], "m_raw": params["MR_W"], "cmin_raw": params["C_W"],
              "send_raw": params["ST_W"], "td_raw": int(params["D_W"]) + 2,
              "rmax_raw": params["Z_W"]}  # fmt: skip
    regs = manifest["registers"]
    return {port: (int(widths[port]), int(regs[name]["raw"]) & ((1 << int(widths[port])) - 1))
            for port, name in P2_REGISTER_PORTS.items()}  # fmt: skip


def p2_bench_header(
    manifest: Mapping, rom_file: str | Path | None, lead: int, overrides: Mapping[str, int] = {}
) -> str:
    """``bench.vh`` of the plain Verilog bench ``hdl/tb_top.v`` for a P2 vector directory
    (``overrides`` replace parameters)."""
    params = p2_parameters(manifest, rom_file) | dict(overrides)
    regs = p2_register_codes(manifest, params)
    depth = max(int(e["count"]) for e in stream_entries(manifest))
    taps = [f'if (dut.{valid}) $fwrite(fd, "T R {tap} %0d %h\\n", cycle, dut.{port});'
            for tap, (port, valid) in P2_TAP_PORTS.items()]  # fmt: skip
    taps = [t.replace("[Z_W]", f"[{params['Z_W']}]").replace("[Z_W-1:0]",
            f"[{int(params['Z_W']) - 1}:0]") for t in taps]  # fmt: skip
    counts = [f'$fwrite(fd, "O R {sig} %0d\\n", dut.{port});'
              for port, sig in P2_OVERFLOW_PORTS.items()]  # fmt: skip
    ports = ", ".join(f".{p}({w}'h{v:x})" for p, (w, v) in regs.items())
    cycles = int(manifest["total_cycles"]) + 16
    return _tb_header(P2_TOPLEVEL, params, params["PIX_W"], int(params["Z_W"]) + 1, depth,
                      cycles, lead, ports, taps, counts, P2_FLAGS)  # fmt: skip


def p2_config_parameters(config, shape: tuple[int, int], rom_file: str = "recip_rom.mem") -> dict:
    """Verilog parameters of ``p2_top`` for a :class:`~rangefx.rtl_model.p2.config.P2Config`
    and frames of ``shape`` = (height, width), without a vector directory (synthesis,
    timing); ``rom_file`` as the reciprocal divider reads it."""
    import tomllib

    m, n = (int(v) for v in shape)
    manifest = {"pipeline": "p2", "shape": [m, n],
                "config": {"parsed": tomllib.loads(config.to_toml())}}  # fmt: skip
    params = p2_parameters(manifest, None)
    params["ROM_FILE"] = f'"{rom_file}"'
    return params


def p2_timing_wrapper(params: Mapping[str, int | str]) -> tuple[str, int]:
    """Verilog of ``p2_timing_top``: ``p2_top`` with ``params``, its host registers loaded
    through one serial chain (``reg_sdi`` shifted while ``reg_shift``, as P1's timing
    wrapper) and its overflow counters (probes) unconnected; returns ``(text, pins)``."""
    widths = {"ka_raw": params["KA_W"], "m_raw": params["MR_W"], "cmin_raw": params["C_W"],
              "send_raw": params["ST_W"], "td_raw": int(params["D_W"]) + 2,
              "rmax_raw": params["Z_W"]}  # fmt: skip
    chain, lo, slices = sum(int(w) for w in widths.values()), 0, []
    for port, w in widths.items():
        slices.append(f".{port}(chain[{lo + int(w) - 1}:{lo}])")
        lo += int(w)
    plist = ", ".join(f".{k}({v})" for k, v in params.items())
    pix, out = int(params["PIX_W"]), int(params["Z_W"]) + 1
    probes = ", ".join(f".{p}()" for p in P2_OVERFLOW_PORTS)
    text = f"""// generated by rangefx.vectors.hdl.p2_timing_wrapper: p2_top with its host registers
// loaded through a serial chain, its overflow counters unconnected, for place and route
`timescale 1ns / 1ps
module p2_timing_top (
    input wire clk, input wire rst, input wire reg_sdi, input wire reg_shift,
    input wire s0_axis_tvalid, input wire [{pix - 1}:0] s0_axis_tdata,
    input wire s0_axis_tuser, input wire s0_axis_tlast,
    input wire s1_axis_tvalid, input wire [{pix - 1}:0] s1_axis_tdata,
    input wire s1_axis_tuser, input wire s1_axis_tlast,
    output wire m_axis_tvalid, output wire [{out - 1}:0] m_axis_tdata,
    output wire m_axis_tuser, output wire m_axis_tlast,
    output wire align_error, output wire line_too_long, output wire overrun);
    reg [{chain - 1}:0] chain;
    always @(posedge clk) if (reg_shift) chain <= {{chain[{chain - 2}:0], reg_sdi}};
    p2_top #({plist}) dut (
        .clk(clk), .rst(rst), {", ".join(slices)},
        .s0_axis_tvalid(s0_axis_tvalid), .s0_axis_tdata(s0_axis_tdata),
        .s0_axis_tuser(s0_axis_tuser), .s0_axis_tlast(s0_axis_tlast),
        .s1_axis_tvalid(s1_axis_tvalid), .s1_axis_tdata(s1_axis_tdata),
        .s1_axis_tuser(s1_axis_tuser), .s1_axis_tlast(s1_axis_tlast),
        .m_axis_tvalid(m_axis_tvalid), .m_axis_tdata(m_axis_tdata),
        .m_axis_tuser(m_axis_tuser), .m_axis_tlast(m_axis_tlast),
        .align_error(align_error), .line_too_long(line_too_long), .overrun(overrun),
        {probes});
endmodule
"""
    pins = 4 + 2 * (pix + 3) + out + 3 + 3
    return text, pins
