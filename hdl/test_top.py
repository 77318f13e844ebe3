"""cocotb bench of ``p1_top`` and ``p2_top``: replay a P1 or P2 vector directory, dump every
tap with its cycle, the overflow counters, the flags and the AXI4-Stream output.

Needs nothing but the vector directory (``RANGEFX_VECTORS``): the input streams
(``*.stream.mem``, the stimulus the plain Verilog bench ``tb_top.v`` reads too), the
register codes of ``manifest.json``; the design is built with the parameters of
``rangefx.vectors.hdl.top_parameters`` / ``p2_parameters`` (``rangefx hdl replay`` does
both and passes P2's in ``RANGEFX_PARAMS``, JSON). The manifest's pipeline picks the
probe: which registers are taps and when they are valid, which counters and flags to
read; everything else is one protocol for both. The inputs are driven by cocotbext-axi's
``AxiStreamSource`` with a pause generator that reproduces the streams' idle cycles
exactly (one line per AXI frame: TLAST = end of line, TUSER = start of frame). The
output beats are sampled with their cycle in every cycle TVALID is high (not by an
``AxiStreamSink``, which cannot hold x/z words). Each tap is sampled in the cycles its
valid is high; a value with x/z bits is recorded as unknown (a mismatch), never
converted. Cycles are counted in the streams' own time (cycle 0 = the stream files'
first word): the bench checks that every input beat reached the DUT in its file's cycle.

Writes into ``RANGEFX_DUMP``: ``<tap>.mem`` (``rangefx vectors diff`` reads them),
``taps.npz`` (per tap ``<tap>.value`` and ``<tap>.cycle``), ``m_axis.npz`` (the output
words per line) and ``status.json`` (overflow counters summed per signal, sticky flags,
cycles simulated).
"""

from __future__ import annotations

import itertools
import json
import os
import re
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from cocotbext.axi import AxiStreamBus, AxiStreamFrame, AxiStreamSource

from rangefx.vectors.hdl import (
    FRONTEND_TAPS,
    OVERFLOW_SIGNALS,
    P2_FLAGS,
    P2_OVERFLOW_PORTS,
    P2_TAP_PORTS,
    RANGE_TAP_GROUPS,
    frontend_instances,
    p2_register_codes,
    read_stream_mem,
    register_codes,
    stream_entries,
    write_dump,
)

#: Idle cycles driven before the streams start (reset is released in the meantime).
LEAD = 8

Samples = dict[str, list[tuple[int, int | None]]]


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


def _child(dut, name: str):
    h = dut
    for part in name.split("."):
        h = getattr(h, part)
    return h


class P1Probe:
    """``p1_top``: both streams' front-end taps (one valid per stage), the range stage's
    tap groups with their overflow-flag vectors, the front ends' counters."""

    flags = ("line_too_long", "align_error", "frame_too_big")

    def __init__(self, dut, manifest: dict) -> None:
        self.manifest = manifest
        self.instances = {s: _child(dut, name) for s, name in frontend_instances(manifest).items()}
        consistent = manifest["config"]["parsed"]["design"]["variant"] == "consistent"
        taps = {t: pv for t, pv in FRONTEND_TAPS.items() if consistent or t != "col2_state"}
        self.groups: dict[str, list[tuple[str, object]]] = {}
        for stream, inst in self.instances.items():
            for tap, (port, valid) in taps.items():
                self.groups.setdefault(f"{stream}|{valid}", []).append((tap, getattr(inst, port)))
        self.valids = {key: getattr(self.instances[key.split("|")[0]], key.split("|")[1])
                       for key in self.groups}  # fmt: skip
        # the range stage: its tap groups, each with a valid and a vector of overflow flags
        # (bit k: the k-th tap's cast), counted per signal as the model counts them
        self.signal_of = {e["tap"]: e["signal"] for e in manifest["files"]}
        self.overflows: dict[str, int | None] = dict.fromkeys(OVERFLOW_SIGNALS, 0)
        self.ranges = []
        for ovf, (vport, names) in RANGE_TAP_GROUPS.items():
            flags_h = getattr(dut.u_range, ovf) if ovf else None
            handles = [(t, getattr(dut.u_range, t)) for t in names]
            self.ranges.append((getattr(dut.u_range, vport), flags_h, handles))
            for t in names:
                if ovf:
                    self.overflows.setdefault(self.signal_of[t], 0)

    def registers(self) -> dict[str, int]:
        return register_codes(self.manifest)

    def cycles(self, stream_cycles: int) -> int:
        return LEAD + stream_cycles + int(self.manifest["latency"]["total"]) + 8

    def _count(self, signal: str, n: int | None) -> None:  # None: x/z bits, kept unknown
        before = self.overflows.get(signal, 0)
        self.overflows[signal] = None if before is None or n is None else before + n

    def sample(self, cycle: int, samples: Samples) -> None:
        for key, handle in self.valids.items():
            if handle.value == 1:
                stream = key.split("|")[0]
                for tap, h in self.groups[key]:
                    samples.setdefault(f"{stream}.{tap}", []).append((cycle, _read(h)))
        for valid, flags_h, handles in self.ranges:
            if valid.value == 1:
                bits = _read(flags_h) if flags_h is not None else 0
                for k, (tap, h) in enumerate(handles):
                    samples.setdefault(tap, []).append((cycle, _read(h)))
                    if flags_h is not None:
                        self._count(self.signal_of[tap], None if bits is None else (bits >> k) & 1)

    def counters(self) -> dict[str, int | None]:
        for inst in self.instances.values():
            for signal in OVERFLOW_SIGNALS:
                self._count(signal, _read(getattr(inst, f"ovf_{signal}")))
        return self.overflows


