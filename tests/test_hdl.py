"""Icarus Verilog replay of the P1 row + column filter stage (issue 6, ``hdl/``).

The vectors of a case are generated in-process (``rangefx vectors gen`` for the lab
crop, :func:`build_vectors` for random images), ``hdl/p1_rowcol.v`` is compiled with the
config's formats and modes, the input stream is replayed through it under cocotb, and
every dumped tap is compared bit for bit with ``rangefx vectors diff``. A mutant compiled
with truncation where rounding is configured must fail at the right pixel.
Skips when iverilog or cocotb is absent (``.ci/run`` installs both).
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.pipeline import Case
from rangefx.tools.cli import main
from rangefx.tools.cli.vectors import crop_case
from rangefx.tools.studies.cases import scene_case
from rangefx.vectors.generate import build_vectors, diff_dump, write_vectors
from rangefx.vectors.hdl import (
    HDL_DIR,
    HDL_SOURCES,
    ROWCOL_TAPS,
    rowcol_parameters,
    rowcol_registers,
)

if shutil.which("iverilog") is None or shutil.which("vvp") is None:
    pytest.skip("Icarus Verilog (iverilog) is not installed", allow_module_level=True)
cocotb_tools_runner = pytest.importorskip(
    "cocotb_tools.runner", reason="cocotb is not installed (pip install cocotb)"
)


def _fmt(text: str, quant: Quant, overflow: Overflow = Overflow.SAT) -> FixedFormat:
    return FixedFormat.from_string(text, quant, overflow)


def modes_config() -> P1Config:
    """Consistent variant with a different rounding or overflow mode on every stage signal
    (TRN, TRN_ZERO, RND_CONV, RND_ZERO, RND_INF, RND_MIN_INF; WRAP and SAT_SYM), and a
    narrow ``col_s2`` that wraps on strong edges."""
    d = P1Config.default(variant="consistent")
    return d.with_formats(
        bias_in=_fmt("u10.1", Quant.TRN),
        row_state=_fmt("u20.11", Quant.RND_CONV),
        row_r1=_fmt("u20.11", Quant.RND_CONV),
        row_r2=_fmt("s20.10", Quant.TRN, Overflow.WRAP),
        col_state=_fmt("u22.13", Quant.RND_ZERO),
        col_s1=_fmt("u19.10", Quant.RND_INF),
        col_s2=_fmt("s15.11", Quant.RND_MIN_INF, Overflow.WRAP),
        col2_state=_fmt("s23.13", Quant.TRN_ZERO, Overflow.SAT_SYM),
    ).with_(name="modes")


@functools.cache
def _lab():
    return scene_case("lab")


def _replay(vec: Path, config: P1Config, work: Path, stream: str = "e1", **over) -> Path:
    """Build p1_rowcol for ``config`` (parameters ``over`` overridden) and replay ``vec``."""
    _m, n = json.loads((vec / "manifest.json").read_text())["shape"]
    params = rowcol_parameters(config, n) | over
    runner = cocotb_tools_runner.get_runner("icarus")
    build = work / "build"
    runner.build(
        sources=[HDL_DIR / s for s in HDL_SOURCES],
        hdl_toplevel="p1_rowcol",
        parameters=params,
        build_dir=build,
        always=True,
    )
    dump = work / "dump"
    regs = rowcol_registers(config)
    env = {
        "RANGEFX_VECTORS": str(vec),
        "RANGEFX_DUMP": str(dump),
        "RANGEFX_STREAM": stream,
        "RANGEFX_POLE": str(regs["pole_raw"]),
        "RANGEFX_BIAS": str(regs["bias_raw"]),
        "PYTHONPATH": os.pathsep.join([str(HDL_DIR), *sys.path]),
    }
    results = runner.test(
        hdl_toplevel="p1_rowcol",
        test_module="test_p1_rowcol",
        test_dir=HDL_DIR,
        build_dir=build,
        extra_env=env,
    )
    from cocotb_tools.runner import get_results

    tests, fails = get_results(results)
    assert (tests, fails) == (1, 0)
    return dump


def _assert_all_match(vec: Path, dump: Path, stream: str = "e1") -> int:
    total = 0
    for tap in ROWCOL_TAPS:
        for suffix in (".mem", ".csv"):
            report = diff_dump(vec, dump / f"{stream}.{tap}{suffix}")
            assert report.ok, report.text()
            total += report.expected_count
    return total


@pytest.fixture
def cached_scene(monkeypatch):
    _lab()


@pytest.mark.parametrize("config_name", ["default", "modes"])
def test_lab_crop_replays_bit_exact(config_name, tmp_path, cached_scene):
    config = P1Config.default() if config_name == "default" else modes_config()
    toml = tmp_path / "config.toml"
    config.save(toml)
    vec = tmp_path / "vec"
    argv = ["vectors", "gen", "--scene", "lab", "--crop", "240", "256", "100", "124"]
    argv += ["--out", str(vec), "--config", str(toml), "--hblank", "4", "--gap-prob", "0.2"]
    assert main(argv) == 0
    dump = _replay(vec, config, tmp_path)
    assert _assert_all_match(vec, dump) == 2 * 7 * 16 * 24


@pytest.mark.parametrize("config_name", ["default", "modes"])
def test_random_scene_replays_bit_exact(config_name, tmp_path):
    config = P1Config.default() if config_name == "default" else modes_config()
    rng = np.random.default_rng(6)
    m, n = 12, 40
    im1 = rng.integers(0, 256, (m, n))
    im2 = np.clip(np.roll(im1, 1, axis=1) + rng.integers(-3, 4, (m, n)), 0, 255)
    case = Case(im1, im2, PinholeCamera(n, m, 50.0), MotionIncrement.stereo(0.1))
    vs = build_vectors(
        "p1",
        case,
        config,
        TimingConfig(hblank=2, vblank=5, gap_prob=0.3, seed=3),
        description={"source": "random", "seed": 6},
    )
    vec = tmp_path / "vec"
    vec.mkdir()
    write_vectors(vec, vs)
    dump = _replay(vec, config, tmp_path, stream="e2")
    assert _assert_all_match(vec, dump, stream="e2") == 2 * 7 * m * n


def test_truncating_mutant_is_caught_at_the_first_differing_pixel(tmp_path, cached_scene):
    """row_r2 is RND in the default config; the mutant truncates (TRN). The first pixel
    where the model's TRN and RND row_r2 differ is where ``vectors diff`` must point."""
    config = P1Config.default()
    vec = tmp_path / "vec"
    argv = ["vectors", "gen", "--scene", "lab", "--crop", "240", "256", "100", "124"]
    assert main([*argv, "--out", str(vec), "--hblank", "3"]) == 0
    dump = _replay(vec, config, tmp_path, R2_Q=int(Quant.TRN))
    mutant = config.with_formats(row_r2=_fmt("s20.10", Quant.TRN))
    case = crop_case(_lab(), [240, 256, 100, 124])
    runs = [build_vectors("p1", case, c, TimingConfig(hblank=3)).result for c in (config, mutant)]
    differ = np.flatnonzero(runs[0].taps["e1.row_r2"].ravel() != runs[1].taps["e1.row_r2"].ravel())
    assert differ.size > 0
    k = int(differ[0])
    report = diff_dump(vec, dump / "e1.row_r2.mem")
    assert not report.ok
    assert report.mismatches == differ.size
    first = report.first
    assert (first["row"], first["col"]) == (k // 24, k % 24)
    lat = 1 + 1 + 2  # input, bias, row filter
    assert first["cycle"] == (k // 24) * (24 + 3) + k % 24 + lat
    assert first["expected"] == int(runs[0].taps["e1.row_r2"].ravel()[k])
    assert first["got"] == int(runs[1].taps["e1.row_r2"].ravel()[k])
    # the other taps do not depend on row_r2 in the paper variant: still bit exact
    for tap in ("bias_in", "row_state", "row_r1", "col_state", "col_s1", "col_s2"):
        assert diff_dump(vec, dump / f"e1.{tap}.mem").ok
    assert main(["vectors", "diff", str(vec), str(dump / "e1.row_r2.mem"), "--json"]) == 1
