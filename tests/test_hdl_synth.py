"""Synthesis area of the P1 RTL (``rangefx hdl synth``, ``optimise --cost synth``; issue 15).

Yosys runs on the ``frontend`` stage only (a 16-pixel line), cached under a
temporary ``RANGEFX_CACHE``; the cell-count mapping and the optimiser's use of a measured
cost are tested without Yosys.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from rangefx.rtl_model.fixedpoint import FixedFormat
from rangefx.rtl_model.p1.config import P1Config
from rangefx.tools.cli import main
from rangefx.tools.studies.cases import scene_case
from rangefx.tools.studies.optimiser import Budget, optimise
from rangefx.tools.studies.synth import area_from_cells, proxy_area, proxy_ratios

HDL_CONFIGS = Path(__file__).resolve().parent.parent / "tools" / "studies" / "sweeps"


def test_cell_counts_map_to_lut_ff_carry_dsp_bram():
    cells = {"LUT2": 10, "LUT6": 5, "INV": 2, "SRLC32E": 1, "FDRE": 30, "FDSE": 2}
    cells |= {"CARRY4": 7, "DSP48E2": 3, "RAMB18E2": 1, "RAMB36E2": 2, "IBUF": 9, "MUXF7": 4}
    a = area_from_cells(cells, "xcup")
    assert (a.lut, a.ff, a.carry, a.dsp, a.bram) == (18, 32, 7, 3, 5)
    e = area_from_cells({"LUT4": 40, "TRELLIS_FF": 12, "CCU2C": 6, "MULT18X18D": 4,
                         "DP16KD": 1, "PFUMX": 3}, "ecp5")  # fmt: skip
    assert (e.lut, e.ff, e.carry, e.dsp, e.bram) == (40, 12, 6, 4, 1)
    assert (a + a).lut == 36 and a.times(2).cells["FDRE"] == 60


def test_proxy_of_a_stage_and_its_ratios():
    cfg = P1Config.default()
    front = proxy_area(cfg, "frontend", (512, 512))
    # paper + reciprocal: one stream's pix_in .. col_s2 and div_quot plus the pole and bias
    # registers (190 bits); s1 * r2 (2 DSP) and the reciprocal divider's three products
    # (2 + 2 + 3); the filters' pole 2^-k is a shift (filter_form "shift"); one line buffer
    assert front == {"register_bits": 190, "dsp": 9, "bram18": 1}
    assert proxy_ratios(front, {"ff": 380, "dsp": 9, "bram": 0}) == {
        "ff": 0.5, "dsp": 1.0, "bram": None, "lut": None}  # fmt: skip
    consistent = proxy_area(P1Config.default(variant="consistent"), "frontend", (512, 512))
    assert consistent["dsp"] == 0 and consistent["bram18"] == 2  # second column filter
    # the report's direct form multiplies in its three filters
    direct = P1Config.default(variant="consistent", filter_form="direct")
    assert proxy_area(direct, "frontend", (512, 512))["dsp"] == 3


def test_synth_without_yosys_is_one_error_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("PATH", str(tmp_path))
    assert main(["hdl", "synth", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error: yosys is not installed")


@pytest.mark.skipif(shutil.which("yosys") is None, reason="yosys is not installed")
def test_yosys_area_of_the_frontend_stage_is_cached_and_follows_the_formats(
    monkeypatch, tmp_path, capsys
):
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    argv = ["hdl", "synth", "--stage", "frontend", "--width", "16", "--height", "16", "--json"]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    stage = first["stages"]["frontend"]
    assert stage["instances"] == 2 and not stage["cached"]
    assert stage["dsp"] >= 2  # at least C (b - p) and C (r1 - q) on DSP48E2
    assert stage["ff"] > 0 and stage["lut"] > 0
    assert first["headline"] == "stages"  # the whole top was not asked for
    assert all(first[k] == 2 * stage[k] for k in ("lut", "ff", "carry", "dsp", "bram"))
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["stages"]["frontend"]["cached"] and again["stages_sum"] == first["stages_sum"]
    # 12 fewer fraction bits of row_r1 and row_r2 (row_r2 s8.-2: a negative parameter
    # value, which chparam reads as a signed literal): fewer flip-flops
    cfg = P1Config.default()
    narrow = cfg.with_formats(**{
        s: FixedFormat(f.signed, f.word - 12, f.frac - 12, f.quant, f.overflow)
        for s, f in ((s, cfg.formats[s]) for s in ("row_r1", "row_r2"))
    })  # fmt: skip
    toml = tmp_path / "narrow.toml"
    narrow.save(toml)
    assert main([*argv, "--config", str(toml), "--mode", "motion"]) == 0
    small = json.loads(capsys.readouterr().out)
    assert small["stages"]["frontend"]["instances"] == 1
    assert small["stages"]["frontend"]["ff"] < stage["ff"]


def test_optimiser_keeps_only_narrowings_that_lower_the_measured_cost():
    """A measured cost that rises when ``col_s1`` narrows: the optimiser tries it, meets
    the budget, and does not keep it; ``row_r2``'s narrowing lowers the cost and stays."""
    case = scene_case("lab", [32, 40])
    start = P1Config.default()

    def cost(cfg: P1Config) -> float:
        return cfg.formats["row_r2"].word - 10 * cfg.formats["col_s1"].word

    res = optimise(case, start, Budget(0.01, 0.99), signals=["col_s1", "row_r2"],
                   progress=False, cost_fn=cost)  # fmt: skip
    assert res.config.formats["col_s1"] == start.formats["col_s1"]
    assert res.config.formats["row_r2"].word < start.formats["row_r2"].word
    dropped = [s for s in res.steps if not s["kept"]]
    assert dropped and {s["signal"] for s in dropped} == {"col_s1"}
    assert all(s["cost_to"] > s["cost_from"] for s in dropped)
    assert all(s["cost_to"] <= s["cost_from"] for s in res.steps if s["kept"])


