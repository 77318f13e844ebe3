"""Synthesis area of the P1 RTL with Yosys (issues 15, 35; ``rangefx hdl synth``,
``--cost synth``).

The headline is the whole ``hdl/p1_top.v`` synthesised flat (:func:`synth_top`) with the
formats of a word-length config as Verilog parameters
(:func:`rangefx.vectors.hdl.config_top_parameters`): the design without its probes. The
taps and the 32-bit overflow counters of ``p1_frontend``/``p1_range`` are ports that
``p1_top`` leaves unconnected, so flattening removes the counters and every tap register
the datapath does not read. The probes' cost is reported apart: the same top synthesised
again with every output port of every module kept (Yosys ``keep`` on ``*/o:*`` before
flattening), minus the headline. The stages are the breakdown (:func:`synth_stage`):
``frontend`` (``p1_frontend.v``, one stream: input cast, bias, row and column filter, the
x-derivative of the config's variant with its divider or second column filter) and
``range`` (``p1_range.v``, the range stage with its divider and thresholds), each
synthesised alone with its probes as outputs. Each run is ``synth_xilinx -family
xc7|xcup``, ``synth_ecp5`` or ``synth_ice40 -dsp`` with ``-flatten``, then ``stat
-json``; the cell counts are mapped to LUT, FF, carry, DSP and BRAM (:data:`TARGETS`).

Results are cached per design: the key is the SHA-256 of the stage (or ``top`` with or
without probes), the target, its parameters, the Verilog sources and the Yosys version,
under ``$RANGEFX_CACHE/synth`` (default ``~/.cache/rangefx/synth``).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path

from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.p1.pipeline import FRONTEND_SIGNALS
from rangefx.rtl_model.registry import get_pipeline
from rangefx.vectors.hdl import (
    FRONTEND_SOURCES,
    HDL_DIR,
    HDL_SOURCES,
    P2_OVERFLOW_PORTS,
    P2_SOURCES,
    RANGE_SOURCES,
    TOPLEVEL,
    config_top_parameters,
    frontend_parameters,
    p2_config_parameters,
    range_parameters,
    rtl_files,
    write_recip_rom,
)

from ..errors import UserError

__all__ = [
    "AREA_KEYS",
    "RTL_TOPS",
    "STAGES",
    "STAGE_SIGNALS",
    "TARGETS",
    "RtlTop",
    "SynthArea",
    "area_from_cells",
    "cache_dir",
    "proxy_area",
    "proxy_ratios",
    "rtl_top",
    "synth_p1",
    "synth_p2",
    "synth_pipeline",
    "synth_pipeline_top",
    "synth_record",
    "synth_stage",
    "synth_top",
    "yosys_version",
]

#: Stages of P1 that ``hdl/`` implements, and their top modules and sources.
STAGES: dict[str, tuple[str, tuple[str, ...]]] = {
    "frontend": ("p1_frontend", FRONTEND_SOURCES),
    "range": ("p1_range", RANGE_SOURCES),
}
#: The whole top, without (``top``) and with (``top+probes``) its probes.
_TOPS: dict[str, tuple[str, tuple[str, ...]]] = {
    "top": (TOPLEVEL, HDL_SOURCES),
    "top+probes": (TOPLEVEL, HDL_SOURCES),
    "p2_top": ("p2_top", P2_SOURCES),
    "p2_top+probes": ("p2_top", P2_SOURCES),
}


@dataclass(frozen=True)
class RtlTop:
    """One pipeline's whole top in ``hdl/`` as synthesis and timing see it: the top
    ``module`` and its ``sources``; ``parameters(config, shape, mode)``, its Verilog
    parameters for a word-length config (the reciprocal ROM named ``recip_rom.mem`` in the
    work directory, so no path enters a cache key); ``probe_ports``, the Yosys selection of
    the top's own ports that are probes (overflow counters), turned into internal wires
    for the headline so that Yosys removes what drives them; ``stage``, the synthesis
    cache's name of the headline (``stage + "+probes"``: with the probes kept); and
    ``modes``, the modes the top implements; ``stages``, the parts synthesised alone as
    its breakdown (:data:`STAGES`; none for P2)."""

    pipeline: str
    module: str
    sources: tuple[str, ...]
    parameters: Callable[[object, tuple[int, int], str], dict]
    stage: str
    probe_ports: str = ""
    modes: tuple[str, ...] = ("stereo", "motion")
    stages: tuple[str, ...] = ()


def _p1_top_parameters(config: P1Config, shape: tuple[int, int], mode: str) -> dict:
    params = config_top_parameters(config, shape, mode, "recip_rom.mem")
    if config.divider == "reciprocal":
        params["ROM_FILE"] = '"recip_rom.mem"'  # in the work directory: no path in the key
    return params


def _p2_top_parameters(config, shape: tuple[int, int], mode: str) -> dict:
    return p2_config_parameters(config, shape, "recip_rom.mem")


#: The pipelines with RTL in ``hdl/``; a pipeline not here has none (:func:`rtl_top`).
RTL_TOPS: dict[str, RtlTop] = {
    "p1": RtlTop("p1", TOPLEVEL, HDL_SOURCES, _p1_top_parameters, "top", stages=tuple(STAGES)),
    # p2_top has the counters as its own ports (the bench reads them): they are dropped
    "p2": RtlTop("p2", "p2_top", P2_SOURCES, _p2_top_parameters, "p2_top",
                 " ".join(f"p2_top/{p}" for p in P2_OVERFLOW_PORTS), ("stereo",)),
}  # fmt: skip


def rtl_top(pipeline: str) -> RtlTop:
    """The :class:`RtlTop` of ``pipeline``; :class:`UserError` (one line) if it has no RTL."""
    if pipeline not in RTL_TOPS:
        raise UserError(f"pipeline {pipeline} has no RTL in hdl/ (only "
                        f"{', '.join(RTL_TOPS)}): nothing to synthesise or time")  # fmt: skip
    return RTL_TOPS[pipeline]


@dataclass(frozen=True)
class Target:
    """A Yosys synthesis flow and how its cells count: cell-name prefixes of each class;
    ``bram_weight`` gives each block RAM cell's size in 18 Kbit units (a RAMB36 is 2)."""

    command: str
    lut: tuple[str, ...]
    ff: tuple[str, ...]
    carry: tuple[str, ...]
    dsp: tuple[str, ...]
    bram_weight: Mapping[str, int]
    #: inverters, shift registers, LUT RAM: cell -> the LUTs it occupies
    lut_like: Mapping[str, int] = field(default_factory=dict)
    #: Yosys commands run after ``hierarchy``, before the synthesis command
    prepare: str = ""


