"""Icarus replay of the P1 range stage (``hdl/p1_range.v``, issue 15 part B).

Vectors of small lab (stereo) and runway (motion) crops are built in-process, the range
stage is compiled with the config's formats and the manifest's register codes, its
inputs are driven from the vectors' front-end taps (``e1``/``e2`` ``col_s1``, ``ex``,
``col_s2``) in the cycles of the ``e2.ex`` samples, and every range tap is compared with
the vectors value for value (``vectors diff`` on the dumps) and cycle for cycle (the
manifest's latencies on the input beats); the RTL's overflow flags, counted per signal,
must equal the manifest's counts. A mutant with one rounding mode changed must be found
at the first pixel where the model under that mode differs.
Skips when iverilog or cocotb is absent (``.ci/run`` installs both).
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1 import RANGE_TAPS
from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.p1.taps import TAP_SIGNALS
from rangefx.tools.studies.cases import crop_case, scene_case
from rangefx.vectors import formats as fmt_io
from rangefx.vectors.generate import build_vectors, diff_dump, load_manifest, write_vectors
from rangefx.vectors.hdl import HDL_DIR, RANGE_SOURCES, range_parameters, range_registers

if shutil.which("iverilog") is None or shutil.which("vvp") is None:
    pytest.skip("Icarus Verilog (iverilog) is not installed", allow_module_level=True)
cocotb_tools_runner = pytest.importorskip(
    "cocotb_tools.runner", reason="cocotb is not installed (pip install cocotb)"
)

CROPS = {"lab": [240, 252, 100, 120], "runway": [300, 310, 240, 262]}
TIMING = TimingConfig(hblank=3, vblank=4, gap_prob=0.2, seed=5)


def _fmt(text: str, quant: Quant, overflow: Overflow = Overflow.SAT) -> FixedFormat:
    return FixedFormat.from_string(text, quant, overflow)


def range_modes_config(variant: str, divider: str) -> P1Config:
    """Narrowed range stage with a different rounding or overflow mode on every signal
    (TRN, TRN_ZERO, RND_ZERO, RND_INF, RND_MIN_INF, RND_CONV; WRAP, SAT_SYM, SAT_ZERO),
    narrow enough that ``c1``, ``grad_b``, ``gv``, ``num`` and the quotient overflow on
    the crops."""
    d = P1Config.default(variant=variant, divider=divider)
    return d.with_formats(
        coord=_fmt("s13.1", Quant.RND_CONV),
        c1=_fmt("s4.1", Quant.TRN, Overflow.SAT_SYM),
        grad_a=_fmt("s18.10", Quant.RND_ZERO),
        grad_b=_fmt("s6.3", Quant.RND_INF, Overflow.SAT_ZERO),
        k_rot=_fmt("s22.19", Quant.RND_MIN_INF),
        geom_v=_fmt("s22.4", Quant.TRN_ZERO),
        geom_w=_fmt("s20.13", Quant.RND_CONV, Overflow.WRAP),
        gv=_fmt("s10.1", Quant.RND, Overflow.SAT),
        num=_fmt("s11.1", Quant.TRN_ZERO, Overflow.SAT_SYM),
        den=_fmt("s24.8", Quant.RND_CONV, Overflow.SAT_SYM),
        range=_fmt("s10.3", Quant.RND_ZERO, Overflow.SAT),
        v_sq=_fmt("u24.0", Quant.TRN),
        grad_sq=_fmt("u34.0", Quant.RND_INF),
    ).with_(name=f"range-modes-{variant}-{divider}")


@functools.cache
def _scene(name: str):
    return scene_case(name)


def _vectors(tmp: Path, scene: str, config: P1Config) -> Path:
    vs = build_vectors("p1", crop_case(_scene(scene), CROPS[scene]), config, TIMING,
                       description={"scene": scene, "crop": CROPS[scene]})  # fmt: skip
    vec = tmp / "vec"
    vec.mkdir()
    write_vectors(vec, vs)
    return vec


def replay_range(vec: Path, config: P1Config, work: Path, **over: int) -> Path:
    """Build ``p1_range`` for ``config`` (parameters ``over`` overridden) and replay the
    front-end taps of ``vec`` through it; returns the dump directory."""
    manifest = load_manifest(vec)
    m, n = manifest["shape"]
    params = range_parameters(config, n, m, rom_file=str(vec / "recip_rom.mem")) | over
    runner = cocotb_tools_runner.get_runner("icarus")
    build = work / "build"
    runner.build(sources=[HDL_DIR / s for s in RANGE_SOURCES], includes=[HDL_DIR],
                 hdl_toplevel="p1_range", parameters=params, build_dir=build,
                 always=True)  # fmt: skip
    dump = work / "dump"
    env = {
        "RANGEFX_VECTORS": str(vec),
        "RANGEFX_DUMP": str(dump),
        "RANGEFX_REGS": json.dumps(range_registers(config, manifest["registers"])),
        "PYTHONPATH": os.pathsep.join([str(HDL_DIR), *sys.path]),
    }
    results = runner.test(hdl_toplevel="p1_range", test_module="test_p1_range",
                          test_dir=HDL_DIR, build_dir=build, extra_env=env)  # fmt: skip
    from cocotb_tools.runner import get_results

    assert get_results(results) == (1, 0)
    return dump


def expected_cycles(vec: Path, tap: str) -> np.ndarray:
    """Cycle of every sample of a range tap: E2's input beats plus the tap's latency."""
    manifest = load_manifest(vec)
    m, n = manifest["shape"]
    streams = [e for e in manifest["files"] if e["kind"] == "stream" and e["path"].endswith(".bin")]
    e = next((s for s in streams if s["tap"] == "e2.pix_in"), streams[0])
    valid = fmt_io.read_stream_bin_valid((vec / e["path"]).read_bytes(), int(e["word"]))
    entry = next(f for f in manifest["files"] if f["tap"] == tap and f["path"].endswith(".mem"))
    return np.flatnonzero(valid)[-m * n :] + int(entry["latency"])


def rtl_overflows(dump: Path) -> dict[str, int]:
    """The RTL's overflow flags counted per word-length signal."""
    counts: dict[str, int] = {}
    for tap, k in json.loads((dump / "cycles.json").read_text())["overflows"].items():
        counts[TAP_SIGNALS[tap]] = counts.get(TAP_SIGNALS[tap], 0) + k
    return counts


