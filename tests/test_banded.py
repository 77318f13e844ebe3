"""A large frame run in bands of lines (issue 40 item 2; docs/guarantees.md, "Which
commands stream"): for every pipeline of the registry whose lines are independent, a
banded run equals the whole-frame run bit for bit; every other pipeline refuses bands."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rangefx import api
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow
from rangefx.rtl_model.registry import PIPELINES
from rangefx.tools.cli import main
from rangefx.tools.report import json_safe
from rangefx.tools.studies.banded import run_in_bands

BANDED = [name for name, pipe in PIPELINES.items() if pipe.line_independent]
WHOLE = [name for name, pipe in PIPELINES.items() if not pipe.line_independent]
MAPS = ("range", "valid", "range_raw", "in_cycles", "out_cycles")


def _narrow(pipeline: str):
    """The default config with every datapath signal 3 bits narrower (integer bits), in
    saturating and wrapping modes alternately: a run that overflows."""
    config = PIPELINES[pipeline].default_config()
    host = set(config.HOST_REGISTERS)
    formats = {}
    for k, name in enumerate(config.signals()[1:]):
        f = config.fmt(name)
        if name in host or f.word - 3 < max(2, f.frac + (1 if f.signed else 0)):
            continue
        ovf = Overflow.SAT if k % 2 else Overflow.WRAP
        formats[name] = FixedFormat(f.signed, f.word - 3, f.frac, f.quant, ovf)
    return config.with_formats(**formats)


def _text(figures: dict) -> str:
    return json.dumps(json_safe(figures), sort_keys=True)


def test_the_registry_has_a_banded_pipeline():
    assert "p2" in BANDED  # P2's sweep and its golden G5 run along each line


@pytest.mark.parametrize("pipeline", BANDED)
@pytest.mark.parametrize("formats", ["default", "narrow"])
@pytest.mark.parametrize("band_lines", [1, 5, 16])
def test_a_banded_run_is_the_whole_frame_run(pipeline, formats, band_lines):
    """Every output map, tap, cycle stamp, overflow count, min/max and figure of a run in
    bands of 1, 5 or 16 lines (a short last band) equals the whole-frame run's, with the
    default formats and with narrow ones that overflow."""
    case = api.scene_case("lab", size=(23, 40))
    config = PIPELINES[pipeline].default_config() if formats == "default" else _narrow(pipeline)
    whole = api.run(case, config, pipeline=pipeline)
    banded = api.run(case, config, pipeline=pipeline, band_lines=band_lines)
    a, b = whole.result, banded.result
    for name in MAPS:
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.taps.keys() == b.taps.keys() and a.taps
    for name in a.taps:
        assert np.array_equal(a.taps[name], b.taps[name]), name
    assert a.overflows == b.overflows and a.minmax == b.minmax
    assert (a.latency, a.total_cycles) == (b.latency, b.total_cycles)
    if formats == "narrow":
        assert a.overflow_total > 0
    assert _text(whole.figures) == _text(banded.figures)  # NaN (no valid pixel) compares
    assert np.array_equal(whole.golden.range, banded.golden.range)
    assert np.array_equal(whole.golden.valid, banded.golden.valid)


@pytest.mark.parametrize("pipeline", BANDED)
def test_banded_maps_are_files_left_nowhere(pipeline, tmp_path, monkeypatch):
    """Off the heap, the frame's maps are memory-mapped files of a temporary directory
    that is gone once the run returns (its files unlinked, the mappings still valid)."""
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    case = api.scene_case("lab", size=(23, 40))
    pipe = PIPELINES[pipeline]
    result, golden = run_in_bands(pipe, case, pipe.default_config(), None, 4, taps=False)
    assert isinstance(result.range, np.memmap) and isinstance(golden.range, np.memmap)
    assert list(tmp_path.iterdir()) == []
    whole = api.run(case, pipeline=pipeline, taps=False)
    assert np.array_equal(whole.result.range_raw, result.range_raw)


@pytest.mark.parametrize("pipeline", WHOLE)
def test_a_pipeline_that_runs_whole_frames_refuses_bands(pipeline, capsys):
    assert main(["run", "--pipeline", pipeline, "--band-lines", "4"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"rangefx: error: {pipeline} cannot run in bands of lines: its lines are "
                   "not independent"]  # fmt: skip


@pytest.mark.parametrize("pipeline", list(PIPELINES))
def test_a_frame_above_half_the_free_memory_is_banded_where_the_lines_allow(monkeypatch, pipeline):
    """The whole-frame estimate (``run_memory_bytes``, per pipeline) decides: at most half
    of the memory available, the whole frame; above it, bands for a pipeline whose lines
    are independent (the other half is the machine's other processes': a P2 8192x8192
    run once grew to 10.7 GB whole while they took the rest), the whole frame for the
    others up to all of it, and a refusal beyond."""
    from rangefx.tools import errors
    from rangefx.tools.errors import UserError
    from rangefx.tools.studies.banded import plan_bands
    from rangefx.tools.studies.runner import run_memory_bytes

    pipe = PIPELINES[pipeline]
    shape = (2048, 2048)
    whole = run_memory_bytes(shape[0] * shape[1], pipeline)
    assert run_memory_bytes(shape[0] * shape[1]) >= whole > run_memory_bytes(1, pipeline)
    for available, want in ((2 * whole, None), (2 * whole - 2, "bands"), (whole, "bands")):
        monkeypatch.setattr(errors, "available_memory_bytes", lambda a=available: a)
        lines = plan_bands(pipe, shape)
        if want is None or not pipe.line_independent:
            assert lines is None, (available, lines)
        else:
            assert isinstance(lines, int) and 1 <= lines < shape[0], (available, lines)
    monkeypatch.setattr(errors, "available_memory_bytes", lambda: whole - 1)
    if pipe.line_independent:
        assert 1 <= plan_bands(pipe, shape) < shape[0]
    else:
        with pytest.raises(UserError, match="would need about"):
            plan_bands(pipe, shape)
