"""Replay a P1 or P2 vector directory through the Verilog (``hdl/``) and check every tap of
the RTL value for value and cycle for cycle (``rangefx hdl replay``, docs/hdl.md).

:func:`simulate` builds the pipeline's top (``hdl/p1_top.v``, ``hdl/p2_top.v``) with the
directory's parameters (:func:`rangefx.vectors.hdl.top_parameters`, ``p2_parameters``)
and runs one of two benches, both written against one protocol for both tops: the
cocotb bench ``hdl/test_top.py`` (through ``cocotb_tools.runner``; Icarus) or the plain
Verilog bench ``hdl/tb_top.v`` with a generated ``bench.vh`` (Icarus or Verilator);
:func:`compare` checks the dump against the vectors: per tap the samples, value
mismatches, cycle mismatches (a sample's cycle against the manifest's: its input beat
plus the declared latency) and the first mismatch; the AXI4-Stream output against the
``valid`` and ``range`` taps, word for word and cycle for cycle; the overflow counters
against the manifest's counts. P2's taps are compared in cycle order (its lanes leave
interleaved, one sample per cycle per tap), its output with one TLAST per lane group
(docs/hdl.md, "P2").

Before a run, every file of the directory the replay reads (the streams, the taps, the
reciprocal ROM) is checked against the manifest's size and SHA-256 (:func:`verify_files`):
both simulators read the same stimulus, the ``.stream.mem`` files. A failed build or
simulation raises ``ValueError`` quoting the tail of its log (the work directory may be
temporary). x/z bits in the RTL's outputs are mismatches, never a crash.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import formats as fmt_io
from .generate import load_manifest, read_tap, tap_cycles
from .hdl import (
    HDL_DIR,
    HDL_SOURCES,
    OVERFLOW_SIGNALS,
    P2_FLAGS,
    P2_SOURCES,
    P2_TOPLEVEL,
    RANGE_TAP_GROUPS,
    TOPLEVEL,
    bench_header,
    frontend_instances,
    p2_bench_header,
    p2_parameters,
    stream_entries,
    top_parameters,
    write_dump,
)

__all__ = [
    "BENCHES",
    "DEFAULT_BENCH",
    "OVERFLOW_SIGNALS",
    "SIMULATORS",
    "ReplayReport",
    "SimulatorMissing",
    "compare",
    "simulate",
    "verify_files",
]

#: Simulators the replay runs on, and the executable each needs.
SIMULATORS = {"icarus": "iverilog", "verilator": "verilator"}
#: The benches: cocotb (``hdl/test_top.py``) and the plain Verilog one (``hdl/tb_top.v``).
BENCHES = ("cocotb", "plain")
#: The bench ``auto`` picks per simulator (cocotb 2.1 cannot drive Verilator 5.006).
DEFAULT_BENCH = {"icarus": "cocotb", "verilator": "plain"}
_BENCH = "test_top"


class SimulatorMissing(RuntimeError):
    """The simulator (or cocotb) is not installed."""


def verify_files(directory: str | Path, manifest: Mapping) -> None:
    """Check every file the replay reads (each ``.mem`` and ``.bin`` the manifest lists:
    streams, taps, ROMs) against the manifest's size and SHA-256.

    Raises
    ------
    ValueError
        A file is missing, or its size or SHA-256 differs (the first such file named).
    """
    vec = Path(directory)
    for e in manifest["files"]:
        if not e["path"].endswith((".mem", ".bin")):
            continue
        path = vec / e["path"]
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise ValueError(f"{path}: {exc.strerror} (listed in the manifest)") from None
        if len(data) != int(e["size"]) or hashlib.sha256(data).hexdigest() != e["sha256"]:
            raise ValueError(
                f"{path}: {len(data)} bytes whose SHA-256 differs from the manifest's "
                f"({e['size']} bytes): the file was changed after `rangefx vectors gen`"
            )


def _log_tail(log: Path, lines: int = 4) -> str:
    """The last meaningful lines of a log, joined on one line (the log may be deleted
    with its temporary directory once the message is read)."""
    try:
        text = log.read_text(errors="replace").strip().splitlines()
    except OSError:
        return f"no log ({log.name} was not written)"
    keep = [ln.strip() for ln in text if ln.strip()]
    errors = [ln for ln in keep if any(w in ln for w in ("rror", "FAIL", "assert", "Exception"))]
    return " | ".join((errors or keep)[-lines:]) or f"{log.name} is empty"


def _rom_file(vec: Path, manifest: Mapping) -> Path | None:
    """The reciprocal divider's seed ROM of the directory, if its config has one."""
    rom = next((e for e in manifest["files"] if e["kind"] == "rom"
                and e["path"].endswith(".mem")), None)  # fmt: skip
    design = manifest["config"]["parsed"]["design"]
    if design.get("divider") != "reciprocal":
        return None
    if rom is None:
        raise ValueError(f"{vec / 'manifest.json'}: the reciprocal divider needs its seed ROM "
                         "(recip_rom.mem), which the manifest does not list")  # fmt: skip
    return vec / rom["path"]