def assert_replay_exact(vec: Path, dump: Path) -> int:
    """Every range tap: 0 value and 0 cycle mismatches; overflow counts as the manifest's."""
    manifest = load_manifest(vec)
    got_cycles = json.loads((dump / "cycles.json").read_text())["cycles"]
    samples = 0
    for tap in RANGE_TAPS:
        report = diff_dump(vec, dump / f"{tap}.mem")
        assert report.ok, report.text()
        assert got_cycles[tap] == expected_cycles(vec, tap).tolist(), f"{tap}: cycle stamps"
        samples += report.expected_count
    counts = rtl_overflows(dump)
    for signal, k in counts.items():
        assert k == manifest["overflows"].get(signal, 0), signal
    return samples


#: The shipped lab-optimised config: words of 1-2 bits and negative fraction bits
#: (``coord`` s1.-11, ``v_sq`` u1.-12, ``k_rot`` s1.-3, ...).
OPTIMISED = HDL_DIR.parent / "tools" / "studies" / "sweeps" / "p1_lab_optimised_1pct.toml"

CASES = [
    ("lab", "paper", "reciprocal", "default"),
    ("lab", "paper", "reciprocal", "optimised"),
    ("lab", "consistent", "restoring", "modes"),
    ("runway", "paper", "restoring", "default"),
    ("runway", "consistent", "reciprocal", "modes"),
]