_XILINX_FF = ("FDRE", "FDSE", "FDCE", "FDPE")
# a RAM32M/RAM64M/RAM128X1D fills the four LUTs of a SLICEM, a RAM32X1D/RAM64X1D two
_XILINX_LUTLIKE = {"INV": 1, "SRL16E": 1, "SRLC32E": 1, "RAM32M": 4, "RAM64M": 4,
                   "RAM32X1D": 2, "RAM64X1D": 2, "RAM128X1D": 4}  # fmt: skip
TARGETS: dict[str, Target] = {
    "xc7": Target(
        "synth_xilinx -family xc7 -flatten",
        ("LUT",),
        _XILINX_FF,
        ("CARRY4",),
        ("DSP48E1",),
        {"RAMB18E1": 1, "RAMB36E1": 2},
        _XILINX_LUTLIKE,
    ),
    "xcup": Target(
        "synth_xilinx -family xcup -flatten",
        ("LUT",),
        _XILINX_FF,
        ("CARRY4", "CARRY8"),
        ("DSP48E2",),
        {"RAMB18E2": 1, "RAMB36E2": 2},
        _XILINX_LUTLIKE,
    ),
    "ecp5": Target(
        "synth_ecp5 -flatten",
        ("LUT4",),
        ("TRELLIS_FF",),
        ("CCU2C",),
        ("MULT18X18D",),
        {"DP16KD": 1},
        {"TRELLIS_DPR16X4": 1},
    ),
    "ice40": Target(
        "synth_ice40 -dsp -flatten",
        ("SB_LUT4",),
        ("SB_DFF",),
        ("SB_CARRY",),
        ("SB_MAC16",),
        {"SB_RAM40_4K": 1},
        # no LUT RAM on iCE40: the delay lines' ram_style "distributed" would leave Yosys
        # no mapping for them; without it they go to RAM40 blocks or flip-flops
        prepare="setattr -unset ram_style m:*",
    ),
}
#: Keys of an area, in report order.
AREA_KEYS = ("lut", "ff", "carry", "dsp", "bram")