def _rtl_taps(manifest: Mapping) -> list[str]:
    """The taps the RTL emits: both streams' front-end taps and the range stage's."""
    return [e["tap"] for e in manifest["files"]
            if e["kind"] in ("stream_tap", "range") and e["path"].endswith(".mem")]  # fmt: skip


def simulate(
    directory: str | Path,
    work: str | Path,
    sim: str = "icarus",
    bench: str = "auto",
    **overrides: int,
) -> dict:
    """Build and run the bench on ``directory``; the dump goes to ``work/dump``.

    ``bench``: ``cocotb`` (``hdl/test_top.py``), ``plain`` (``hdl/tb_top.v``) or ``auto``
    (:data:`DEFAULT_BENCH`: cocotb under Icarus, the plain bench under Verilator).
    ``overrides`` replace Verilog parameters (a mutation test compiles ``R2_Q=0``, say).
    Returns ``{"sim_s", "build_s", "dump", "status", "bench"}``.

    Raises
    ------
    SimulatorMissing
        ``sim``'s executable or cocotb is not installed.
    ValueError
        The directory is not P1 or P2 vectors; the bench cannot run on ``sim``; the
        simulation failed (its log is named).
    """
    if sim not in SIMULATORS:
        raise ValueError(f"unknown simulator {sim!r}; choose from {', '.join(SIMULATORS)}")
    bench = DEFAULT_BENCH[sim] if bench == "auto" else bench
    if bench not in BENCHES:
        raise ValueError(f"unknown bench {bench!r}; choose from auto, {', '.join(BENCHES)}")
    if bench == "cocotb" and sim == "verilator":
        raise ValueError("the cocotb bench needs Verilator >= 5.036 (cocotb 2.1); "
                         "use --bench plain with --sim verilator")  # fmt: skip
    if shutil.which(SIMULATORS[sim]) is None:
        raise SimulatorMissing(f"{sim}: '{SIMULATORS[sim]}' is not installed (not on PATH)")
    vec = Path(directory).resolve()
    manifest = load_manifest(vec)
    if manifest.get("pipeline") not in ("p1", "p2"):
        raise ValueError(f"{vec}: the RTL implements P1 and P2, not {manifest.get('pipeline')!r}")
    verify_files(vec, manifest)
    rom_file = _rom_file(vec, manifest)
    work = Path(work).resolve()
    dump = work / "dump"
    run = _run_cocotb if bench == "cocotb" else _run_plain
    timings = run(vec, manifest, rom_file, work, dump, sim, overrides)
    if not (dump / "status.json").exists():
        raise ValueError(f"the {sim} simulation wrote no dump: {_log_tail(work / 'sim.log')}")
    status = json.loads((dump / "status.json").read_text())
    return {**timings, "dump": dump, "status": status, "bench": bench}


