"""The word-length studies on every pipeline with RTL (issue 36 item 5): ``rangefx optimise
--cost synth``, ``--fmax-min`` and the sweep's ``synth`` / ``timing`` metric groups use the
pipeline's own whole top (:data:`rangefx.tools.studies.synth.RTL_TOPS`), P2's beside P1's.

A real synthesis of P2's whole top takes minutes and a place and route longer (docs/hdl.md
"P2"), so the synthesis and timing functions are replaced by fakes that record which
pipeline, config and target reached them; the real flows are tested in
``tests/test_hdl_top_flows.py`` and ``tests/test_hdl_timing.py``.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from rangefx.rtl_model.registry import PIPELINES, get_pipeline
from rangefx.tools.cli import main
from rangefx.tools.studies import synth, timing
from rangefx.tools.studies.synth import RTL_TOPS, SynthArea

WITH_RTL = [name for name in PIPELINES if name in RTL_TOPS]
WITHOUT_RTL = [name for name in PIPELINES if name not in RTL_TOPS]
_CASE = ["--scene", "lab", "--size", "32", "40"]


def _tuned_signal(pipeline: str) -> str:
    """One datapath signal of ``pipeline`` to tune (the last: past the input word)."""
    return get_pipeline(pipeline).signal_groups["datapath"][-1]


def _bits(config) -> int:
    return sum(f.word for f in config.formats.values())


@pytest.fixture
def fake_synthesis(monkeypatch):
    """``synth_pipeline_top`` replaced: records (pipeline, target, shape, mode) and
    returns an area that shrinks with the config's bits, so that narrowing pays."""
    calls: list[tuple] = []

    def fake(pipeline, config, target="xcup", shape=(512, 512), mode="stereo", **_kw):
        calls.append((pipeline, target, tuple(shape), mode))
        return SynthArea(lut=3 * _bits(config), ff=_bits(config), dsp=1), False

    monkeypatch.setattr(synth, "synth_pipeline_top", fake)
    monkeypatch.setattr(synth, "yosys_version", lambda: "Yosys (fake)")
    return calls


@pytest.fixture
def fake_timing(monkeypatch):
    """``time_top`` replaced: records (pipeline, stage, speed, shape, mode) and returns
    a 150 MHz clock; the tool look-ups answer as if both tools were installed."""
    calls: list[tuple] = []

    def fake(pipeline, config, *, speed=6, shape=(512, 512), mode="stereo", stage="top", **_kw):
        calls.append((pipeline, stage, speed, tuple(shape), mode))
        path = SimpleNamespace(logic_ns=4.0, routing_ns=2.6)
        return SimpleNamespace(fmax_mhz={"clk": 150.0}, critical_path={"clk": path})

    monkeypatch.setattr(timing, "time_top", fake)
    monkeypatch.setattr(timing, "yosys_command", lambda: ["yosys"])
    monkeypatch.setattr(timing, "nextpnr_command", lambda target="ecp5": ["nextpnr-ecp5"])
    return calls


@pytest.mark.parametrize("target", ["ecp5", "xcup"])
@pytest.mark.parametrize("pipeline", WITH_RTL)
def test_optimise_cost_synth_minimises_the_pipelines_own_area(
    pipeline, target, fake_synthesis, capsys
):
    argv = ["optimise", "--pipeline", pipeline, *_CASE, "--signals", _tuned_signal(pipeline),
            "--cost", "synth", "--synth-target", target, "--margin", "0", "--json"]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert fake_synthesis and set(fake_synthesis) == {(pipeline, target, (32, 40), "stereo")}
    # the figures are the fake's LUT + FF: the start's, and the result's no larger
    start = get_pipeline(pipeline).default_config()
    logged = [s for s in out["steps"] if "cost_from" in s]
    assert logged and logged[0]["cost_from"] == 4 * _bits(start)


@pytest.mark.parametrize("pipeline", WITH_RTL)
def test_optimise_fmax_min_times_the_pipelines_own_top(pipeline, fake_timing, capsys):
    argv = ["optimise", "--pipeline", pipeline, *_CASE, "--signals", _tuned_signal(pipeline),
            "--fmax-min", "100", "--timing-speed", "8", "--margin", "0", "--json"]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert fake_timing and set(fake_timing) == {(pipeline, "top", 8, (32, 40), "stereo")}
    assert out["fmax"]["start"] == 150.0 and out["fmax"]["optimised"] == 150.0