@dataclass(frozen=True)
class SynthArea:
    """Cell counts of one synthesised design: LUTs (inverters, which the vendor tools
    place as LUT1, shift registers and LUT RAM included), flip-flops, carry cells, DSP
    blocks, block RAM (18 Kbit units on Xilinx, the target's block otherwise) and every
    cell type's count."""

    lut: int = 0
    ff: int = 0
    carry: int = 0
    dsp: int = 0
    bram: int = 0
    cells: dict[str, int] = field(default_factory=dict)

    def __add__(self, other: SynthArea) -> SynthArea:
        cells = dict(self.cells)
        for k, v in other.cells.items():
            cells[k] = cells.get(k, 0) + v
        return SynthArea(*(getattr(self, k) + getattr(other, k) for k in AREA_KEYS), cells)

    def times(self, k: int) -> SynthArea:
        return SynthArea(*(getattr(self, a) * k for a in AREA_KEYS),
                         {c: v * k for c, v in self.cells.items()})  # fmt: skip

    def as_dict(self) -> dict:
        return asdict(self)


def area_from_cells(cells: Mapping[str, int], target: str) -> SynthArea:
    """Map Yosys cell counts (``stat -json`` ``num_cells_by_type``) to a :class:`SynthArea`."""
    t = TARGETS[target]

    def count(prefixes: tuple[str, ...]) -> int:
        return sum(v for c, v in cells.items() if c.startswith(prefixes)) if prefixes else 0

    bram = sum(v * t.bram_weight[c] for c, v in cells.items() if c in t.bram_weight)
    return SynthArea(
        lut=count(t.lut) + sum(v * t.lut_like.get(c, 0) for c, v in cells.items()),
        ff=count(t.ff),
        carry=count(t.carry),
        dsp=count(t.dsp),
        bram=bram,
        cells=dict(sorted(cells.items())),
    )


def yosys_version() -> str:
    """``yosys -V`` of the Yosys on PATH; :class:`UserError` if there is none."""
    exe = shutil.which("yosys")
    if exe is None:
        raise UserError("yosys is not installed (apt-get install yosys); `hdl synth` and "
                        "`--cost synth` run it")  # fmt: skip
    out = subprocess.run([exe, "-V"], capture_output=True, text=True, check=False)
    return out.stdout.strip()


def cache_dir() -> Path:
    """``$RANGEFX_CACHE/synth``, else ``$XDG_CACHE_HOME/rangefx/synth``, else
    ``~/.cache/rangefx/synth``."""
    if os.environ.get("RANGEFX_CACHE"):
        return Path(os.environ["RANGEFX_CACHE"]) / "synth"
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "rangefx" / "synth"


def stage_parameters(config: P1Config, stage: str, shape: tuple[int, int]) -> dict:
    """Verilog parameters of one stage for ``config`` on ``shape`` = (height, width) frames
    (the reciprocal ROM file name is left as a placeholder: its content is a function of
    ``RECIP_L``/``RECIP_R``, which are parameters)."""
    m, n = shape
    if stage == "frontend":
        return frontend_parameters(config, n) | {"ROM_FILE": '"recip_rom.mem"'}
    if stage == "range":
        return range_parameters(config, n, m, rom_file="recip_rom.mem")
    raise ValueError(f"unknown stage {stage!r}; choose from {', '.join(STAGES)}")


def _key(stage: str, target: str, params: Mapping, version: str) -> str:
    h = hashlib.sha256()
    _top, sources = (STAGES | _TOPS)[stage]
    t = TARGETS[target]
    command = t.command + (f"; {t.prepare}" if t.prepare else "")  # other targets' keys kept
    h.update(json.dumps([stage, target, command, sorted(params.items()), version]).encode())
    for path in rtl_files(sources):  # the sources and the headers they include
        h.update(path.read_bytes())
    return h.hexdigest()[:32]