def _top(manifest: Mapping, rom_file: Path | None, overrides: Mapping[str, int]) -> tuple:
    """The pipeline's top: (its module, its sources, its Verilog parameters)."""
    if manifest["pipeline"] == "p2":
        params = p2_parameters(manifest, rom_file) | dict(overrides)
        return P2_TOPLEVEL, P2_SOURCES, params
    return TOPLEVEL, HDL_SOURCES, top_parameters(manifest, rom_file) | dict(overrides)


def _run_cocotb(
    vec: Path, manifest: Mapping, rom_file: Path | None, work: Path, dump: Path, sim: str,
    overrides: Mapping[str, int],
) -> dict:  # fmt: skip
    """The cocotb bench (``hdl/test_top.py``, cocotbext-axi) through cocotb's runner."""
    try:
        from cocotb_tools.runner import get_results, get_runner
    except ImportError:
        raise SimulatorMissing("cocotb is not installed (pip install 'rangefx[hdl]')") from None
    toplevel, sources, params = _top(manifest, rom_file, overrides)
    build = work / f"build_{sim}"
    runner = get_runner(sim)
    t0 = time.perf_counter()
    try:
        runner.build(
            sources=[HDL_DIR / s for s in sources],
            hdl_toplevel=toplevel,
            includes=[HDL_DIR],
            parameters=params,
            build_dir=build,
            always=True,
            log_file=work / "build.log",
        )
    except (RuntimeError, SystemExit):  # cocotb's runner exits when a test fails
        tail = _log_tail(work / "build.log")
        raise ValueError(f"building the RTL with {sim} failed: {tail}") from None
    t1 = time.perf_counter()
    env = {
        "RANGEFX_VECTORS": str(vec),
        "RANGEFX_DUMP": str(dump),
        # the bench reads P2's bit fields (m_axis_tdata[Z_W]) from the built parameters
        "RANGEFX_PARAMS": json.dumps(params),
        "PYTHONPATH": os.pathsep.join([str(HDL_DIR), *sys.path]),
        # no pytest assertion rewriting: it would load the checkout's pytest config, whose
        # warning filter imports numba into the simulator (2-15 s a run, measured)
        "COCOTB_REWRITE_ASSERTION_FILES": "",
    }
    try:
        results = runner.test(
            hdl_toplevel=toplevel,
            test_module=_BENCH,
            test_dir=HDL_DIR,
            build_dir=build,
            extra_env=env,
            log_file=work / "sim.log",
            # in the work directory: cocotb's default is beside the bench, in hdl/ (named
            # after a pytest test when run under pytest), inside the installed package
            results_xml=str(work / "results.xml"),
        )
    except (RuntimeError, SystemExit):  # cocotb's runner exits when a test fails
        raise ValueError(f"the {sim} simulation failed: {_log_tail(work / 'sim.log')}") from None
    t2 = time.perf_counter()
    if get_results(results) != (1, 0):
        raise ValueError(f"the {sim} simulation failed: {_log_tail(work / 'sim.log')}")
    return {"build_s": t1 - t0, "sim_s": t2 - t1}


#: Idle cycles the Verilog bench drives before the streams (reset inside them).
_LEAD = 8