@pytest.mark.parametrize(("scene", "variant", "divider", "formats"), CASES)
def test_range_stage_replays_bit_and_cycle_exact(scene, variant, divider, formats, tmp_path):
    if formats == "default":
        config = P1Config.default(variant=variant, divider=divider)
    elif formats == "optimised":
        config = P1Config.load(str(OPTIMISED)).with_(variant=variant, divider=divider)
    else:
        config = range_modes_config(variant, divider)
    vec = _vectors(tmp_path, scene, config)
    manifest = load_manifest(vec)
    assert manifest["mode"] == ("stereo" if scene == "lab" else "motion")
    dump = replay_range(vec, config, tmp_path)
    m, n = manifest["shape"]
    assert assert_replay_exact(vec, dump) == len(RANGE_TAPS) * m * n
    if formats == "modes":  # the narrowed formats do overflow: the counts are not all 0
        assert sum(rtl_overflows(dump).values()) > 0


def test_rounding_mutant_is_caught_at_the_first_differing_pixel(tmp_path):
    """``gv`` rounds (RND) in the default config; the mutant RTL truncates (``GV_Q`` = TRN).
    ``vectors diff`` must name the first pixel (row, col, cycle) where the model under TRN
    differs, with the same count; the taps before ``gv`` still match."""
    config = P1Config.default()
    vec = _vectors(tmp_path, "lab", config)
    dump = replay_range(vec, config, tmp_path, GV_Q=int(Quant.TRN))
    gv_fmt = config.fmt("gv")
    mutant = config.with_formats(gv=_fmt(str(gv_fmt), Quant.TRN, gv_fmt.overflow))
    case = crop_case(_scene("lab"), CROPS["lab"])
    runs = [
        build_vectors("p1", case, c, TIMING).result.taps["gv"].ravel() for c in (config, mutant)
    ]
    differ = np.flatnonzero(runs[0] != runs[1])
    assert differ.size > 0
    k = int(differ[0])
    report = diff_dump(vec, dump / "gv.mem")
    assert not report.ok
    assert report.mismatches == differ.size
    n = load_manifest(vec)["shape"][1]
    first = report.first
    assert (first["index"], first["row"], first["col"]) == (k, k // n, k % n)
    assert first["cycle"] == int(expected_cycles(vec, "gv")[k])
    assert (first["expected"], first["got"]) == (int(runs[0][k]), int(runs[1][k]))
    for tap in RANGE_TAPS[: RANGE_TAPS.index("gv")]:
        assert diff_dump(vec, dump / f"{tap}.mem").ok, tap


@pytest.mark.parametrize(
    ("iw", "signed", "f_in", "out"),
    [
        (14, 1, 3, (1, 12, 5)),  # left shift by 2, signed
        (14, 0, 4, (0, 6, -2)),  # unsigned in and out, negative output fraction
        (14, 1, 9, (1, 4, 0)),  # a 4-bit output: most inputs overflow
        (14, 1, 3, (1, 10, 2)),  # a right shift by 1: the dropped bit is the tie
    ],
)
def test_sized_cast_equals_the_generic_cast_on_every_input(iw, signed, f_in, out, tmp_path):
    """``fx_cast_sized`` and its two-stage form ``fx_cast_reg`` (every cast of p1_range)
    against the 64-bit ``fx_cast`` on all 2^14 inputs, under all 7 x 4 quantisation and
    overflow modes (Icarus)."""
    import subprocess

    out_s, out_w, out_f = out
    vvp = tmp_path / "tb.vvp"
    params = {"IW": iw, "IS": signed, "IF": f_in, "OW": out_w, "OF": out_f, "OS": out_s}
    cmd = ["iverilog", "-g2005", "-o", str(vvp), "-s", "tb_fx_cast_sized"]
    cmd += [f"-Ptb_fx_cast_sized.{k}={v}" for k, v in params.items()]
    cmd += [str(HDL_DIR / f) for f in ("fx_cast.v", "fx_cast_sized.v", "tb_fx_cast_sized.v")]
    subprocess.run(cmd, check=True, capture_output=True)
    run = subprocess.run(["vvp", "-n", str(vvp)], check=True, capture_output=True, text=True)
    assert f"inputs={1 << iw} mismatching=0" in run.stdout