def _verilog_constant(value: object) -> str:
    """A parameter value as ``chparam`` reads it: a negative integer as a signed 32-bit
    literal (``chparam`` cannot decode ``-4``), strings as they are (quoted)."""
    if isinstance(value, int) and value < 0:
        return f"32'sh{value & 0xFFFFFFFF:08X}"
    return str(value)


def _yosys_script(
    top: str,
    sources: tuple[str, ...],
    params: Mapping,
    target: str,
    keep_probes: bool = False,
    drop_ports: str = "",
) -> str:
    lines = [f"read_verilog -defer -I{HDL_DIR} " + " ".join(str(HDL_DIR / s) for s in sources)]
    sets = " ".join(f"-set {k} {_verilog_constant(v)}" for k, v in params.items())
    lines += [f"chparam {sets} {top}", f"hierarchy -top {top}"]
    if keep_probes:  # every module's outputs (taps, overflow counters) survive flattening
        lines.append("setattr -set keep 1 */o:*")
    if drop_ports:  # the top's probe ports become wires: Yosys removes what drives them
        lines.append(f"delete -port {drop_ports}")
    if TARGETS[target].prepare:
        lines.append(TARGETS[target].prepare)
    lines += [TARGETS[target].command, "tee -q -o stat.json stat -json"]
    return "\n".join(lines) + "\n"


def synth_stage(
    config: P1Config,
    stage: str,
    target: str = "xcup",
    shape: tuple[int, int] = (512, 512),
    *,
    use_cache: bool = True,
    timeout_s: float = 3600.0,
) -> tuple[SynthArea, bool]:
    """Yosys area of one stage; returns ``(area, from_cache)``.

    Raises
    ------
    UserError
        Yosys is missing, or fails on the design (its last lines are in the message).
    """
    return _synthesise(config, stage, target, stage_parameters(config, stage, shape),
                       use_cache=use_cache, timeout_s=timeout_s)  # fmt: skip


def synth_pipeline_top(
    pipeline: str,
    config,
    target: str = "xcup",
    shape: tuple[int, int] = (512, 512),
    mode: str = "stereo",
    *,
    probes: bool = False,
    use_cache: bool = True,
    timeout_s: float = 3600.0,
) -> tuple[SynthArea, bool]:
    """Yosys area of ``pipeline``'s whole top (:data:`RTL_TOPS`) synthesised flat for
    ``config`` on ``shape`` frames; returns ``(area, from_cache)``. ``probes`` False: the
    design without its taps and overflow counters; True: with every module's outputs
    kept. :class:`UserError` for a pipeline without RTL or a mode its top lacks."""
    rtl = rtl_top(pipeline)
    if mode not in rtl.modes:
        raise UserError(f"{pipeline} has no {mode} mode in hdl/ (it has {', '.join(rtl.modes)})")
    params = rtl.parameters(config, shape, mode)
    stage = rtl.stage + "+probes" if probes else rtl.stage
    return _synthesise(config, stage, target, params, use_cache=use_cache, timeout_s=timeout_s,
                       drop_ports="" if probes else rtl.probe_ports)  # fmt: skip


#: Yosys area of the whole ``p1_top`` synthesised flat, :func:`synth_pipeline_top` of P1:
#: ``synth_top(config, target, shape, mode, *, probes=False, use_cache=True, timeout_s)``.
synth_top = functools.partial(synth_pipeline_top, "p1")