def test_sweep_synth_metrics_make_lut_plus_ff_the_pareto_cost():
    from rangefx.tools.errors import UserError
    from rangefx.tools.studies.sweep import parse_sweep

    head = '[sweep]\nname = "s"\nscenes = ["lab"]\nmetrics = ["golden", "synth"]\n'
    axis = '[[axis]]\nsignals = "row_r2"\nparam = "frac"\nvalues = [8, 10]\n'
    assert parse_sweep(head + axis).cost_key == "synth_cost"
    assert parse_sweep(head.replace(', "synth"', "") + axis).cost_key == "cost_bits"
    p2 = head + 'pipeline = "p2"\n' + axis.replace("row_r2", "p2_a")
    assert parse_sweep(p2).cost_key == "synth_cost"  # P2 has RTL too
    p3 = head + 'pipeline = "p3"\n' + axis.replace("row_r2", "p3_grad")
    with pytest.raises(UserError, match="synth metrics need RTL: p3 has none"):
        parse_sweep(p3)
    # the place-and-route Fmax is a metric of the sweeps of every pipeline with RTL
    timing = head.replace('"synth"', '"timing"')
    assert "timing" in parse_sweep(timing + axis).metrics
    with pytest.raises(UserError, match="timing metrics need RTL: p3 has none"):
        parse_sweep(timing + 'pipeline = "p3"\n' + axis.replace("row_r2", "p3_grad"))


@pytest.mark.skipif(shutil.which("yosys") is None, reason="yosys is not installed")
def test_the_headline_is_the_whole_top_without_its_probes(monkeypatch, tmp_path, capsys):
    """The whole p1_top flat (lab-optimised formats, 16-pixel lines, ECP5): the overflow
    counters are not in the headline but in the probes' cost."""
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    cfg = HDL_CONFIGS / "p1_lab_optimised_1pct.toml"
    argv = ["hdl", "synth", "--config", str(cfg), "--target", "ecp5", "--stage", "top",
            "--width", "16", "--height", "8", "--json"]  # fmt: skip
    assert main(argv) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["headline"] == "p1_top" and not r["cached"] and not r["probes"]["cached"]
    assert r["ff"] > 0 and r["dsp"] > 0 and r["lut"] > 0
    # the overflow counters of the casts that can overflow (Yosys removes a counter that
    # stays 0), at least one 32-bit counter per stream
    assert r["probes"]["ff"] >= 2 * 32
    assert r["stages"] == {}  # --stage top: no breakdown
    assert r["proxy_ratio"]["ff"] == round(r["proxy"]["register_bits"] / r["ff"], 3)


@pytest.mark.parametrize("command", ["synth", "timing"])
def test_hdl_synth_and_timing_take_the_filter_form_and_pole(command, monkeypatch):
    """The filters' structure is hardware: ``--filter-form``/``--pole`` reach the config
    that is synthesised or timed."""
    from rangefx.tools.studies import synth, timing

    seen = []

    class Stop(Exception):
        pass

    def capture(pipeline, config, *args, **kwargs):
        seen.append((pipeline, config.filter_form, config.pole))
        raise Stop

    # the command calls rangefx.api, which imports the flow's function when it runs
    if command == "synth":
        monkeypatch.setattr(synth, "synth_pipeline", capture)
    else:
        monkeypatch.setattr(timing, "time_top", capture)
    with pytest.raises(Stop):
        main(["hdl", command, "--filter-form", "direct", "--pole", "0.375", "--json"])
    assert seen == [("p1", "direct", 0.375)]


def test_the_ice40_script_drops_the_lut_ram_style_that_ice40_cannot_map():
    """iCE40 has no LUT RAM: the delay lines' ``ram_style = "distributed"`` is unset before
    ``synth_ice40`` (else Yosys stops: no valid mapping for the memory); other targets
    keep it."""
    from rangefx.tools.studies import synth

    script = synth._yosys_script  # the script's text, before any Yosys run
    ice40 = script("p1_top", ("p1_top.v",), {"PIX_W": 8}, "ice40").splitlines()
    unset = ice40.index("setattr -unset ram_style m:*")
    assert unset < next(i for i, ln in enumerate(ice40) if ln.startswith("synth_ice40"))
    for target in ("ecp5", "xcup"):
        assert "ram_style" not in script("p1_top", ("p1_top.v",), {}, target)