def _run_plain(
    vec: Path, manifest: Mapping, rom_file: Path | None, work: Path, dump: Path, sim: str,
    overrides: Mapping[str, int],
) -> dict:  # fmt: skip
    """The plain Verilog bench ``hdl/tb_top.v`` with the pipeline's generated ``bench.vh``,
    under Icarus (``iverilog -g2005``, ``vvp``) or Verilator (``--binary``: cocotb 2.1
    needs Verilator >= 5.036; this drives any Verilator 5); its text parsed into the dump."""
    build = work / f"build_{sim}"
    build.mkdir(parents=True, exist_ok=True)
    _toplevel, top_sources, _params = _top(manifest, rom_file, overrides)
    header = p2_bench_header if manifest["pipeline"] == "p2" else bench_header
    (build / "bench.vh").write_text(header(manifest, rom_file, _LEAD, overrides))
    sources = [str(HDL_DIR / s) for s in (*top_sources, "tb_top.v")]
    exe = build / ("obj" if sim == "verilator" else ".") / "tb"
    if sim == "verilator":
        cmd = ["verilator", "--binary", "-O3", "-j", "2", "-Wno-fatal", "-Wno-lint",
               "-Wno-style", "--top-module", "tb_top", f"-I{build}", f"-I{HDL_DIR}",
               "--Mdir", str(build / "obj"), "-o", "tb", *sources]  # fmt: skip
    else:
        cmd = ["iverilog", "-g2005", "-o", str(exe), f"-I{build}", f"-I{HDL_DIR}", *sources]
    t0 = time.perf_counter()
    with open(work / "build.log", "w") as log:
        rc = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=build).returncode
    if rc != 0:
        raise ValueError(f"building the RTL with {sim} failed: {_log_tail(work / 'build.log')}")
    t1 = time.perf_counter()
    streams = stream_entries(manifest)
    out = work / "tb_out.txt"
    args = [f"+STREAM{k}={vec / e['path']}" for k, e in enumerate(streams)] + [f"+OUT={out}"]
    run = [str(exe), *args] if sim == "verilator" else ["vvp", "-n", str(exe), *args]
    with open(work / "sim.log", "w") as log:
        rc = subprocess.run(run, stdout=log, stderr=subprocess.STDOUT, cwd=build).returncode
    t2 = time.perf_counter()
    if rc != 0 or not out.exists():
        raise ValueError(f"the {sim} simulation failed: {_log_tail(work / 'sim.log')}")
    dump.mkdir(parents=True, exist_ok=True)
    try:
        _dump_from_text(out, vec, manifest, dump)
    except AssertionError as exc:
        raise ValueError(f"the {sim} bench: {exc}") from None
    return {"build_s": t1 - t0, "sim_s": t2 - t1}


def _number(text: str, base: int) -> int | None:
    """A simulator's printed number, ``None`` when it holds x/z bits."""
    return None if any(c in "xXzZ" for c in text) else int(text, base)


def _dump_from_text(out: Path, vec: Path, manifest: Mapping, dump: Path) -> None:
    """Parse the plain bench's lines (``hdl/tb_top.v``) into the dump; x/z values become
    ``None`` (mismatches), counters or flags with x/z bits a count of ``None``. Counters
    are summed per signal (P1: over both front ends and the range stage's flag groups)."""
    p1 = manifest["pipeline"] == "p1"
    streams = list(frontend_instances(manifest)) if p1 else []
    signal_of = {e["tap"]: e["signal"] for e in manifest["files"]}
    samples: dict[str, list[tuple[int, int | None]]] = {}
    inputs: list[int] = []
    beats: list[tuple[int, int | None, int, int]] = []
    overflows: dict[str, int | None] = dict.fromkeys(OVERFLOW_SIGNALS, 0) if p1 else {}
    flags: dict[str, int | None] = {}
    cycles = 0

    def add(signal: str, count: int | None) -> None:
        before = overflows.get(signal, 0)
        overflows[signal] = None if before is None or count is None else before + count

    with open(out) as f:
        for text in f:
            part = text.split()
            kind = part[0]
            if kind == "T":
                name = part[2] if part[1] == "R" else f"{streams[int(part[1])]}.{part[2]}"
                samples.setdefault(name, []).append((int(part[3]), _number(part[4], 16)))
                cycles = max(cycles, int(part[3]) + 1)
            elif kind == "I":
                inputs.append(int(part[1]))
            elif kind == "M":
                tuser, tlast = _number(part[3], 10), _number(part[4], 10)
                user = -1 if tuser is None else tuser  # x: framing fails
                beats.append((int(part[1]), _number(part[2], 16), user, tlast is None or tlast))
            elif kind == "G":  # a range tap group's overflow flags, bit k = its k-th tap
                bits = _number(part[2], 16)
                for k, tap in enumerate(RANGE_TAP_GROUPS[part[1]][1]):
                    add(signal_of[tap], None if bits is None else bits >> k & 1)
            elif kind == "O":
                add(part[2], _number(part[3], 10))
            elif kind == "F":
                flags[part[1]] = _number(part[2], 10)
    write_dump(dump, vec, manifest, samples, inputs, beats, overflows, flags, cycles)