def _synthesise(
    config: P1Config, stage: str, target: str, params: Mapping, *, use_cache: bool,
    timeout_s: float, drop_ports: str = "",
) -> tuple[SynthArea, bool]:  # fmt: skip
    if target not in TARGETS:
        raise UserError(f"unknown synthesis target {target!r}; choose from {', '.join(TARGETS)}")
    version = yosys_version()
    key = _key(
        stage, target, dict(params) | ({"drop_ports": drop_ports} if drop_ports else {}), version
    )
    cached = cache_dir() / f"{stage}-{target}-{key}.json"
    if use_cache and cached.is_file():
        try:
            data = json.loads(cached.read_text())
            return area_from_cells(data["cells"], target), True
        except (OSError, ValueError, KeyError):
            pass  # a damaged cache entry: synthesise again
    top, sources = (STAGES | _TOPS)[stage]
    with tempfile.TemporaryDirectory(prefix="rangefx-synth-") as tmp:
        work = Path(tmp)
        if config.divider == "reciprocal":
            write_recip_rom(config, work / "recip_rom.mem")
        keep = stage.endswith("+probes")
        script = _yosys_script(top, sources, params, target, keep, drop_ports)
        (work / "synth.ys").write_text(script)
        try:
            run = subprocess.run(["yosys", "-q", "-s", "synth.ys"], cwd=work, capture_output=True,
                                 text=True, timeout=timeout_s, check=False)  # fmt: skip
        except subprocess.TimeoutExpired:
            raise UserError(f"yosys took over {timeout_s:.0f} s on {stage}") from None
        if run.returncode != 0 or not (work / "stat.json").is_file():
            tail = " | ".join((run.stderr or run.stdout).strip().splitlines()[-3:])
            raise UserError(f"yosys failed on {stage} ({target}): {tail}")
        stat = json.loads((work / "stat.json").read_text())
    modules = stat.get("modules", {})
    top_stat = modules.get(f"\\{top}") or next(iter(modules.values()))
    cells = {str(k).lstrip("\\$"): int(v) for k, v in top_stat["num_cells_by_type"].items()}
    cached.parent.mkdir(parents=True, exist_ok=True)
    tmp_file = cached.with_suffix(".tmp")
    tmp_file.write_text(json.dumps({"stage": stage, "target": target, "params": dict(params),
                                    "yosys": version, "cells": cells}, indent=1))  # fmt: skip
    tmp_file.replace(cached)
    return area_from_cells(cells, target), False


def synth_p1(
    config: P1Config,
    target: str = "xcup",
    shape: tuple[int, int] = (512, 512),
    mode: str = "stereo",
    parts: tuple[str, ...] = ("top", "frontend", "range"),
    *,
    use_cache: bool = True,
    probes: bool = True,
) -> dict:
    """Area of the whole P1 (``top``, the headline) and of its stages (the breakdown),
    each synthesised when named in ``parts``.

    Returns a JSON-able dict: ``target``, ``shape``, ``mode``, ``headline`` (``p1_top``,
    or ``stages`` when the top is not in ``parts``) and its ``lut``, ``ff``, ``carry``,
    ``dsp``, ``bram`` at the top level; with ``top``: ``cached``, ``cells`` of the whole
    ``p1_top`` without its probes (:func:`synth_top`) and, when ``probes``, ``probes``:
    what the taps and overflow counters add (the top with them kept, minus the headline);
    ``stages`` {stage: {``instances`` (``frontend`` once per stream: two in stereo, one in
    motion; ``range`` once), ``cached``, per-instance area with its probes, ``proxy``
    (:func:`proxy_area`), ``proxy_ratio`` (:func:`proxy_ratios`)}}; ``stages_sum``: those
    stages as instantiated; ``proxy``: the proxy of the whole P1 (the frame store's BRAM
    in motion) and its ``proxy_ratio`` against the headline."""
    if mode not in ("stereo", "motion"):
        raise UserError(f"unknown P1 mode {mode!r}; choose stereo or motion")
    instances = {"frontend": 2 if mode == "stereo" else 1, "range": 1}
    out_stages = {}
    total = SynthArea()
    proxy_total = {"register_bits": 0, "dsp": 0, "bram18": 0}
    for stage in (s for s in parts if s in STAGES):
        area, hit = synth_stage(config, stage, target, shape, use_cache=use_cache)
        proxy = proxy_area(config, stage, shape)
        ratio = proxy_ratios(proxy, area.as_dict())
        out_stages[stage] = {"instances": instances[stage], "cached": hit, **area.as_dict(),
                             "proxy": proxy, "proxy_ratio": ratio}  # fmt: skip
        total = total + area.times(instances[stage])
    for stage in STAGES:
        for k, v in proxy_area(config, stage, shape).items():
            proxy_total[k] += v * instances[stage]
    if mode == "motion":  # the frame store: E_hat, ex, ey of every pixel
        proxy_total["bram18"] += _frame_store_bram18(config, shape)
    stages_sum = {k: getattr(total, k) for k in AREA_KEYS}
    out: dict = {"target": target, "shape": list(shape), "mode": mode}
    if "top" in parts:
        whole, hit = synth_top(config, target, shape, mode, use_cache=use_cache)
        head = {k: getattr(whole, k) for k in AREA_KEYS}
        out |= {"headline": "p1_top", **head, "cached": hit, "cells": whole.cells}
        if probes:
            kept, k_hit = synth_top(config, target, shape, mode, probes=True, use_cache=use_cache)
            out["probes"] = {k: getattr(kept, k) - head[k] for k in AREA_KEYS} | {"cached": k_hit}
    else:
        head = stages_sum
        out |= {"headline": "stages", **head}
    return out | {
        "stages": out_stages,
        "stages_sum": stages_sum,
        "proxy": proxy_total,
        "proxy_ratio": proxy_ratios(proxy_total, head),
    }