@pytest.mark.parametrize("pipeline", WITH_RTL)
def test_the_api_optimise_routes_the_pipeline_to_synthesis(pipeline, fake_synthesis):
    from rangefx import api

    api.optimise(pipeline, ["lab"], size=(32, 40), signals=[_tuned_signal(pipeline)],
                 cost="synth", synth_target="ecp5", margin=0.0)  # fmt: skip
    assert fake_synthesis and {c[0] for c in fake_synthesis} == {pipeline}


@pytest.mark.parametrize(
    ("flag", "lead"), [(["--cost", "synth"], "--cost synth"), (["--fmax-min", "100"], "--fmax-min")]
)
@pytest.mark.parametrize("pipeline", WITHOUT_RTL)
def test_a_pipeline_without_rtl_is_one_error_line(
    pipeline, flag, lead, fake_synthesis, fake_timing, error_line
):
    argv = ["optimise", "--pipeline", pipeline, *_CASE, *flag]
    assert main(argv) == 2
    line = error_line()
    assert f"{lead}: pipeline {pipeline} has no RTL in hdl/" in line
    assert not fake_synthesis and not fake_timing  # refused before any run


def test_a_timing_stage_the_pipeline_lacks_is_one_error_line(fake_timing, error_line):
    """P2's RTL is timed whole: ``--timing-stage frontend`` (P1's one front end) is refused
    before any run, naming the stages P2 has."""
    no_frontend = [n for n in WITH_RTL if "frontend" not in timing.TIMED_TOPS[n].wrappers]
    assert "p2" in no_frontend
    for pipeline in no_frontend:
        argv = ["optimise", "--pipeline", pipeline, *_CASE, "--fmax-min", "100",
                "--timing-stage", "frontend"]  # fmt: skip
        assert main(argv) == 2
        assert f"{pipeline} has no timing stage 'frontend' (it has top)" in error_line()
    assert not fake_timing


_SWEEP = """[sweep]
name = "rtl"
pipeline = "{pipeline}"
scenes = ["lab"]
size = [16, 24]
metrics = ["golden", {metrics}]
combine = "grid"
{timing}
[[axis]]
signals = "{signal}"
param = "frac"
values = [{frac}]
"""


def _sweep_text(pipeline: str, metrics: str = '"synth", "timing"', timing_table: str = "") -> str:
    signal = _tuned_signal(pipeline)
    frac = get_pipeline(pipeline).default_config().formats[signal].frac
    return _SWEEP.format(pipeline=pipeline, metrics=metrics, timing=timing_table, signal=signal,
                         frac=frac)  # fmt: skip


@pytest.mark.parametrize("pipeline", WITH_RTL)
def test_a_sweeps_synth_and_timing_metrics_are_the_pipelines_own(
    pipeline, fake_synthesis, fake_timing, tmp_path, capsys
):
    definition = tmp_path / "rtl.toml"
    definition.write_text(_sweep_text(pipeline))
    assert main(["sweep", str(definition), "--out", str(tmp_path / "out"), "--json"]) == 0
    capsys.readouterr()
    (rec,) = [json.loads(ln) for ln in (tmp_path / "out/results.jsonl").read_text().splitlines()]
    bits = _bits(get_pipeline(pipeline).default_config())
    assert rec["pipeline"] == pipeline and rec["status"] == "ok"
    assert rec["synth_cost"] == 4 * bits and rec["synth_dsp"] == 1
    assert rec["fmax_mhz"] == 150.0 and rec["critical_logic_ns"] == 4.0
    assert set(fake_synthesis) == {(pipeline, "xcup", (16, 24), "stereo")}
    assert set(fake_timing) == {(pipeline, "top", 6, (16, 24), "stereo")}


@pytest.mark.parametrize("metric", ["synth", "timing"])
@pytest.mark.parametrize("pipeline", WITHOUT_RTL)
def test_a_sweep_of_a_pipeline_without_rtl_refuses_its_rtl_metrics(pipeline, metric, tmp_path,
                                                                     error_line):  # fmt: skip
    definition = tmp_path / "rtl.toml"
    definition.write_text(_sweep_text(pipeline, f'"{metric}"'))
    assert main(["sweep", str(definition), "--out", str(tmp_path / "out")]) == 2
    line = error_line()
    assert f"the {metric} metrics need RTL: {pipeline} has none in hdl/" in line
    assert not (tmp_path / "out").exists()


def test_a_sweep_timing_stage_the_pipeline_lacks_is_refused(tmp_path, error_line):
    definition = tmp_path / "rtl.toml"
    definition.write_text(_sweep_text("p2", '"timing"', 'timing = { stage = "frontend" }'))
    assert main(["sweep", str(definition), "--out", str(tmp_path / "out")]) == 2
    assert "p2 has no timing stage 'frontend' (it has top)" in error_line()
