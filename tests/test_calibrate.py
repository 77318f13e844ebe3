"""The area proxy calibrated against the whole-top synthesis (``python -m
rangefx.tools.studies.calibrate``; issues 35, 36), for every pipeline with RTL.

Yosys is replaced by stand-ins whose areas are exact lines in the proxy's terms, so the
fit, its scoring and the file it writes are tested in seconds; the shipped coefficients
are checked for what the estimate needs.
"""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from rangefx.rtl_model.registry import get_pipeline
from rangefx.tools.studies import calibrate as cal

PIPELINES = cal.calibrated_pipelines()
#: Lines the stand-in synthesis follows, per target: class -> {term: slope, intercept}
#: (integer slopes where a term can be odd: the stand-in rounds its areas to whole cells,
#: and half a cell on several configs would move the fitted intercept).
TRUTH = {
    "ecp5": {"lut": {"register_bits": 3.0, "restoring_cells": 2.0, "intercept": 900.0},
             "ff": {"register_bits": 2.0, "restoring_cells": 1.5, "intercept": 100.0},
             "dsp": {"dsp": 2.0, "intercept": 0.0},
             "bram": {"bram18": 1.0, "recip_roms": 1.0, "intercept": 3.0}},
    "xcup": {"lut": {"register_bits": 4.0, "restoring_cells": 0.5, "intercept": 800.0},
             "ff": {"register_bits": 5.0, "restoring_cells": 3.0, "intercept": 700.0},
             "dsp": {"dsp": 1.0, "intercept": 2.0},
             "bram": {"bram18": 2.0, "intercept": 1.0}},
}  # fmt: skip


def _linear_synth(truth=TRUTH):
    """A stand-in for Yosys: each area class an exact line in the pipeline's terms."""

    def synth(pipeline, config, target, shape, mode):
        terms = get_pipeline(pipeline).area_terms(config, shape, mode)
        return {cls: round(sum(k * (1 if t == "intercept" else terms[t]) for t, k in c.items()))
                for cls, c in truth[target].items()}  # fmt: skip

    return synth


def test_there_is_a_pipeline_to_calibrate():
    assert "p1" in PIPELINES and "p2" in PIPELINES


def test_the_fit_recovers_known_coefficients():
    terms = [{"a": 1, "b": 0, "c": 7}, {"a": 2, "b": 0, "c": 7}, {"a": 3, "b": 5, "c": 7},
             {"a": 5, "b": 2, "c": 7}]  # fmt: skip
    areas = [10 + 2 * t["a"] + 3 * t["b"] for t in terms]
    got = cal.fit_area_class(terms, areas, ["a", "b", "c"])
    # c is constant: it cannot be told from the intercept and gets no slope
    assert got == pytest.approx({"intercept": 10.0, "a": 2.0, "b": 3.0, "c": 0.0}, abs=1e-6)
    # every feature constant: the mean ratio to the first, or the mean where it is 0
    assert cal.fit_area_class([{"a": 4}, {"a": 4}], [8, 12], ["a"]) == {"intercept": 0.0,
                                                                        "a": 2.5}  # fmt: skip
    assert cal.fit_area_class([{"a": 0}, {"a": 0}], [8, 12], ["a"]) == {"intercept": 10.0,
                                                                        "a": 0.0}  # fmt: skip


@pytest.mark.parametrize("pipeline", PIPELINES)
def test_every_term_is_identifiable_from_the_fit_configs(pipeline):
    """Each term of each class varies over the fit configs (a restoring config is among
    them), and there are more fit configs than coefficients; at least 4 are held out."""
    pipe = get_pipeline(pipeline)
    fit = [n for n, (_p, _d, f) in pipe.calibration_configs.items() if f]
    held = [n for n, (_p, _d, f) in pipe.calibration_configs.items() if not f]
    assert len(held) >= 4
    terms = [pipe.area_terms(pipe.calibration_config(n), (512, 512)) for n in fit]
    for cls, features in pipe.area_features.items():
        assert len(fit) > len(features) + 1, cls
        for feature in features:
            assert len({t[feature] for t in terms}) > 1, (cls, feature)


@pytest.mark.parametrize("pipeline", PIPELINES)
def test_the_restoring_divider_has_its_own_term(pipeline):
    """``restoring_cells`` is 0 with the reciprocal divider and grows with the restoring
    divider's quotient bits (fewer with one fraction bit less)."""
    pipe = get_pipeline(pipeline)
    base = pipe.default_config()
    assert pipe.area_terms(base.with_(divider="reciprocal"), (64, 64))["restoring_cells"] == 0
    restoring = base.with_(divider="restoring")
    cells = pipe.area_terms(restoring, (64, 64))["restoring_cells"]
    quotient = "range" if pipeline == "p1" else "p2_r"
    f = restoring.formats[quotient]
    narrower = restoring.with_formats(**{quotient: replace(f, word=f.word - 1, frac=f.frac - 1)})
    assert cells > 0 and pipe.area_terms(narrower, (64, 64))["restoring_cells"] < cells


