"""cocotb test of ``p1_rowcol``: replay a vector directory's input stream, dump the taps.

Run by ``tests/test_hdl.py`` through ``cocotb_tools.runner`` (Icarus). Environment:
``RANGEFX_VECTORS`` (vector directory), ``RANGEFX_DUMP`` (where the ``<tap>.mem`` dumps
go), ``RANGEFX_STREAM`` (``e1`` or ``e2``), ``RANGEFX_POLE``, ``RANGEFX_BIAS`` (raw
register codes). Comparison is ``rangefx vectors diff`` on the dumps.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, RisingEdge

from rangefx.vectors.cocotb_axis import AxisVideoSink, AxisVideoSource
from rangefx.vectors.hdl import ROWCOL_TAPS


@cocotb.test()
async def replay(dut) -> None:
    vec = Path(os.environ["RANGEFX_VECTORS"])
    stream = os.environ.get("RANGEFX_STREAM", "e1")
    manifest = json.loads((vec / "manifest.json").read_text())
    entry = next(
        e for e in manifest["files"]
        if e["kind"] == "stream" and e["path"].endswith(".bin") and e["tap"] == f"{stream}.pix_in"
    )  # fmt: skip
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.pole_raw.value = int(os.environ["RANGEFX_POLE"])
    dut.bias_raw.value = int(os.environ["RANGEFX_BIAS"])
    src = AxisVideoSource.from_file(
        dut.clk, vec / entry["path"], int(entry["word"]),
        tvalid=dut.s_valid, tdata=dut.s_data, tuser=dut.s_sof, tlast=dut.s_eol,
    )  # fmt: skip
    src.idle()
    dut.rst.value = 1
    await ClockCycles(dut.clk, 3)
    await RisingEdge(dut.clk)
    dut.rst.value = 0
    sink = AxisVideoSink(
        dut.clk,
        tvalid=dut.m_valid,
        tuser=dut.m_sof,
        tlast=dut.m_eol,
        data={f"{stream}.{tap}": getattr(dut, port) for tap, port in ROWCOL_TAPS.items()},
    )
    cocotb.start_soon(sink.run())
    await src.run()
    await ClockCycles(dut.clk, 8)
    sink.write_dumps(os.environ["RANGEFX_DUMP"])
    sink.write_dumps(os.environ["RANGEFX_DUMP"], suffix=".csv")