def _frame_store_bram18(config: P1Config, shape: tuple[int, int]) -> int:
    """RAMB18 of the motion frame store (``p1_top.v``: ``{ey, ex, E_hat}`` per pixel)."""
    from rangefx.rtl_model.cost import bram18_blocks

    f = config.formats
    word = f["col_s1"].word + f[config.ex_signal].word + f["col_s2"].word
    return bram18_blocks(shape[0] * shape[1], word)


#: Signals whose registers each stage of ``hdl/`` holds (``rtl_model/p1/cost.py``
#: ``REGISTER_INSTANCES``): ``frontend`` per stream (with the pole and bias registers),
#: ``range`` once (with the host registers it reads); from the pipeline's signal groups.
STAGE_SIGNALS: dict[str, tuple[str, ...]] = {
    "frontend": ("pix_in", "bias_reg", "pole_coef", *FRONTEND_SIGNALS),
    "range": (
        *get_pipeline("p1").signal_groups["range_stage"],
        "f_reg",
        "k_t_reg",
        "k_m_reg",
        "tg2_reg",
    ),
}
#: Multipliers of the proxy (``rtl_model/p1/cost.py multipliers``) of the front end, by
#: name prefix: the filters, the x-derivative and its divider or second column filter.
_FRONTEND_MULTIPLIERS = (
    "row filter:",
    "column filter",
    "x-derivative",
    "divider s1",
)


def proxy_area(config: P1Config, stage: str, shape: tuple[int, int]) -> dict[str, int]:
    """The cost proxy (``rtl_model/p1/cost.py``) of one instance of a stage, restricted to
    what that stage of ``hdl/`` implements: register bits of :data:`STAGE_SIGNALS` used by
    the config's variant (``frontend``: one stream's instances and the pole/bias
    registers), DSP slices of its multipliers, RAMB18 of its line buffers; the proxy has no
    LUT term."""
    from rangefx.rtl_model.cost import bram18_blocks
    from rangefx.rtl_model.p1.cost import REGISTER_INSTANCES, multipliers
    from rangefx.rtl_model.p1.model import line_buffer_words

    f = config.formats
    unused = ("col2_state", "col2_out") if config.variant == "paper" else ("div_quot",)
    regs = sum(sum(REGISTER_INSTANCES[s]) * f[s].word for s in STAGE_SIGNALS[stage]
               if s not in unused)  # fmt: skip
    muls = multipliers(config, "motion")  # one stream's instances
    front = [m for m in muls if m.name.startswith(_FRONTEND_MULTIPLIERS)]
    if stage == "frontend":
        mine = front
        bram = sum(bram18_blocks(shape[1], w) for w in line_buffer_words(config))
    else:
        mine = [m for m in muls if m not in front]
        bram = 0
    return {"register_bits": regs, "dsp": sum(m.dsp for m in mine), "bram18": bram}


def proxy_ratios(proxy: Mapping[str, int], area: Mapping[str, int]) -> dict[str, float | None]:
    """Proxy / synthesis: register bits / FF, DSP / DSP, RAMB18 / BRAM (``None`` where the
    synthesis count is 0); LUT has no proxy term."""

    def ratio(a: int, b: int) -> float | None:
        return round(a / b, 3) if b else None

    return {
        "ff": ratio(proxy["register_bits"], area["ff"]),
        "dsp": ratio(proxy["dsp"], area["dsp"]),
        "bram": ratio(proxy["bram18"], area["bram"]),
        "lut": None,
    }