@dataclass
class ReplayReport:
    """Outcome of :func:`compare`: per-tap counts, the first mismatch, the totals."""

    taps: dict[str, dict] = field(default_factory=dict)
    first_mismatch: dict | None = None
    overflows: dict[str, dict] = field(default_factory=dict)
    m_axis: dict = field(default_factory=dict)
    flags: dict[str, int] = field(default_factory=dict)

    @property
    def value_mismatches(self) -> int:
        return sum(t["value_mismatches"] for t in self.taps.values())

    @property
    def cycle_mismatches(self) -> int:
        return sum(t["cycle_mismatches"] for t in self.taps.values())

    @property
    def overflow_mismatches(self) -> int:
        return sum(o["rtl"] != o["model"] for o in self.overflows.values())

    @property
    def ok(self) -> bool:
        return (
            self.value_mismatches == 0
            and self.cycle_mismatches == 0
            and self.overflow_mismatches == 0
            and self.m_axis.get("mismatches", 0) == 0
            and not any(self.flags.values())
        )

    def as_dict(self) -> dict:
        return {
            "ok": self.ok,
            "value_mismatches": self.value_mismatches,
            "cycle_mismatches": self.cycle_mismatches,
            "overflow_mismatches": self.overflow_mismatches,
            "first_mismatch": self.first_mismatch,
            "taps": self.taps,
            "overflows": self.overflows,
            "m_axis": self.m_axis,
            "flags": self.flags,
        }


