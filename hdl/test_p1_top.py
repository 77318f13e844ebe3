"""cocotb bench of ``p1_top``: replay a P1 vector directory, dump every front-end tap with
its cycle, the overflow counters and the AXI4-Stream output.

Needs nothing but the vector directory (``RANGEFX_VECTORS``): the input streams
(``*.stream.bin``), the register codes of ``manifest.json``; the design is built with
the parameters of ``rangefx.vectors.hdl.top_parameters`` (``rangefx hdl replay`` does
both). The inputs are driven by cocotbext-axi's ``AxiStreamSource`` with a pause
generator that reproduces the streams' idle cycles exactly (one line per AXI frame:
TLAST = end of line, TUSER = start of frame); the output is received by its
``AxiStreamSink``. Each tap is sampled in the cycles its stage's valid is high. Cycles
are counted in the streams' own time (cycle 0 = the stream files' first word): the
bench checks that every input beat reached the DUT in its file's cycle.

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
from cocotbext.axi import AxiStreamBus, AxiStreamFrame, AxiStreamSink, AxiStreamSource

from rangefx.vectors.formats import read_stream_bin
from rangefx.vectors.hdl import (
    FRONTEND_TAPS,
    OVERFLOW_SIGNALS,
    RANGE_TAP_GROUPS,
    frontend_instances,
    register_codes,
    write_dump,
)

#: Idle cycles driven before the streams start (reset is released in the meantime).
LEAD = 8


def _stream_files(vec: Path, manifest: dict) -> list[tuple[str, dict]]:
    """(file, entry) of each input stream, in the order of the DUT's inputs s0, s1."""
    entries = [e for e in manifest["files"] if e["kind"] == "stream" and e["path"].endswith(".bin")]
    return sorted(((e["path"], e) for e in entries), key=lambda pe: pe[1]["tap"])


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
    streams = _stream_files(vec, manifest)
    sources = []
    for k, (path, entry) in enumerate(streams):
        beats = read_stream_bin((vec / path).read_bytes(), int(entry["word"]))
        src = AxiStreamSource(AxiStreamBus.from_prefix(dut, f"s{k}_axis"), dut.clk, byte_lanes=1)
        pause = [True] * LEAD + [not bool(v) for v in beats["valid"]]
        src.set_pause_generator(itertools.chain(pause, itertools.repeat(True)))
        for frame in _frames(beats):
            await src.send(frame)
        sources.append(src)
    total = max(int(e["count"]) for _p, e in streams)

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
    overflows = dict.fromkeys(OVERFLOW_SIGNALS, 0)
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
                    bits = int(flags_h.value) if flags_h is not None else 0
                    for k, (tap, h) in enumerate(handles):
                        samples.setdefault(tap, []).append((cycle, _read(h)))
                        if flags_h is not None:
                            overflows[signal_of[tap]] += (bits >> k) & 1
            cycle += 1

    await ClockCycles(dut.clk, 2)
    dut.rst.value = 0
    # after reset: the outputs are defined from here on
    sink = AxiStreamSink(AxiStreamBus.from_prefix(dut, "m_axis"), dut.clk, byte_lanes=1)
    cocotb.start_soon(sample())
    lat = int(manifest["latency"]["total"])
    await ClockCycles(dut.clk, LEAD + total + lat + 8)

    lines = []
    while not sink.empty():
        frame = sink.recv_nowait()
        lines.append((list(frame.tdata), _first(frame.tuser)))
    for inst in instances.values():
        for signal in OVERFLOW_SIGNALS:
            overflows[signal] += int(getattr(inst, f"ovf_{signal}").value)
    flags = {
        k: int(getattr(dut, k).value) for k in ("line_too_long", "align_error", "frame_too_big")
    }
    write_dump(
        dump, vec, manifest, samples, inputs, lines, overflows, flags, LEAD + total + lat + 8
    )


def _child(dut, name: str):
    h = dut
    for part in name.split("."):
        h = getattr(h, part)
    return h


def _first(tuser) -> int:
    if isinstance(tuser, list):
        return int(tuser[0]) if tuser else 0
    return int(tuser or 0)
