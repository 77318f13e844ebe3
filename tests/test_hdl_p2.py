"""HDL replay of P2 (``hdl/p2_top.v``, ``rangefx hdl replay``, docs/hdl.md "P2").

Vectors of small lab crops are replayed through ``hdl/p2_top.v`` with the cocotb bench
under Icarus (and the plain Verilog bench under Verilator when installed): every tap is
checked value for value and cycle for cycle (in cycle order: the lanes' interleaved
order), the AXI4-Stream output word for word, cycle for cycle and group for group, the
overflow counters against the manifest; both dividers, lanes at and above the loop
latency, blanking and input gaps, short last groups, a mixed-modes narrowed config
that overflows on several signals, and a stream of two frames (an odd number of groups
each) at the least vertical blanking the model's ``frame_period`` gives. The mutants
and the line-buffer read bound: ``tests/test_hdl_replay_benches.py``.
"""

from __future__ import annotations

import functools
import shutil

import pytest
from hdl_frames import two_frame_report, two_frames

from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p2 import P2_TAPS
from rangefx.rtl_model.p2.config import P2Config, divider_latency_p2, loop_latency
from rangefx.tools.studies.cases import crop_case, scene_case
from rangefx.vectors import replay
from rangefx.vectors.generate import build_vectors, write_vectors
from rangefx.vectors.hdl import HDL_DIR

if shutil.which("iverilog") is None or shutil.which("vvp") is None:
    pytest.skip("Icarus Verilog (iverilog) is not installed", allow_module_level=True)

CROP = (200, 208, 100, 124)  # 8 x 24 pixels of the lab scene: one short lane group
T_B = loop_latency(P2Config.default())  # the default lanes (reciprocal divider)
R_B = loop_latency(P2Config.default().with_(divider="restoring"))
# (2 T_b + 2) x 24: three groups of T_b (the last short), two of T_b + 1
TALL = (190, 190 + 2 * T_B + 2, 100, 124)
GAPS = TimingConfig(hblank=3, vblank=5, gap_prob=0.2, seed=4)
PLAIN = TimingConfig()


def _fmt(text: str, quant: Quant, overflow: Overflow = Overflow.SAT) -> FixedFormat:
    return FixedFormat.from_string(text, quant, overflow)


def modes_config() -> P2Config:
    """A different rounding or overflow mode on most signals (TRN, TRN_ZERO, RND_CONV,
    RND_ZERO, RND_INF, RND_MIN_INF; WRAP, SAT_SYM, SAT_ZERO) and words narrow enough
    that ``a``, ``c``, ``h``, ``q``, ``w``, ``lam``, ``z`` and ``e`` overflow on the crop."""
    return (
        P2Config.default()
        .with_formats(
            p2_a=_fmt("s12.8", Quant.RND_CONV, Overflow.SAT_SYM),
            p2_c=_fmt("u12.6", Quant.TRN, Overflow.SAT),
            p2_st=_fmt("u26.8", Quant.RND_INF),
            p2_den=_fmt("u50.20", Quant.RND_ZERO),
            p2_r=_fmt("u26.25", Quant.RND_MIN_INF),
            p2_h=_fmt("s20.2", Quant.TRN_ZERO, Overflow.WRAP),
            p2_q=_fmt("s16.2", Quant.RND, Overflow.SAT_ZERO),
            p2_w=_fmt("s22.6", Quant.RND_CONV, Overflow.SAT_SYM),
            p2_lam=_fmt("s20.11", Quant.TRN, Overflow.WRAP),
            p2_z=_fmt("s20.12", Quant.RND_ZERO, Overflow.SAT),
            p2_e=_fmt("s10.5", Quant.RND_INF, Overflow.SAT_SYM),
        )
        .with_(name="modes")
    )


@functools.cache
def _lab():
    return scene_case("lab")


def _vectors(tmp_path, config: P2Config, crop=CROP, timing: TimingConfig = PLAIN,
             name: str = "vec"):  # fmt: skip
    case = crop_case(_lab(), list(crop))
    vs = build_vectors("p2", case, config, timing, description={"scene": "lab", "crop": crop})
    vec = tmp_path / name
    vec.mkdir()
    write_vectors(vec, vs)
    return vec, vs


