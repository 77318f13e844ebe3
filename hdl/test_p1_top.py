"""cocotb bench of ``p1_top``: replay a P1 vector directory, dump every front-end tap with
its cycle, the overflow counters and the AXI4-Stream output.

Needs nothing but the vector directory (``RANGEFX_VECTORS``): the input streams
(``*.stream.mem``, the stimulus the Verilog bench ``tb_p1_top.v`` reads too), the
register codes of ``manifest.json``; the design is built with the parameters of
``rangefx.vectors.hdl.top_parameters`` (``rangefx hdl replay`` does both). The inputs
are driven by cocotbext-axi's ``AxiStreamSource`` with a pause generator that
reproduces the streams' idle cycles exactly (one line per AXI frame: TLAST = end of
line, TUSER = start of frame). The output beats are sampled with their cycle in every
cycle TVALID is high (not by an ``AxiStreamSink``, which cannot hold x/z words). Each tap
is sampled in the cycles its stage's valid is high; a value with x/z bits is recorded
as unknown (a mismatch), never converted. Cycles are counted in the streams' own time
(cycle 0 = the stream files' first word): the bench checks that every input beat
reached the DUT in its file's cycle.

Writes into ``RANGEFX_DUMP``: ``<tap>.mem`` (``rangefx vectors diff`` reads them),
``taps.npz`` (per tap ``<tap>.value`` and ``<tap>.cycle``), ``m_axis.npz`` (the output
words per line) and ``status.json`` (overflow counters summed per signal, sticky flags,
cycles simulated).
"""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from cocotbext.axi import AxiStreamBus, AxiStreamFrame, AxiStreamSource

from rangefx.vectors.hdl import (
    FRONTEND_TAPS,
    OVERFLOW_SIGNALS,
    RANGE_TAP_GROUPS,
    frontend_instances,
    read_stream_mem,
    register_codes,
    stream_entries,
    write_dump,
)

#: Idle cycles driven before the streams start (reset is released in the meantime).
LEAD = 8


def _frames(beats: dict[str, np.ndarray]) -> list[AxiStreamFrame]:
    """One AXI frame per line (TLAST on its last pixel), TUSER per beat."""
    v = beats["valid"].astype(bool)
    data = beats["data"][v].astype(np.int64)
    sof = beats["sof"][v].astype(np.int64)
    eol = np.flatnonzero(beats["eol"][v])
    out, start = [], 0
    for end in eol:
        out.append(
            AxiStreamFrame(data[start : end + 1].tolist(), tuser=sof[start : end + 1].tolist())
        )
        start = end + 1
    return out


def _read(handle) -> int | None:
    try:
        return int(handle.value)
    except ValueError:  # x or z bits
        return None


@cocotb.test()
async def replay(dut) -> None:
    vec = Path(os.environ["RANGEFX_VECTORS"])
    dump = Path(os.environ["RANGEFX_DUMP"])
    dump.mkdir(parents=True, exist_ok=True)
    manifest = json.loads((vec / "manifest.json").read_text())
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    for port, code in register_codes(manifest).items():
        getattr(dut, port).value = code
    dut.rst.value = 1
    for p in ("tvalid", "tdata", "tuser", "tlast"):
        getattr(dut, f"s1_axis_{p}").value = 0
    streams = stream_entries(manifest)
    sources = []
    for k, entry in enumerate(streams):
        beats = read_stream_mem(vec / entry["path"], int(entry["word"]))
        src = AxiStreamSource(AxiStreamBus.from_prefix(dut, f"s{k}_axis"), dut.clk, byte_lanes=1)
        pause = [True] * LEAD + [not bool(v) for v in beats["valid"]]
        src.set_pause_generator(itertools.chain(pause, itertools.repeat(True)))
        for frame in _frames(beats):
            await src.send(frame)
        sources.append(src)
    total = max(int(e["count"]) for e in streams)

    instances = {s: getattr(dut, name) if "." not in name else _child(dut, name)
                 for s, name in frontend_instances(manifest).items()}  # fmt: skip
    consistent = manifest["config"]["parsed"]["design"]["variant"] == "consistent"
    taps = {t: pv for t, pv in FRONTEND_TAPS.items() if consistent or t != "col2_state"}
    groups: dict[str, list[tuple[str, object]]] = {}
    for stream, inst in instances.items():
        for tap, (port, valid) in taps.items():
            groups.setdefault(f"{stream}|{valid}", []).append((tap, getattr(inst, port)))
    valids = {key: getattr(instances[key.split("|")[0]], key.split("|")[1]) for key in groups}
    samples: dict[str, list[tuple[int, int | None]]] = {}
    inputs: list[int] = []
    # the range stage: its tap groups, each with a valid and a vector of overflow flags
    # (bit k: the k-th tap's cast), counted per signal as the model counts them
    signal_of = {e["tap"]: e["signal"] for e in manifest["files"]}
    overflows: dict[str, int | None] = dict.fromkeys(OVERFLOW_SIGNALS, 0)

    def count(signal: str, n: int | None) -> None:  # None: x/z bits, kept as unknown
        before = overflows.get(signal, 0)
        overflows[signal] = None if before is None or n is None else before + n

    out_beats: list[tuple[int, int | None, int, int]] = []
    ranges = []
    for ovf, (vport, names) in RANGE_TAP_GROUPS.items():
        flags_h = getattr(dut.u_range, ovf) if ovf else None
        handles = [(t, getattr(dut.u_range, t)) for t in names]
        ranges.append((getattr(dut.u_range, vport), flags_h, handles))
        for t in names:
            if ovf:
                overflows.setdefault(signal_of[t], 0)

    async def sample() -> None:
        cycle = 0
        while True:
            await RisingEdge(dut.clk)
            await ReadOnly()
            if dut.s0_axis_tvalid.value == 1:
                inputs.append(cycle)
            for key, handle in valids.items():
                if handle.value == 1:
                    stream = key.split("|")[0]
                    for tap, h in groups[key]:
                        samples.setdefault(f"{stream}.{tap}", []).append((cycle, _read(h)))
            for valid, flags_h, handles in ranges:
                if valid.value == 1:
                    bits = _read(flags_h) if flags_h is not None else 0
                    for k, (tap, h) in enumerate(handles):
                        samples.setdefault(tap, []).append((cycle, _read(h)))
                        if flags_h is not None:
                            count(signal_of[tap], None if bits is None else (bits >> k) & 1)
            if dut.m_axis_tvalid.value == 1:
                tuser, tlast = _read(dut.m_axis_tuser), _read(dut.m_axis_tlast)
                out_beats.append((cycle, _read(dut.m_axis_tdata), -1 if tuser is None else tuser,
                                  1 if tlast is None else tlast))  # fmt: skip
            cycle += 1

    await ClockCycles(dut.clk, 2)
    dut.rst.value = 0
    cocotb.start_soon(sample())
    lat = int(manifest["latency"]["total"])
    await ClockCycles(dut.clk, LEAD + total + lat + 8)

    for inst in instances.values():
        for signal in OVERFLOW_SIGNALS:
            count(signal, _read(getattr(inst, f"ovf_{signal}")))
    flags = {k: _read(getattr(dut, k)) for k in ("line_too_long", "align_error", "frame_too_big")}
    write_dump(
        dump, vec, manifest, samples, inputs, out_beats, overflows, flags, LEAD + total + lat + 8
    )


def _child(dut, name: str):
    h = dut
    for part in name.split("."):
        h = getattr(h, part)
    return h
