"""cocotb driver and monitor for AXI4-Stream video (TVALID, TDATA, TUSER = sof, TLAST = eol).

:class:`AxisVideoSource` replays a packed stream file (``*.stream.bin``, one
``{sof, eol, valid, data}`` word per clock, written by ``rangefx vectors gen``) onto a
DUT's input ports, cycle for cycle, idle cycles included, so the DUT sees the exact
timing of the vectors. :class:`AxisVideoSink` samples a DUT's output beats (when TVALID
is high) and writes each data signal as a dump (``.mem`` words or ``.csv``) for
``rangefx vectors diff``. No back-pressure (P1 has none): TREADY is not used.

Use on any DUT, naming its ports::

    src = AxisVideoSource.from_file(dut.clk, "vec/e1.pix_in.stream.bin", 8,
                                    tvalid=dut.s_valid, tdata=dut.s_data,
                                    tuser=dut.s_sof, tlast=dut.s_eol)
    sink = AxisVideoSink(dut.clk, tvalid=dut.m_valid, data={"e1.col_s1": dut.col_s1})
    cocotb.start_soon(sink.run())
    await src.run()

Only numpy, bitstring and cocotb are imported (the simulator process stays light).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .formats import hex_digits, read_stream_bin

__all__ = ["AxisVideoSink", "AxisVideoSource"]


def _value_or_none(handle: Any) -> int | None:
    """Integer value of a signal, ``None`` when any bit is x/z/u."""
    bits = str(handle.value).strip()
    if bits and all(c in "01" for c in bits):
        return int(bits, 2)
    return None


class AxisVideoSource:
    """Drive AXI4-Stream-video beats, one word per clock cycle.

    Parameters
    ----------
    clk
        The clock handle; a new beat is presented after each rising edge.
    beats
        ``valid``, ``data``, ``sof``, ``eol`` integer arrays of equal length (cycles).
    tvalid, tdata, tuser, tlast
        The DUT's input handles.
    """

    def __init__(
        self, clk: Any, beats: dict[str, np.ndarray], *, tvalid: Any, tdata: Any, tuser: Any,
        tlast: Any,
    ) -> None:  # fmt: skip
        self.clk = clk
        self.beats = {k: np.asarray(v, dtype=np.int64) for k, v in beats.items()}
        self.ports = {"valid": tvalid, "data": tdata, "sof": tuser, "eol": tlast}

    @classmethod
    def from_file(cls, clk: Any, path: str | Path, word: int, **ports: Any) -> AxisVideoSource:
        """Beats from a ``.stream.bin`` of ``word``-bit data (see ``docs/vectors.md``)."""
        return cls(clk, read_stream_bin(Path(path).read_bytes(), word), **ports)

    @property
    def cycles(self) -> int:
        return int(self.beats["valid"].size)

    def idle(self) -> None:
        """Drive an idle beat (all zero)."""
        for port in self.ports.values():
            port.value = 0

    async def run(self) -> None:
        """Present every beat for one clock cycle, then go idle."""
        from cocotb.triggers import RisingEdge

        names = ("valid", "data", "sof", "eol")
        columns = [self.beats[k].tolist() for k in names]
        ports = [self.ports[k] for k in names]
        for values in zip(*columns, strict=True):
            for port, v in zip(ports, values, strict=True):
                port.value = v
            await RisingEdge(self.clk)
        self.idle()


class AxisVideoSink:
    """Record the data signals of every output beat whose TVALID is high.

    Parameters
    ----------
    clk
        The clock handle; outputs are sampled after each rising edge (read-only phase).
    tvalid
        Output valid handle.
    data
        Name -> handle of each data signal to record (e.g. ``{"e1.col_s1": dut.col_s1}``).
    tuser, tlast
        Optional sof/eol handles, recorded too (``sof``, ``eol``).
    """

    def __init__(
        self, clk: Any, *, tvalid: Any, data: dict[str, Any], tuser: Any = None, tlast: Any = None
    ) -> None:
        self.clk = clk
        self.tvalid = tvalid
        self.data = dict(data)
        self.flags = {k: h for k, h in (("sof", tuser), ("eol", tlast)) if h is not None}
        self.samples: dict[str, list[int | None]] = {k: [] for k in (*self.data, *self.flags)}
        self.cycles: list[int] = []

    async def run(self) -> None:
        """Sample forever (start it with ``cocotb.start_soon``)."""
        from cocotb.triggers import ReadOnly, RisingEdge

        cycle = 0
        while True:
            await RisingEdge(self.clk)
            await ReadOnly()
            if _value_or_none(self.tvalid) == 1:
                self.cycles.append(cycle)
                for name, handle in (*self.data.items(), *self.flags.items()):
                    self.samples[name].append(_value_or_none(handle))
            cycle += 1

    def mem_text(self, name: str) -> str:
        """``$readmemh`` dump of one data signal (``x`` words where unresolved)."""
        digits = hex_digits(len(self.data[name]))
        lines = [f"// {name}: RTL dump, {len(self.samples[name])} beats"]
        lines += ["x" * digits if v is None else f"{v:0{digits}x}" for v in self.samples[name]]
        return "\n".join(lines) + "\n"

    def write_dumps(self, directory: str | Path, suffix: str = ".mem") -> list[Path]:
        """Write ``<name>.mem`` (or ``.csv``: cycle,row,col,sof,eol,value) per data signal.

        The csv ``value`` column holds the unsigned code; ``row``/``col`` count beats
        from the first ``sof`` (``-1`` when the DUT gives no TUSER).
        """
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        out = []
        for name in self.data:
            p = d / f"{name}{suffix}"
            if suffix == ".csv":
                p.write_text(self._csv(name))
            else:
                p.write_text(self.mem_text(name))
            out.append(p)
        return out

    def _csv(self, name: str) -> str:
        rows, row, col = [], -1, -1
        sofs = self.samples.get("sof", [None] * len(self.cycles))
        eols = self.samples.get("eol", [None] * len(self.cycles))
        lines = ["cycle,row,col,sof,eol,value"]
        for k, cyc in enumerate(self.cycles):
            if sofs[k] == 1:
                row, col = 0, 0
            rows.append((row, col))
            v = self.samples[name][k]
            lines.append(
                f"{cyc},{row},{col},{sofs[k] or 0},{eols[k] or 0},{'x' if v is None else v}"
            )
            if row >= 0:
                col += 1
                if eols[k] == 1:
                    row, col = row + 1, 0
        return "\n".join(lines) + "\n"
