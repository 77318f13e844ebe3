"""The two replay benches and what they must catch (``rangefx hdl replay``, docs/hdl.md).

* One protocol, two benches: for every pipeline with RTL (``RTL_TOPS``) and both
  dividers, the cocotb bench (``hdl/test_top.py``, Icarus) replays a small lab crop with
  blanking and input gaps exactly (every tap value and cycle, the AXI output, the
  overflow counts of the manifest) and writes the same dump as the plain Verilog bench
  (``hdl/tb_top.v``).
* The AXI4-Stream output check compares cycles (every pipeline with RTL).
* Mutants of P2's RTL, patched in a copy of ``hdl/`` and replayed through the CLI or
  ``rangefx.api.replay``, are reported at the first mismatch computed without the RTL:
  a rounding mode of the sweep engine (the model of the same change gives the first
  differing sample and every tap's count), the sweep's lane tags one cycle late beside
  the divider (every write-back sample one cycle late), the one sweep buffer written in
  the forward pass's column order (the first forward read that the next group's sweep
  overwrote first).
* P2's line-buffer read bound (docs/p2_datapath.md, Timing): the default schedule sits on
  it with equality; one cycle past it the model raises and the RTL raises ``overrun``.

Expectations come from the vectors, the model and the manifest, never fixed cycle numbers.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import re
import shutil

import numpy as np
import pytest

from rangefx import api
from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.fixedpoint import Quant
from rangefx.rtl_model.p2.config import P2Config, loop_latency
from rangefx.rtl_model.p2.model import FWD_READ, W_OFFSET, group_starts
from rangefx.rtl_model.registry import get_pipeline
from rangefx.tools.cli import main
from rangefx.tools.studies.cases import crop_case, scene_case
from rangefx.tools.studies.synth import RTL_TOPS
from rangefx.vectors import replay
from rangefx.vectors.generate import build_vectors, load_manifest, tap_cycles, write_vectors
from rangefx.vectors.hdl import (
    HDL_DIR,
    QUANT_CODES,
    p2_parameters,
    read_stream_mem,
    stream_entries,
)

if shutil.which("iverilog") is None or shutil.which("vvp") is None:
    pytest.skip("Icarus Verilog (iverilog) is not installed", allow_module_level=True)
pytest.importorskip("cocotb_tools.runner", reason="cocotb is not installed (pip install cocotb)")
pytest.importorskip("cocotbext.axi", reason="cocotbext-axi is not installed")

GAPS = TimingConfig(hblank=2, vblank=3, gap_prob=0.15, seed=7)
#: Per pipeline: a lab crop (rows r0:r1, columns c0:c1) small enough for CI.
CROPS = {"p1": (240, 246, 100, 112), "p2": (200, 208, 100, 120)}
#: The taps of P2 that its sweep engine's write-back register holds.
WRITE_BACK = ("a", "c", "den", "r", "s", "h", "q")


@functools.cache
def _lab():
    return scene_case("lab")


def _vectors(tmp_path, pipeline: str, config, crop, timing: TimingConfig, name: str = "vec"):
    case = crop_case(_lab(), list(crop))
    vs = build_vectors(pipeline, case, config, timing, description={"crop": list(crop)})
    vec = tmp_path / name
    vec.mkdir()
    write_vectors(vec, vs)
    return vec, vs


def _load(dump) -> tuple[dict, dict, dict]:
    taps = dict(np.load(dump / "taps.npz"))
    axis = dict(np.load(dump / "m_axis.npz"))
    status = json.loads((dump / "status.json").read_text())
    # the benches count cycles from different origins; the dump's cycles are the files'
    return taps, axis, {k: v for k, v in status.items() if k not in ("cycles", "stream_offset")}


@pytest.mark.parametrize("divider", ["reciprocal", "restoring"])
@pytest.mark.parametrize("pipeline", list(RTL_TOPS))
def test_the_cocotb_bench_replays_exactly_and_writes_the_plain_benchs_dump(
    pipeline, divider, tmp_path
):
    config = get_pipeline(pipeline).default_config(divider=divider)
    vec, _vs = _vectors(tmp_path, pipeline, config, CROPS[pipeline], GAPS)
    cocotb = replay.simulate(vec, tmp_path / "cocotb", "icarus", "cocotb")
    assert cocotb["bench"] == "cocotb"
    report = replay.compare(vec, cocotb["dump"])
    manifest = load_manifest(vec)
    m, n = manifest["shape"]
    assert report.ok, report.first_mismatch
    assert report.value_mismatches == 0 and report.cycle_mismatches == 0
    assert all(row["got_samples"] == row["samples"] > 0 for row in report.taps.values())
    assert report.m_axis["words"] == m * n and report.m_axis["mismatches"] == 0
    for signal, count in manifest["overflows"].items():
        assert report.overflows[signal] == {"rtl": count, "model": count}, signal
    plain = replay.simulate(vec, tmp_path / "plain", "icarus", "plain")
    got, want = _load(cocotb["dump"]), _load(plain["dump"])
    for a, b in zip(got[:2], want[:2], strict=True):
        assert sorted(a) == sorted(b)
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    assert got[2] == want[2]


@pytest.mark.parametrize("pipeline", list(RTL_TOPS))
def test_the_axi_output_check_compares_cycles(pipeline, tmp_path):
    """The RTL's output beats one cycle late, values unchanged (as an extra register
    before ``m_axis`` would give): the AXI check fails on its own, every word a cycle
    mismatch, the taps exact."""
    config = get_pipeline(pipeline).default_config()
    vec, _vs = _vectors(tmp_path, pipeline, config, CROPS[pipeline], GAPS)
    dump = replay.simulate(vec, tmp_path / "work", "icarus", "plain")["dump"]
    assert replay.compare(vec, dump).ok
    out = dict(np.load(dump / "m_axis.npz"))
    out["cycles"] = out["cycles"] + 1
    np.savez(dump / "m_axis.npz", **out)
    report = replay.compare(vec, dump)
    assert report.value_mismatches == 0 and report.cycle_mismatches == 0  # the taps
    m, n = load_manifest(vec)["shape"]
    axis = report.m_axis
    assert (axis["cycle_mismatches"], axis["value_mismatches"]) == (m * n, 0)
    assert axis["first_mismatch"]["got_cycle"] == axis["first_mismatch"]["cycle"] + 1
    assert not report.ok


def _patched_hdl(tmp_path, monkeypatch, pattern: str, replacement: str):
    """A copy of ``hdl/`` with one match of ``pattern`` in ``p2_top.v`` replaced; the
    replay builds from it (the package's ``hdl/`` is untouched)."""
    hdl = tmp_path / "hdl"
    shutil.copytree(HDL_DIR, hdl)
    text = (hdl / "p2_top.v").read_text()
    assert len(re.findall(pattern, text)) == 1, f"{pattern!r} is not one line of p2_top.v"
    (hdl / "p2_top.v").write_text(re.sub(pattern, replacement, text))
    monkeypatch.setattr(replay, "HDL_DIR", hdl)


def _cycles(vec, manifest, tap: str) -> np.ndarray:
    entry = next(e for e in manifest["files"] if e["tap"] == tap and e["path"].endswith(".mem"))
    return tap_cycles(vec, manifest, tap, int(entry["first_valid_cycle"]))


def test_a_rounding_mutant_of_the_sweep_engine_is_reported_where_its_model_differs(
    tmp_path, monkeypatch, capsys
):
    """The S~ cast of the sweep engine (``c_s``) compiled with TRN instead of the config's
    RND, in a patched copy of the RTL, replayed through the CLI: the first mismatch is
    the earliest (cycle) sample where the model of the same change differs from the
    model, at its tap, cycle, row and column, with its expected and mutant values; each
    tap's value mismatches are the two models' differing samples; no cycle mismatch."""
    config = P2Config.default()
    assert config.formats["p2_st"].quant != Quant.TRN
    vec, vs = _vectors(tmp_path, "p2", config, CROPS["p2"], GAPS)
    mutant = config.with_formats(
        p2_st=dataclasses.replace(config.formats["p2_st"], quant=Quant.TRN)
    )
    _mvec, mvs = _vectors(tmp_path, "p2", mutant, CROPS["p2"], GAPS, name="mutant")
    _patched_hdl(tmp_path, monkeypatch, r"ST_Q(, ST_O\) c_s )", f"{QUANT_CODES['TRN']}\\1")
    assert main(["hdl", "replay", str(vec), "--bench", "plain", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)

    manifest = load_manifest(vec)
    m, n = manifest["shape"]
    want, got = vs.result.taps, mvs.result.taps
    differ = []  # (cycle, tap, row, col) of every sample where the two models differ
    for tap in want:
        cycles = _cycles(vec, manifest, tap).reshape(m, n)
        bad = np.argwhere(want[tap] != got[tap])
        differ += [(int(cycles[j, i]), tap, int(j), int(i)) for j, i in bad]
        assert out["taps"][tap]["value_mismatches"] == len(bad), tap
    assert out["taps"]["s"]["value_mismatches"] > 0
    cycle = min(differ)[0]
    first = out["first_mismatch"]
    tap, row, col = first["tap"], first["row"], first["col"]
    assert (cycle, tap, row, col) in differ, (first, [d for d in differ if d[0] == cycle])
    assert (first["cycle"], first["got_cycle"]) == (cycle, cycle)
    assert (first["expected"], first["got"]) == (int(want[tap][row, col]),
                                                  int(got[tap][row, col]))  # fmt: skip
    assert out["cycle_mismatches"] == 0 and out["m_axis"]["cycle_mismatches"] == 0


def test_the_lanes_tag_delay_off_by_one_is_reported_at_the_first_write_back(tmp_path, monkeypatch):
    """The sweep engine's write-back tag taken one stage too late (``WB_T``, in a patched
    copy; the lanes' state writes and the taps' strobes a cycle late, the loop's values
    not), replayed through ``rangefx.api.replay``: every write-back sample leaves one
    cycle late, so the first mismatch is the earliest write-back sample of the
    manifest (its cycle, row and column; got one cycle later) and each write-back tap
    has one cycle mismatch per pixel; the input taps are exact in cycle."""
    vec, _vs = _vectors(tmp_path, "p2", P2Config.default(), CROPS["p2"], GAPS)
    _patched_hdl(
        tmp_path, monkeypatch, r"(localparam integer WB_T = SWEEP_READ \+ T_B)(;)", r"\1 + 1\2"
    )
    result = api.replay(vec, "icarus", bench="plain")
    assert not result.ok
    figures = result.figures
    manifest = load_manifest(vec)
    m, n = manifest["shape"]
    cycles = {t: _cycles(vec, manifest, t) for t in WRITE_BACK}
    first_cycle = min(int(c.min()) for c in cycles.values())
    at = int(np.argmin(cycles["s"]))
    assert int(cycles["s"][at]) == first_cycle  # every write-back tap leaves together
    first = figures["first_mismatch"]
    assert first["tap"] in WRITE_BACK, first
    assert (first["cycle"], first["got_cycle"]) == (first_cycle, first_cycle + 1), first
    assert (first["row"], first["col"]) == (at // n, at % n), first
    for tap in WRITE_BACK:
        assert figures["taps"][tap]["cycle_mismatches"] == m * n, tap
    for tap in ("d", "g_hat"):
        assert figures["taps"][tap]["cycle_mismatches"] == 0, tap


def test_the_sweep_buffer_written_in_the_forward_passs_order_is_reported_at_the_first_overwrite(
    tmp_path, monkeypatch
):
    """The one sweep buffer's write address taken with the parity of the forward pass
    running beside the sweep (the previous group's) instead of the sweep's own group, in a
    patched copy: group 1's sweep then writes its entry (lane, k) on the word where group
    0's forward pass reads column k, and overwrites those read later than the write (slot
    n-1-k of the sweep against slot k of the forward pass). The first mismatch is the
    ``w`` tap (the first product of the entry read) of the earliest such read, at its cycle,
    row and column, computed from the model's stamps (write-back: tap ``a``; read: tap
    ``e`` - FWD_READ); no cycle mismatch."""
    config = P2Config.default()
    lanes = config.effective_lanes()
    crop = (190, 190 + 2 * lanes, 100, 116)  # two full groups
    vec, vs = _vectors(tmp_path, "p2", config, crop, GAPS)
    manifest = load_manifest(vec)
    m, n = manifest["shape"]
    write = _cycles(vec, manifest, "a").reshape(m, n)
    read = _cycles(vec, manifest, "e").reshape(m, n) - FWD_READ
    # group 0's reads of columns k <= n-2 that group 1's write of (lane, k) comes before
    late = write[lanes:, : n - 1] < read[:lanes, : n - 1]
    assert late.any() and not late.all()
    at = np.argwhere(late)
    j, k = at[np.argmin(read[:lanes, : n - 1][late])]
    taps = vs.result.taps
    # the overwriting entry differs in S~_k+1 and Q~_k+1 (the w product's operands)
    assert taps["s"][j, k + 1] != taps["s"][j + lanes, k + 1]
    assert taps["q"][j, k + 1] != taps["q"][j + lanes, k + 1]
    _patched_hdl(tmp_path, monkeypatch, r"(wire sb_wbank = )tg9\[0\](;)", r"\1fw_bank\2")
    result = api.replay(vec, "icarus", bench="plain")
    assert not result.ok
    first = result.figures["first_mismatch"]
    w_at = int(read[j, k]) + W_OFFSET
    assert w_at == int(_cycles(vec, manifest, "w").reshape(m, n)[j, k])
    assert (first["tap"], first["row"], first["col"]) == ("w", j, k), first
    assert (first["cycle"], first["got_cycle"]) == (w_at, w_at), first
    assert first["expected"] != first["got"], first
    assert result.figures["cycle_mismatches"] == 0


# -- the line-buffer read bound ---------------------------------------------------------------
def _line_cycles(vec, manifest) -> tuple[np.ndarray, np.ndarray]:
    """Input cycle of every line's first and last pixel, from the E1 stream file."""
    m, n = manifest["shape"]
    entry = stream_entries(manifest)[0]
    beats = np.flatnonzero(read_stream_mem(vec / entry["path"], int(entry["word"]))["valid"])
    lines = beats.reshape(m, n)
    return lines[:, 0].copy(), lines[:, n - 1].copy()


def test_the_default_schedule_is_on_the_line_buffer_read_bound_and_one_cycle_past_raises(
    tmp_path,
):
    """Lanes = loop latency, no blanking: group 2's first pixel is written into the line
    buffer bank in the cycle right after group 0's sweep reads it for the last time (lane
    L-1, column 0 at ``b_0 + (n-1) P_b + L - 1``, docs/p2_datapath.md), so the bound holds
    with equality; the same lines with group 2 one cycle earlier must be rejected."""
    config = P2Config.default()
    lanes = config.effective_lanes()
    crop = (190, 190 + 2 * lanes + 2, 100, 116)  # three groups, the last one short
    vec, _vs = _vectors(tmp_path, "p2", config, crop, TimingConfig())
    manifest = load_manifest(vec)
    m, n = manifest["shape"]
    firsts, lasts = _line_cycles(vec, manifest)
    starts, info = group_starts(firsts, lasts, n, config, 0)
    last_read = int(starts[0, 0]) + (n - 1) * info["backward_period"] + lanes - 1
    write = int(_cycles(vec, manifest, "d").reshape(m, n)[2 * lanes, 0])  # the d/Ĝ register
    assert write == last_read + 1
    early = np.arange(m) >= 2 * lanes
    with pytest.raises(ValueError, match="overwrite the line buffer"):
        group_starts(firsts - early, lasts - early, n, config, 0)


@pytest.mark.parametrize("past", [0, 1], ids=["on-the-bound", "one-cycle-past"])
def test_the_rtl_raises_overrun_exactly_past_the_line_buffer_read_bound(past, tmp_path):
    """The RTL's guard on the same bound: vectors with lanes = the loop latency ``T_b`` and
    hblank 1, the RTL compiled with a divider one cycle slower (its sweep period
    ``T_b + 1``). Group 0's last read then comes ``(n-1) - (L+1) hblank`` cycles later than
    on the model's schedule: with ``n = (L+1) hblank + 1`` the bound holds with equality
    (no ``overrun``), one column more and group 2's first pixel lands in the cycle of
    that read (``overrun``)."""
    config = P2Config.default()
    lanes = loop_latency(config)
    config = config.with_(lanes=lanes)
    hblank = 1
    n = (lanes + 1) * hblank + 1 + past
    crop = (190, 190 + 2 * lanes + 2, 100, 100 + n)
    vec, _vs = _vectors(tmp_path, "p2", config, crop, TimingConfig(hblank=hblank))
    t_div = int(p2_parameters(load_manifest(vec))["T_DIV"])
    run = replay.simulate(vec, tmp_path / "work", "icarus", "plain", T_DIV=t_div + 1)
    status = run["status"]
    assert (status["overrun"], status["line_too_long"], status["align_error"]) == (past, 0, 0)


def test_the_cocotb_bench_under_verilator_is_one_error_line(tmp_path, capsys):
    """cocotb 2.1 cannot drive Verilator 5.006: refused before any build, one line."""
    vec, _vs = _vectors(tmp_path, "p2", P2Config.default(), CROPS["p2"], TimingConfig())
    assert main(["hdl", "replay", str(vec), "--sim", "verilator", "--bench", "cocotb"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error: the cocotb bench"), err
    assert "--bench plain" in err[0]