def _replay(vec, tmp_path, sim: str = "icarus", **overrides) -> replay.ReplayReport:
    run = replay.simulate(vec, tmp_path / f"work_{sim}", sim, **overrides)
    return replay.compare(vec, run["dump"])


def _check_exact(report: replay.ReplayReport, m: int, n: int, groups: int) -> None:
    assert set(report.taps) == set(P2_TAPS)
    for tap, row in report.taps.items():
        assert (row["samples"], row["got_samples"]) == (m * n, m * n), tap
    assert report.value_mismatches == 0 and report.cycle_mismatches == 0, report.first_mismatch
    axis = {k: report.m_axis[k] for k in ("words", "mismatches", "lines", "framing_ok")}
    assert axis == {"words": m * n, "mismatches": 0, "lines": groups, "framing_ok": True}
    assert report.ok, report.as_dict()


CASES = [  # (id, divider, lanes, crop, timing, groups)
    (f"recip-L{T_B}-short", "reciprocal", 0, CROP, PLAIN, 1),
    (f"recip-L{T_B + 1}-gaps", "reciprocal", T_B + 1, TALL, GAPS, 2),
    (f"recip-L{T_B}-gaps-3groups", "reciprocal", 0, TALL, GAPS, 3),
    (f"restoring-L{R_B}", "restoring", 0, CROP, TimingConfig(hblank=2), 1),
]


@pytest.mark.parametrize(("divider", "lanes", "crop", "timing", "groups"),
                         [c[1:] for c in CASES], ids=[c[0] for c in CASES])  # fmt: skip
def test_p2_replays_value_and_cycle_exact(divider, lanes, crop, timing, groups, tmp_path):
    config = P2Config.default().with_(divider=divider, lanes=lanes)
    vec, _vs = _vectors(tmp_path, config, crop, timing)
    report = _replay(vec, tmp_path)
    _check_exact(report, crop[1] - crop[0], crop[3] - crop[2], groups)


def test_overflow_counts_equal_the_models(tmp_path):
    """The mixed-modes narrowed config: every tap exact, and the RTL's overflow counters
    equal the manifest's counts on every signal (several of them non-zero)."""
    vec, _vs = _vectors(tmp_path, modes_config(), TALL, GAPS)
    report = _replay(vec, tmp_path)
    _check_exact(report, TALL[1] - TALL[0], TALL[3] - TALL[2], 3)
    counted = {s: o["rtl"] for s, o in report.overflows.items() if o["rtl"]}
    assert len(counted) >= 5, counted
    assert all(o["rtl"] == o["model"] for o in report.overflows.values()), report.overflows


@pytest.mark.skipif(shutil.which("verilator") is None, reason="Verilator is not installed")
def test_verilator_replays_value_and_cycle_exact(tmp_path):
    config = P2Config.default().with_(lanes=T_B + 1)
    vec, _vs = _vectors(tmp_path, config, TALL, GAPS)
    report = _replay(vec, tmp_path, "verilator")
    _check_exact(report, TALL[1] - TALL[0], TALL[3] - TALL[2], 2)