_FIELD = re.compile(r"^(\w+)\[(\w+)(-1:0)?\]$")


class P2Probe:
    """``p2_top``: every tap one register with its valid strobe (``P2_TAP_PORTS``; the
    output taps are bit fields of ``m_axis_tdata``), one counter per signal."""

    flags = P2_FLAGS

    def __init__(self, dut, manifest: dict, params: dict) -> None:
        self.manifest, self.params = manifest, params
        self.taps: dict[str, list[tuple[str, object, int, int]]] = {}
        for tap, (port, valid) in P2_TAP_PORTS.items():
            lo, bits = 0, 0  # bits 0: the whole register
            field = _FIELD.match(port)
            if field:  # name[P]: bit P; name[P-1:0]: bits P-1..0 (P a parameter)
                port, p = field.group(1), int(params[field.group(2)])
                lo, bits = (0, p) if field.group(3) else (p, 1)
            self.taps.setdefault(valid, []).append((tap, getattr(dut, port), lo, bits))
        self.valids = {v: getattr(dut, v) for v in self.taps}
        self.dut = dut

    def registers(self) -> dict[str, int]:
        return {port: code for port, (_w, code) in
                p2_register_codes(self.manifest, self.params).items()}  # fmt: skip

    def cycles(self, stream_cycles: int) -> int:
        return LEAD + int(self.manifest["total_cycles"]) + 16

    def sample(self, cycle: int, samples: Samples) -> None:
        for valid, handle in self.valids.items():
            if handle.value == 1:
                for tap, h, lo, bits in self.taps[valid]:
                    v = _read(h)
                    if v is not None and bits:
                        v = (v >> lo) & ((1 << bits) - 1)
                    samples.setdefault(tap, []).append((cycle, v))

    def counters(self) -> dict[str, int | None]:
        return {sig: _read(getattr(self.dut, port)) for port, sig in P2_OVERFLOW_PORTS.items()}


@cocotb.test()
async def replay(dut) -> None:
    vec = Path(os.environ["RANGEFX_VECTORS"])
    dump = Path(os.environ["RANGEFX_DUMP"])
    dump.mkdir(parents=True, exist_ok=True)
    manifest = json.loads((vec / "manifest.json").read_text())
    if manifest["pipeline"] == "p2":
        probe = P2Probe(dut, manifest, json.loads(os.environ["RANGEFX_PARAMS"]))
    else:
        probe = P1Probe(dut, manifest)
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    for port, code in probe.registers().items():
        getattr(dut, port).value = code
    dut.rst.value = 1
    for p in ("tvalid", "tdata", "tuser", "tlast"):
        getattr(dut, f"s1_axis_{p}").value = 0
    streams = stream_entries(manifest)
    for k, entry in enumerate(streams):
        beats = read_stream_mem(vec / entry["path"], int(entry["word"]))
        src = AxiStreamSource(AxiStreamBus.from_prefix(dut, f"s{k}_axis"), dut.clk, byte_lanes=1)
        pause = [True] * LEAD + [not bool(v) for v in beats["valid"]]
        src.set_pause_generator(itertools.chain(pause, itertools.repeat(True)))
        for frame in _frames(beats):
            await src.send(frame)
    total = probe.cycles(max(int(e["count"]) for e in streams))

    samples: Samples = {}
    inputs: list[int] = []
    out_beats: list[tuple[int, int | None, int, int]] = []

    async def sample() -> None:
        cycle = 0
        while True:
            await RisingEdge(dut.clk)
            await ReadOnly()
            if dut.s0_axis_tvalid.value == 1:
                inputs.append(cycle)
            probe.sample(cycle, samples)
            if dut.m_axis_tvalid.value == 1:
                tuser, tlast = _read(dut.m_axis_tuser), _read(dut.m_axis_tlast)
                out_beats.append((cycle, _read(dut.m_axis_tdata), -1 if tuser is None else tuser,
                                  1 if tlast is None else tlast))  # fmt: skip
            cycle += 1

    await ClockCycles(dut.clk, 2)
    dut.rst.value = 0
    cocotb.start_soon(sample())
    await ClockCycles(dut.clk, total)
    overflows = probe.counters()
    flags = {k: _read(getattr(dut, k)) for k in probe.flags}
    write_dump(dump, vec, manifest, samples, inputs, out_beats, overflows, flags, total)