def compare(directory: str | Path, dump: str | Path) -> ReplayReport:
    """Check a bench dump (:func:`simulate`) against the vectors of ``directory``."""
    vec, dump = Path(directory), Path(dump)
    manifest = load_manifest(vec)
    m, n = manifest["shape"]
    got = np.load(dump / "taps.npz")
    status = json.loads((dump / "status.json").read_text())
    report = ReplayReport()
    firsts = []
    for tap in _rtl_taps(manifest):
        entry = next(e for e in manifest["files"] if e["tap"] == tap and e["path"].endswith(".mem"))
        word = int(entry["word"])
        exp_v = fmt_io.to_unsigned(read_tap(vec, tap, manifest), word).astype(np.int64)
        exp_c = tap_cycles(vec, manifest, tap, int(entry["first_valid_cycle"]))
        # the RTL emits a tap's samples in cycle order: P2's interleaved lanes are not in
        # scan order (one sample per cycle, so the order is unique)
        order = np.argsort(exp_c, kind="stable")
        exp_v, exp_c = exp_v[order], exp_c[order]
        g_v = got[f"{tap}.value"] if f"{tap}.value" in got else np.zeros(0, np.int64)
        g_c = got[f"{tap}.cycle"] if f"{tap}.cycle" in got else np.zeros(0, np.int64)
        k = min(exp_v.size, g_v.size)
        bad_v = g_v[:k] != exp_v[:k]
        bad_c = g_c[:k] != exp_c[:k]
        extra = abs(exp_v.size - g_v.size)
        row = {
            "samples": int(exp_v.size),
            "got_samples": int(g_v.size),
            "value_mismatches": int(np.count_nonzero(bad_v)) + extra,
            "cycle_mismatches": int(np.count_nonzero(bad_c)) + extra,
            "first_mismatch": None,
        }
        bad = np.flatnonzero(bad_v | bad_c)
        if bad.size or extra:
            i = int(bad[0]) if bad.size else k
            at = int(order[i]) if i < order.size else i
            first = {
                "tap": tap,
                "index": i,
                "row": (at // n) % m,
                "col": at % n,
                "cycle": int(exp_c[i]) if i < exp_c.size else None,
                "got_cycle": int(g_c[i]) if i < g_c.size else None,
                "expected": _signed(exp_v, i, word, entry["signed"]),
                "got": _signed(g_v, i, word, entry["signed"]),
            }
            row["first_mismatch"] = first
            firsts.append(first)
        report.taps[tap] = row
    if firsts:
        report.first_mismatch = min(firsts, key=lambda f: (f["cycle"] is None, f["cycle"] or 0))
    model = manifest.get("overflows", {})
    for signal in sorted(set(status["overflows"]) | set(model)):
        rtl = int(status["overflows"].get(signal, 0))
        report.overflows[signal] = {"rtl": rtl, "model": int(model.get(signal, 0))}
    report.m_axis = _check_m_axis(vec, manifest, dump)
    names = P2_FLAGS if manifest["pipeline"] == "p2" else (
        "line_too_long", "align_error", "frame_too_big")  # fmt: skip
    report.flags = {k: int(status[k]) for k in names}
    return report


def _signed(codes: np.ndarray, i: int, word: int, signed: bool) -> int | None:
    if i >= codes.size or codes[i] < 0:
        return None
    return int(fmt_io.to_signed(codes[i : i + 1].astype(np.uint64), word, signed)[0])


def _check_m_axis(vec: Path, manifest: Mapping, dump: Path) -> dict:
    """The AXI4-Stream output against the vectors: per pixel the word ``{valid, range}``
    (``hdl/p1_top.v``) in the cycle the ``range`` tap declares, one line per image line,
    TUSER on the frame's first pixel. ``mismatches`` counts words that differ in value
    or cycle (and missing or extra ones), plus one for wrong framing."""
    m, n = manifest["shape"]
    out = np.load(dump / "m_axis.npz")
    words = [int(w) for w in out["words"]]
    cycles = out["cycles"] if "cycles" in out else np.full(len(words), -1, np.int64)
    entry = next(e for e in manifest["files"] if e["tap"] == "range" and e["path"].endswith(".mem"))
    rng = fmt_io.to_unsigned(read_tap(vec, "range", manifest), int(entry["word"]))
    valid = read_tap(vec, "valid", manifest)
    expected = [(int(v) << int(entry["word"])) | int(r) for v, r in zip(valid, rng, strict=True)]
    exp_c = tap_cycles(vec, manifest, "range", int(entry["first_valid_cycle"]))
    order = np.argsort(exp_c, kind="stable")  # P2: the interleaved order of its lanes
    expected, exp_c = [expected[i] for i in order], exp_c[order]
    k = min(len(words), len(expected))
    bad_v = [i for i in range(k) if words[i] != expected[i]]
    bad_c = [i for i in range(k) if int(cycles[i]) != int(exp_c[i])]
    extra = abs(len(words) - len(expected))
    lines = out["line_lengths"].tolist()
    tuser = out["first_tuser"].tolist()
    if manifest["pipeline"] == "p2":  # one TLAST per lane group (docs/p2_datapath.md)
        lanes = int(p2_parameters(manifest)["LANES"])
        want = [min(lanes, m - g) * n for g in range(0, m, lanes)]
    else:
        want = [n] * m
    framing = lines == want and tuser == [1] + [0] * (len(want) - 1)
    first = min(bad_v + bad_c, default=k if extra else None)
    where = None
    if first is not None:
        got = words[first] if first < len(words) else -1
        at = int(order[first]) if first < order.size else first
        where = {"index": first, "row": at // n % m, "col": at % n,
                 "cycle": int(exp_c[first]) if first < len(exp_c) else None,
                 "got_cycle": int(cycles[first]) if first < len(words) else None,
                 "expected": expected[first] if first < len(expected) else None,
                 "got": got if got >= 0 else None}  # fmt: skip
    return {"words": len(words), "mismatches": len(set(bad_v) | set(bad_c)) + extra
            + (0 if framing else 1), "value_mismatches": len(bad_v) + extra,
            "cycle_mismatches": len(bad_c) + extra, "lines": len(lines),
            "framing_ok": framing, "first_mismatch": where}  # fmt: skip