@pytest.mark.parametrize("pipeline", PIPELINES)
def test_the_calibration_recovers_the_lines_and_scores_the_held_out_configs(pipeline):
    r = cal.calibrate(pipeline, ("ecp5", "xcup"), (64, 64), synth=_linear_synth(), jobs=1)
    pipe = get_pipeline(pipeline)
    for target, lines in TRUTH.items():
        for cls, line in lines.items():
            got = r["coefficients"][target][cls]
            for term, value in line.items():
                assert got[term] == pytest.approx(value, rel=1e-3, abs=0.6), (target, cls, term)
        rows = r["configs"][target]
        held = {n for n, (_p, _d, f) in pipe.calibration_configs.items() if not f}
        assert (
            {n for n, row in rows.items() if not row["fit"]} == held == set(r["held_out_configs"])
        )
        for row in rows.values():  # the lines are exact: every estimate within rounding
            assert all(v == pytest.approx(1.0, abs=0.02) for v in row["after"].values()), row
        default = rows["default"]
        assert default["before"]["ff"] == round(
            default["proxy"]["register_bits"] / default["synth"]["ff"], 3
        )
        span = r["summary"][target]["before"]["ff"]
        befores = [rows[n]["before"]["ff"] for n in held]
        assert span == [min(befores), max(befores)]


def test_recalibration_is_one_command_that_writes_the_files_the_proxies_read(
    monkeypatch, tmp_path, capsys
):
    written = {}
    for name in PIPELINES:
        pipe = get_pipeline(name)
        written[name] = tmp_path / f"{name}_synth_calibration.toml"
        monkeypatch.setattr(pipe, "area_calibration_path", lambda f=written[name]: f)
    monkeypatch.setattr(cal, "yosys_version", lambda: "Yosys 0.23 (stand-in)")
    monkeypatch.setattr(cal, "_synth", _linear_synth())
    assert cal.main(["--write", "--json", "--jobs", "1"]) == 0
    outs = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [o["pipeline"] for o in outs] == list(PIPELINES)
    for out in outs:
        pipe = get_pipeline(out["pipeline"])
        loaded = pipe.area_calibration_path()
        assert out["written"] == str(loaded) == str(written[pipe.name])
        from rangefx.rtl_model.cost import load_area_calibration

        cal_file = load_area_calibration(loaded)
        assert cal_file["meta"]["pipeline"] == pipe.name
        assert cal_file["meta"]["rtl_sha256"] == cal.rtl_identity(pipe.name)["rtl_sha256"]
        assert cal_file["targets"] == out["coefficients"] and set(cal_file["targets"]) == {"ecp5"}
        config = pipe.default_config()
        est = pipe.estimated_area(config, (512, 512), "stereo", "ecp5")  # reads the file
        terms = pipe.area_terms(config, (512, 512))
        assert est["ff"] == pytest.approx(2.0 * terms["register_bits"] + 100.0, abs=1)
        with pytest.raises(ValueError, match=f"no {pipe.name} area calibration for target 'xcup'"):
            pipe.estimated_area(config, (64, 64), "stereo", "xcup")


SHIPPED = [n for n in PIPELINES if get_pipeline(n).area_calibration_path().is_file()]


def test_p1_ships_its_calibration():
    assert "p1" in SHIPPED


@pytest.mark.parametrize("pipeline", SHIPPED)
def test_the_shipped_calibration_covers_the_reference_and_estimates_the_default(pipeline):
    from rangefx.rtl_model.cost import load_area_calibration

    pipe = get_pipeline(pipeline)
    shipped = load_area_calibration(pipe.area_calibration_path())
    assert set(cal.DEFAULT_TARGETS) <= set(shipped["targets"])
    assert shipped["meta"]["pipeline"] == pipeline
    for target in shipped["targets"]:
        assert set(shipped["targets"][target]) == set(pipe.area_features)
        est = pipe.estimated_area(pipe.default_config(), (512, 512), "stereo", target)
        assert all(v > 0 for v in est.values()), (target, est)


def test_an_rtl_is_identified_by_its_own_files_only():
    """The calibration's RTL identity and the synthesis/timing cache keys hash the
    pipeline's sources and the headers they include: a change to another pipeline's
    parameter header neither marks P1's calibration stale nor misses P1's caches."""
    from rangefx.tools.studies.synth import RTL_TOPS
    from rangefx.vectors.hdl import rtl_files

    files = {name: {p.name for p in rtl_files(top.sources)} for name, top in RTL_TOPS.items()}
    assert {"p1_frontend_params.vh", "p1_range_params.vh", "p1_top.v"} <= files["p1"]
    assert {"p2_params.vh", "p2_top.v"} <= files["p2"]
    assert "p2_params.vh" not in files["p1"]
    assert not any(name.startswith("p1_") for name in files["p2"])