def test_cli_replays_a_p2_directory(tmp_path, capsys):
    """``rangefx hdl replay DIR --json`` on a P2 directory: exit 0, ok."""
    import json

    from rangefx.tools.cli import main

    vec, _vs = _vectors(tmp_path, P2Config.default(), CROP)
    assert main(["hdl", "replay", str(vec), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["ok"] and out["value_mismatches"] == 0 and out["cycle_mismatches"] == 0


def test_overrun_flag_when_the_lanes_cannot_sustain_the_rate(tmp_path):
    """Vectors at one pixel per clock with ``T_b`` lanes, the RTL compiled with a divider
    9 cycles slower (loop latency ``T_b + 9`` > ``T_b`` lanes): the sweep cannot keep up,
    and the hardware raises ``overrun`` (the model's assertion) instead of sweeping
    overwritten lines silently."""
    vec, _vs = _vectors(tmp_path, P2Config.default(), TALL)
    t_div = divider_latency_p2("reciprocal", P2Config.default().formats["p2_r"].word)
    report = _replay(vec, tmp_path, T_DIV=t_div + 9)
    assert report.flags["overrun"] == 1 and not report.ok
    assert report.flags["align_error"] == 0 and report.flags["line_too_long"] == 0


def test_line_too_long_flag(tmp_path):
    """Lines of 24 pixels into an RTL built for 20: the sticky ``line_too_long`` (the
    extra pixels never reach the line buffer)."""
    vec, _vs = _vectors(tmp_path, P2Config.default(), CROP)
    report = _replay(vec, tmp_path, WIDTH=20)
    assert report.flags["line_too_long"] == 1 and not report.ok


def test_timing_wrapper_elaborates(tmp_path):
    """``p2_timing_wrapper`` (the place-and-route top: registers in a serial chain, the
    overflow counters unconnected) elaborates under Icarus and fits a CABGA381 package."""
    import subprocess

    from rangefx.vectors.hdl import P2_SOURCES, p2_config_parameters, p2_timing_wrapper

    text, pins = p2_timing_wrapper(p2_config_parameters(P2Config.default(), (16, 64)))
    (tmp_path / "w.v").write_text(text)
    sources = [str(HDL_DIR / s) for s in P2_SOURCES]
    cmd = ["iverilog", "-g2005", "-s", "p2_timing_top", "-o", str(tmp_path / "w.vvp"),
           f"-I{HDL_DIR}", *sources, str(tmp_path / "w.v")]  # fmt: skip
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert pins < 200


def short_crop(config: P2Config) -> tuple[int, int, int, int]:
    """A crop of ``2 L + 2`` lines x 6 at the default's ``L`` lanes: three groups (an odd
    number), the last one of 2 lines."""
    lanes = config.effective_lanes()
    return (190, 190 + 2 * lanes + 2, 100, 106)


def least_blanking(config: P2Config, m: int, n: int) -> int:
    """The least vertical blanking (no horizontal blanking, no gaps) of a stream of
    ``m x n`` frames: the model's :func:`frame_period` less the frame's ``m n`` beats."""
    import numpy as np

    from rangefx.rtl_model.p2.model import frame_period

    firsts = np.arange(m, dtype=np.int64) * n
    return frame_period(firsts, firsts + n - 1, n, config, 0) - m * n


@pytest.mark.parametrize("case", ["drained", "least", "least-1"])
def test_two_frames_back_to_back(case, tmp_path):
    """A stream of two frames: ``2 L + 2`` lines in ``L`` lanes (three groups, an odd
    number, the last one short), the second after ``vblank`` idle cycles. ``drained``:
    frame 1's last output comes before frame 2's first beat; ``least``: the least
    blanking after which frame 2's schedule is a lone frame's (:func:`least_blanking`).
    In both, frame 2's taps and output equal frame 1's at frame 1's cycles + the stream's
    frame period. One cycle less: frame 2's second group's first pixel would overwrite
    the line buffer frame 1's short last group's sweep still reads (``overrun``)."""
    import json

    config = P2Config.default()
    crop = short_crop(config)
    lanes = config.effective_lanes()
    m, n = crop[1] - crop[0], crop[3] - crop[2]
    assert len(range(0, m, lanes)) % 2 == 1
    vblank = least_blanking(config, m, n) - (case == "least-1")
    if case == "drained":
        one, _vs = _vectors(tmp_path, config, crop, PLAIN, name="one")
        vblank = json.loads((one / "manifest.json").read_text())["total_cycles"] - m * n
    vec, _vs = _vectors(tmp_path, config, crop, TimingConfig(vblank=vblank))
    count = two_frames(vec, tmp_path / "two")
    run = replay.simulate(tmp_path / "two", tmp_path / "work", "icarus")
    groups = [min(lanes, m - g) * n for g in range(0, m, lanes)]
    report = two_frame_report(vec, run["dump"], count, P2_TAPS, groups)
    flags = [report["status"][f] for f in ("align_error", "line_too_long", "overrun")]
    if case == "least-1":
        assert flags == [0, 0, 1], report
        return
    assert flags == [0, 0, 0] and report["framing_ok"] and report["counters_ok"], report
    assert report["values"] == 0 and report["cycles"] == 0, report
