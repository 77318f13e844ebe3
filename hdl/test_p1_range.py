"""cocotb test of ``p1_range``: drive the range stage from a vector directory's front-end
taps, dump every range tap with its cycle stamps and the overflow counts.

Run by ``tests/test_hdl_range.py`` through ``cocotb_tools.runner`` (Icarus). The inputs
of pixel ``k`` (``e1``/``e2`` ``col_s1``, ``ex``, ``col_s2``) are driven in the cycle the
vectors give the ``e2.ex`` sample (E2's input beat plus the ``ex`` tap's latency: the
range stage reads both streams when E2's x-derivative is out; in motion mode E1's values
come from the frame store). Cycle 0 is the first cycle of the input stream. Environment:
``RANGEFX_VECTORS`` (vector directory), ``RANGEFX_DUMP`` (output directory: one
``<tap>.mem`` per range tap, ``cycles.json`` with every tap's cycle stamps and the
overflow count of each tap), ``RANGEFX_REGS`` (JSON: register port -> unsigned word).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge

from rangefx.vectors import formats as fmt_io
from rangefx.vectors.hdl import RANGE_INPUTS, RANGE_TAP_GROUPS


def _entry(manifest: dict, tap: str) -> dict:
    return next(
        e for e in manifest["files"]
        if e["tap"] == tap and e["kind"] != "stream" and e["path"].endswith(".mem")
    )  # fmt: skip


def _codes(vec: Path, manifest: dict, tap: str) -> list[int]:
    """Unsigned codes of a tap's ``.mem`` file (what the ports carry)."""
    return [int(w) for w in fmt_io.read_mem((vec / _entry(manifest, tap)["path"]).read_bytes())]


def _e2_beats(vec: Path, manifest: dict) -> np.ndarray:
    """Input cycle of every pixel of E2's frame (motion: the second frame of the stream)."""
    m, n = manifest["shape"]
    files = manifest["files"]
    streams = {e["tap"]: e for e in files if e["kind"] == "stream" and e["path"].endswith(".bin")}
    e = streams.get("e2.pix_in") or next(iter(streams.values()))
    valid = fmt_io.read_stream_bin_valid((vec / e["path"]).read_bytes(), int(e["word"]))
    return np.flatnonzero(valid)[-m * n :]


@cocotb.test()
async def replay(dut) -> None:
    vec = Path(os.environ["RANGEFX_VECTORS"])
    manifest = json.loads((vec / "manifest.json").read_text())
    m, n = manifest["shape"]
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    for port, value in json.loads(os.environ["RANGEFX_REGS"]).items():
        getattr(dut, port).value = value
    inputs = {
        f"{s}_{port}": _codes(vec, manifest, f"{s}.{tap}")
        for s in ("e1", "e2")
        for port, tap in RANGE_INPUTS.items()
    }
    drive_at = _e2_beats(vec, manifest) + int(_entry(manifest, "e2.ex")["latency"])
    last = int(drive_at[-1])
    ports = {name: getattr(dut, name) for name in inputs}
    for h in (dut.s_valid, dut.s_sof, dut.s_eol, *ports.values()):
        h.value = 0
    dut.rst.value = 1
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    samples: dict[str, list[int]] = {}
    cycles: dict[str, list[int]] = {}
    overflows: dict[str, int] = {}
    groups = {
        ovf: (getattr(dut, vport), [getattr(dut, t) for t in taps], taps,
              getattr(dut, ovf) if ovf else None)
        for ovf, (vport, taps) in RANGE_TAP_GROUPS.items()
    }  # fmt: skip
    for _ovf, (_v, _h, taps, _o) in groups.items():
        for t in taps:
            samples[t], cycles[t], overflows[t] = [], [], 0

    async def monitor() -> None:
        cycle = 0
        while True:
            await RisingEdge(dut.clk)
            await ReadOnly()
            cycle += 1
            for vh, handles, taps, oh in groups.values():
                if int(vh.value) != 1:
                    continue
                flags = int(oh.value) if oh is not None else 0
                for bit, (t, h) in enumerate(zip(taps, handles, strict=True)):
                    samples[t].append(int(h.value))
                    cycles[t].append(cycle)
                    overflows[t] += (flags >> bit) & 1

    # cycle 0: the first cycle of the input stream; this edge starts it
    await RisingEdge(dut.clk)
    cocotb.start_soon(monitor())
    k = 0
    for cycle in range(last + 1):
        if k < drive_at.size and drive_at[k] == cycle:
            dut.s_valid.value = 1
            dut.s_sof.value = int(k == 0)
            dut.s_eol.value = int(k % n == n - 1)
            for name, h in ports.items():
                h.value = inputs[name][k]
            k += 1
        else:
            dut.s_valid.value = 0
        await RisingEdge(dut.clk)
    dut.s_valid.value = 0
    await ClockCycles(dut.clk, 128)  # > the longest divider latency (W + 4, W <= 62)
    dump = Path(os.environ["RANGEFX_DUMP"])
    dump.mkdir(parents=True, exist_ok=True)
    for t, values in samples.items():
        width = len(getattr(dut, t))
        digits = fmt_io.hex_digits(width)
        lines = [f"// {t}: p1_range dump, {len(values)} beats"]
        lines += [f"{v:0{digits}x}" for v in values]
        (dump / f"{t}.mem").write_text("\n".join(lines) + "\n")
    (dump / "cycles.json").write_text(json.dumps({"cycles": cycles, "overflows": overflows}))
    assert k == m * n