def synth_record(
    config, shape: tuple[int, int], mode: str, target: str = "xcup", pipeline: str = "p1"
) -> dict[str, int]:
    """A study's synthesis figures of one config (``rangefx sweep`` metric ``synth``,
    ``rangefx optimise --cost synth``): the whole top of ``pipeline`` (:data:`RTL_TOPS`)
    without its probes (:func:`synth_pipeline_top`): ``synth_lut``, ``synth_ff``,
    ``synth_carry``, ``synth_dsp``, ``synth_bram`` and the cost the studies minimise,
    ``synth_cost`` = LUT + FF."""
    whole, _hit = synth_pipeline_top(pipeline, config, target, shape, mode)
    area = whole.as_dict()
    rec = {f"synth_{k}": area[k] for k in AREA_KEYS}
    rec["synth_cost"] = area["lut"] + area["ff"]
    return rec


def synth_p2(
    config,
    target: str = "xcup",
    shape: tuple[int, int] = (512, 512),
    *,
    use_cache: bool = True,
    probes: bool = True,
) -> dict:
    """Area of the whole P2 (``hdl/p2_top.v``: input stage, line and sweep buffers, the
    lane-interleaved sweep with its divider, the forward pass and thresholds), the
    headline without its overflow counters (:func:`synth_pipeline_top`), and, when
    ``probes``, what the counters add (``probes``: the top with them kept, minus the
    headline). P2's RTL has no separately synthesisable stages.

    Returns a JSON-able dict: ``target``, ``shape``, ``mode`` (stereo), ``headline``
    (``p2_top``), its ``lut``, ``ff``, ``carry``, ``dsp``, ``bram``, ``cached``, ``cells``,
    ``probes``, ``stages`` (empty), ``proxy`` (``rtl_model/p2/cost.py``: register bits,
    DSP slices, RAMB18 of the line and sweep buffers) and ``proxy_ratio`` against the
    headline (:func:`proxy_ratios`)."""
    from rangefx.rtl_model.p2.cost import config_cost

    whole, hit = synth_pipeline_top("p2", config, target, shape, use_cache=use_cache)
    head = {k: getattr(whole, k) for k in AREA_KEYS}
    out: dict = {"target": target, "shape": list(shape), "mode": "stereo", "headline": "p2_top",
                 **head, "cached": hit, "cells": whole.cells}  # fmt: skip
    if probes:
        kept, k_hit = synth_pipeline_top("p2", config, target, shape, probes=True,
                                         use_cache=use_cache)  # fmt: skip
        out["probes"] = {k: getattr(kept, k) - head[k] for k in AREA_KEYS} | {"cached": k_hit}
    cost = config_cost(config, shape)
    proxy = {"register_bits": cost.register_bits, "dsp": cost.dsp, "bram18": cost.bram18}
    return out | {"stages": {}, "stages_sum": head, "proxy": proxy,
                  "proxy_ratio": proxy_ratios(proxy, head)}  # fmt: skip


def synth_pipeline(
    pipeline: str,
    config,
    target: str = "xcup",
    shape: tuple[int, int] = (512, 512),
    mode: str = "stereo",
    parts: tuple[str, ...] = ("top",),
    *,
    use_cache: bool = True,
    probes: bool = True,
) -> dict:
    """``rangefx hdl synth`` of any pipeline with RTL (:data:`RTL_TOPS`): P1's
    :func:`synth_p1` (the top and its stages as ``parts`` names), P2's :func:`synth_p2`
    (the whole top only). :class:`UserError` (one line) for a pipeline without RTL, a
    stage or mode its RTL does not have."""
    rtl = rtl_top(pipeline)
    if mode not in rtl.modes:
        raise UserError(f"{pipeline} has no {mode} mode in hdl/ (it has {', '.join(rtl.modes)})")
    if pipeline == "p1":
        return synth_p1(config, target, shape, mode, parts, use_cache=use_cache, probes=probes)
    if tuple(parts) != ("top",):
        raise UserError(f"{pipeline}'s RTL is synthesised whole (--stage top), not by stage")
    return synth_p2(config, target, shape, use_cache=use_cache, probes=probes)
