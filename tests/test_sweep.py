"""Word-length studies (issues 7, 14): sweep definition, resumable execution, dask, Pareto
front, cost model, optimiser, command line, for every pipeline of the registry. Small
images keep it fast."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from rangefx.rtl_model.config import WordLengthConfig
from rangefx.rtl_model.cost import bram18_blocks, dsp_slices
from rangefx.rtl_model.fixedpoint import FixedFormat
from rangefx.rtl_model.p1.config import HOST_REGISTERS, P1Config
from rangefx.rtl_model.p1.cost import config_cost, multipliers, register_bits
from rangefx.rtl_model.registry import PIPELINES
from rangefx.tools import cli
from rangefx.tools.errors import UserError
from rangefx.tools.studies import runner
from rangefx.tools.studies.buildup import buildup_for
from rangefx.tools.studies.cases import held_out_case, real_pair_case, scene_case
from rangefx.tools.studies.optimiser import Budget, evaluate_scenes, optimise, worst_case
from rangefx.tools.studies.runner import compare_ranges
from rangefx.tools.studies.sweep import (
    RESULTS_NAME,
    cached_golden,
    expand,
    load_results,
    pareto_front,
    parse_sweep,
    point_key,
    run_sweep,
    write_outputs,
)

P1 = PIPELINES["p1"]
P2 = PIPELINES["p2"]

#: A small sweep of one pipeline on the 32x40 lab (stereo: every pipeline models it): a
#: single-signal axis of fraction bits and a group move of the pipeline's own group.
SMALL_TEMPLATE = """
[sweep]
name = "{name}"{pipeline}
scenes = ["lab"]
size = [32, 40]
combine = "one_at_a_time"
metrics = ["golden", "truth", "sqnr", "overflows"]

[[axis]]
signals = "{signal}"
param = "frac"
range = {frac}

[[axis]]
signals = "{group}"
param = "frac_delta"
values = [-4, -2]
"""
#: P1's (the default pipeline: no ``pipeline`` key): the row filter and the datapath.
SMALL = SMALL_TEMPLATE.format(
    name="t", pipeline="", signal="row_state", frac="[5, 9]", group="datapath"
)
#: P2's: the Riccati variable and the sweep engine.
SMALL_P2 = SMALL_TEMPLATE.format(
    name="t2", pipeline='\npipeline = "p2"', signal="p2_st", frac="[4, 7]", group="backward_loop"
)
#: P3's: the estimate's fraction bits and the window sums.
SMALL_P3 = SMALL_TEMPLATE.format(
    name="t3", pipeline='\npipeline = "p3"', signal="p3_u", frac="[5, 9]", group="window"
)
#: Small sweep definition per pipeline of the registry.
SMALL_DEFS = {"p1": SMALL, "p2": SMALL_P2, "p3": SMALL_P3}


def _small(pipeline: str = "p1"):
    return parse_sweep(SMALL_DEFS[pipeline])


def test_every_pipeline_has_a_small_definition():
    assert set(SMALL_DEFS) == set(PIPELINES)
    for name in PIPELINES:
        assert _small(name).pipeline == name


def _lines(path: Path) -> list[dict]:
    return [json.loads(x) for x in path.read_text().splitlines()]


# ----------------------------------------------------------------------- definition
def test_expand_counts_and_dedup():
    defn = _small()
    points = expand(defn)
    assert len(points) == 1 + 5 + 2  # base + one axis at a time
    keys = {p.key for p in points}
    assert len(keys) == len(points)  # the default row_state frac (11) is not in 5..9
    base = points[0].config
    row = [p for p in points if p.labels and p.labels[0][0] == "row_state.frac"]
    for p in row:
        f, f0 = p.config.formats["row_state"], base.formats["row_state"]
        assert f.word - f.frac == f0.word - f0.frac  # integer bits kept
    grp = [p for p in points if p.labels and p.labels[0][0] == "datapath.frac_delta"]
    assert grp[0].config.formats["col_state"].frac == base.formats["col_state"].frac - 4
    assert grp[0].config.formats["pix_in"] == base.formats["pix_in"]  # not in "datapath"


def test_expand_p2_moves_its_own_groups():
    defn = _small("p2")
    points = expand(defn)
    assert len(points) == 1 + 4 + 2 and len({p.key for p in points}) == len(points)
    base = points[0].config
    assert type(base) is type(P2.default_config()) and base == P2.default_config()
    grp = [p for p in points if p.labels and p.labels[0][0] == "backward_loop.frac_delta"]
    for sig in P2.signal_groups["backward_loop"]:
        assert grp[0].config.formats[sig].frac == base.formats[sig].frac - 4, sig
    for sig in ("p2_pix", "p2_e", "p2_z", "p2_ka_reg"):  # not in the sweep engine's group
        assert grp[0].config.formats[sig] == base.formats[sig], sig


def test_point_key_includes_the_pipeline():
    args = ("lab", [32, 40], 0, ["golden"])
    assert point_key("p1", "x", *args) != point_key("p2", "x", *args)
    assert point_key("p2", "x", *args) == point_key("p2", "x", *args)


def test_expand_grid():
    defn = parse_sweep(SMALL.replace("one_at_a_time", "grid"))
    assert len(expand(defn)) == 5 * 2


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[sweep\n", "not valid TOML"),
        ('[sweep]\nscenes=["lab"]\n', "no \\[\\[axis\\]\\]"),
        (SMALL.replace('"row_state"', '"row_stat"'), "unknown signal or group 'row_stat'"),
        (SMALL.replace('param = "frac"', 'param = "bits"'), "unknown param 'bits'"),
        (SMALL.replace("range = [5, 9]", "range = [9, 5]"), "range must be"),
        (SMALL.replace("range = [5, 9]", ""), "exactly one of 'values' or 'range'"),
        (SMALL.replace('scenes = ["lab"]', 'scenes = ["moon"]'), "unknown scenes"),
        (SMALL.replace('"golden", ', '"gold", '), "unknown metrics"),
        (SMALL.replace("one_at_a_time", "random"), "combine must be"),
        (SMALL + "\n[extra]\n", "unknown tables"),
        (SMALL.replace('name = "t"', 'name = "t"\nspeed = 1'), "unknown keys"),
        (SMALL.replace("values = [-4, -2]", 'values = [-4, "x"]'), "not an integer"),
        (
            SMALL + '\n[[axis]]\nsignals = "c1"\nparam = "quant"\nvalues = ["ROUND"]\n',
            "not a quant mode",
        ),
        (SMALL, None),
    ],
)
def test_bad_definitions_are_user_errors(text, match):
    if match is None:
        parse_sweep(text)  # control: valid
        return
    with pytest.raises(UserError, match=match) as info:
        parse_sweep(text, where="def.toml")
    assert str(info.value).startswith("def.toml")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (
            SMALL_P2.replace('"p2_st"', '"p2_stt"'),
            "unknown signal or group 'p2_stt' of p2 (did you mean 'p2_st'?)",
        ),
        (SMALL_P2.replace('"p2_st"', '"row_state"'), "unknown signal or group 'row_state' of p2"),
        (SMALL_P2.replace('"p2_st"', '["p2_st", "p2_ee"]'), "unknown P2 signal 'p2_ee' (did you"),
        (SMALL_P2.replace('"backward_loop"', '"frontend"'), "unknown signal or group 'frontend'"),
        (SMALL_P2.replace('name = "t2"', 'name = "t2"\nvariant = "paper"'), "variant does not"),
        (SMALL_P2.replace('pipeline = "p2"', 'pipeline = "p9"'), "unknown pipeline 'p9'"),
        (
            SMALL.replace('name = "t"', 'name = "t"\nbuildup_hooks = ["riccati"]'),
            "buildup_hooks is no longer a key: every sweep writes its pipeline's own build-up "
            "(the Riccati sweep's is P2's: a sweep with pipeline = \"p2\")",
        ),
        (SMALL_P2, None),
    ],
)
def test_bad_p2_definitions_are_user_errors(text, match):
    if match is None:
        assert parse_sweep(text).pipeline == "p2"  # control: valid
        return
    with pytest.raises(UserError, match=re.escape(match)) as info:
        parse_sweep(text, where="def.toml")
    assert str(info.value).startswith("def.toml")
    assert "\n" not in str(info.value)


def test_p2_sweep_on_a_motion_scene_is_a_user_error(tmp_path):
    defn = parse_sweep(SMALL_P2.replace('scenes = ["lab"]', 'scenes = ["runway"]'))
    with pytest.raises(UserError, match=r"P2 models stereo mode only; case 'runway' is motion"):
        run_sweep(defn, tmp_path, progress=False)
    assert not (tmp_path / RESULTS_NAME).exists()


def test_bad_base_and_missing_file(tmp_path):
    bad = SMALL.replace('name = "t"', 'name = "t"\nbase = "nope.toml"')
    with pytest.raises(UserError, match="base"):
        parse_sweep(bad, root=tmp_path)
    P1Config.default().save(tmp_path / "p1.toml")  # a P1 config as a P2 sweep's base
    other = SMALL_P2.replace('name = "t2"', 'name = "t2"\nbase = "p1.toml"')
    with pytest.raises(UserError, match=r"\[sweep\] base: .*p1.toml: \[design\]: unknown keys"):
        parse_sweep(other, root=tmp_path)
    assert cli.main(["sweep", str(tmp_path / "missing.toml"), "--out", str(tmp_path / "o")]) == 2


def test_invalid_config_points_are_recorded_not_fatal(tmp_path):
    text = SMALL.replace("range = [5, 9]", "range = [5, 6]").replace(
        "values = [-4, -2]", "values = [-12]"
    )  # bias_in u10.1 at frac -11: word 0, rejected
    defn = parse_sweep(text)
    out = run_sweep(defn, tmp_path, workers=2, progress=False)
    statuses = sorted(r["status"] for r in out.records.values())
    assert statuses.count("invalid") == 1 and statuses.count("ok") == 3
    bad = next(r for r in out.records.values() if r["status"] == "invalid")
    assert "word length" in bad["error"]


# ----------------------------------------------------------------------- resume
class _Stop(Exception):
    pass


@pytest.mark.parametrize("pipeline", list(PIPELINES))
def test_kill_and_resume_computes_every_point_once(tmp_path, pipeline):
    # P2's points take milliseconds: more of them, so that the sweep stops before its end
    defn = parse_sweep(SMALL_DEFS[pipeline].replace("range = [4, 7]", "range = [-6, 7]"))
    all_keys = {p.key for p in expand(defn)}
    first: list[str] = []

    def stop_after_3(rec):
        first.append(rec["key"])
        if len(first) == 3:
            raise _Stop

    # one worker: with two, on a loaded machine every point could finish before the third
    # record's callback stops the sweep (seen once: 8 of 8 recorded), and nothing is left
    with pytest.raises(_Stop):
        run_sweep(defn, tmp_path, workers=1, on_point=stop_after_3, progress=False)
    written = _lines(tmp_path / RESULTS_NAME)
    assert 3 <= len(written) < len(all_keys)  # in-flight points finished and recorded
    assert len({r["key"] for r in written}) == len(written)
    done_before = {r["key"] for r in written}
    # a kill in the middle of a write leaves a torn line: it is cut off on resume
    with open(tmp_path / RESULTS_NAME, "a") as f:
        f.write('{"key": "torn", "sta')
    second: list[str] = []
    outcome = run_sweep(
        defn, tmp_path, workers=2, on_point=lambda r: second.append(r["key"]), progress=False
    )
    assert set(second) == all_keys - done_before  # nothing recomputed
    assert set(outcome.computed) == set(second)
    final = _lines(tmp_path / RESULTS_NAME)
    keys = [r["key"] for r in final]
    assert sorted(keys) == sorted(all_keys)  # each point exactly once, none lost
    assert all(r["status"] == "ok" and r["pipeline"] == pipeline for r in final)
    # a third run computes nothing
    third = run_sweep(defn, tmp_path, workers=2, progress=False)
    assert third.computed == ()
    assert len(_lines(tmp_path / RESULTS_NAME)) == len(all_keys)


#: Build-up CSVs of each pipeline's sweep: P1's row and column filters, P2's backward sweep.
BUILDUP_CSVS = {
    "p1": ("buildup_base_row.csv", "buildup_base_col.csv"),
    "p2": ("buildup_base_riccati.csv",),
    "p3": ("buildup_base_warps.csv",),
}


@pytest.mark.parametrize("pipeline", list(PIPELINES))
def test_outputs_written(tmp_path, pipeline):
    defn = _small(pipeline)
    outcome = run_sweep(defn, tmp_path, workers=2, progress=False)
    summary = write_outputs(defn, outcome, tmp_path)
    for name in (
        "points.csv",
        "pareto_lab.csv",
        "pareto_lab.png",
        "sensitivity.csv",
        "sensitivity.png",
        "buildup_base.png",
        *BUILDUP_CSVS[pipeline],
        "summary.json",
    ):
        assert (tmp_path / name).stat().st_size > 0, name
    assert sorted(p.name for p in tmp_path.glob("buildup_base_*.csv")) == sorted(
        BUILDUP_CSVS[pipeline]
    )
    assert summary["complete"] and summary["n_points"] == len(outcome.records)
    assert summary["pipeline"] == pipeline and summary["pareto"]["lab"]
    assert summary["sensitivity"] == [defn.axes[0].label]  # the single-signal axis
    assert summary["golden"] == PIPELINES[pipeline].golden_label(defn.base)
    header = (tmp_path / "points.csv").read_text().splitlines()[0].split(",")
    assert header[:3] == ["key", "pipeline", "scene"]
    if pipeline == "p2":
        base = outcome.records[expand(defn)[0].key]
        assert base["taps"]["g_hat"] == {"sqnr_db": None, "max_abs_err": 0.0}  # lossless
        assert base["taps"]["z"]["sqnr_db"] > 50 and base["taps"]["e"]["sqnr_db"] > 25
        # narrowing the sweep engine's fractions by 4 bits costs accuracy and saves bits
        grp = next(p for p in outcome.points if p.labels == (("backward_loop.frac_delta", -4),))
        rec = outcome.records[grp.key]
        assert rec["cost_bits"] < base["cost_bits"]
        assert rec["median_rel_range_diff"] > base["median_rel_range_diff"]
        with open(tmp_path / "sensitivity.csv") as f:
            sens = list(csv.DictReader(f))
        assert [(r["signal"], int(r["value"])) for r in sens] == [("p2_st", v) for v in range(4, 8)]
        return
    if pipeline == "p3":
        base = outcome.records[expand(defn)[0].key]
        # E1x of the normalised level: p3_norm's rounding (61 dB measured), not exact
        assert base["taps"]["ax"]["sqnr_db"] > 50 and "e1.norm" in base["taps"]
        assert base["taps"]["u1"]["sqnr_db"] > 30 and base["taps"]["sgg1"]["sqnr_db"] > 30
        # narrowing the window sums by 4 fraction bits saves line-buffer bits
        grp = next(p for p in outcome.points if p.labels == (("window.frac_delta", -4),))
        assert outcome.records[grp.key]["cost_bits"] < base["cost_bits"]
        return
    rec = next(iter(outcome.records.values()))
    for key in (
        "median_rel_range_diff",
        "p95_rel_range_diff",
        "valid_agreement",
        "truth_median_rel_error",
        "overflow_total",
        "cost_bits",
        "dsp",
        "bram18",
    ):
        assert key in rec
    # per-signal SQNR vs the float golden taps: a wide default config is far above 40 dB
    base = outcome.records[expand(defn)[0].key]
    for tap in ("e1.row_r1", "e2.col_s1", "e1.ex", "c1", "num", "den"):
        assert base["taps"][tap]["sqnr_db"] > 40, tap
    assert base["taps"]["e1.bias_in"]["max_abs_err"] == 0


# ----------------------------------------------------------------------- dask
@pytest.mark.parametrize("pipeline", list(PIPELINES))
def test_dask_local_cluster_equals_local_run(tmp_path, pipeline):
    distributed = pytest.importorskip("distributed")
    defn = _small(pipeline)
    local = run_sweep(defn, tmp_path / "local", workers=2, progress=False)
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
    ) as cluster:
        remote = run_sweep(
            defn, tmp_path / "dask", scheduler=cluster.scheduler_address, progress=False
        )

    def strip(recs):
        return {k: {kk: vv for kk, vv in v.items() if kk != "seconds"} for k, v in recs.items()}

    assert strip(remote.records) == strip(local.records)
    assert len(_lines(tmp_path / "dask" / RESULTS_NAME)) == len(local.records)


def test_bad_scheduler_is_user_error(tmp_path):
    pytest.importorskip("distributed")
    with pytest.raises(UserError, match="dask scheduler"):
        run_sweep(
            _small(), tmp_path, scheduler="tcp://127.0.0.1:1", progress=False, connect_timeout=2
        )


# ----------------------------------------------------------------------- Pareto
def test_pareto_front_hand_example():
    costs = [1, 2, 2, 3, 4, 5, 0.5, 6]
    errors = [5, 3, 4, 3, 1, math.nan, 9, 1]
    # (2,3) dominates (2,4) and (3,3); (6,1) is dominated by (4,1); NaN never on the front
    assert pareto_front(costs, errors) == [6, 0, 1, 4]
    assert pareto_front([], []) == []
    assert pareto_front([3, 3], [1, 1]) == [0]  # ties keep the first


# ----------------------------------------------------------------------- cost
def test_bram18_packing_hand_examples():
    assert bram18_blocks(512, 22) == 1  # 512 x 36
    assert bram18_blocks(512, 37) == 2
    assert bram18_blocks(1024, 18) == 1
    assert bram18_blocks(2048, 10) == 2  # 2K x 9 twice (or 1K x 18 twice)
    assert bram18_blocks(16384, 1) == 1
    assert bram18_blocks(262144, 65) == 1024  # the 512x512 frame store of 65-bit words
    assert bram18_blocks(0, 8) == 0


def test_dsp_tiling_hand_examples():
    assert dsp_slices(27, 18) == 1
    assert dsp_slices(18, 27) == 1
    assert dsp_slices(28, 18) == 2
    assert dsp_slices(40, 22) == 3  # 3 x 1 tiles of 18 x 27
    assert dsp_slices(54, 36) == 4


def test_cost_model_of_the_default():
    cfg = P1Config.default()
    cost = config_cost(cfg, (512, 512), "stereo")
    assert cost.line_buffer_bits == 2 * 512 * 22  # two streams, u22.13 column state
    assert cost.bram18 == 2 and cost.frame_store_bits == 0
    motion = config_cost(cfg, (512, 512), "motion")
    assert motion.frame_store_bits == 512 * 512 * (20 + 24 + 21)  # s1 + ex + s2 words
    # one more bit of the column state costs a line of bits per stream + its registers
    f = cfg.formats["col_state"]
    wider = cfg.with_formats(
        col_state=FixedFormat(f.signed, f.word + 1, f.frac, f.quant, f.overflow)
    )
    assert config_cost(wider, (512, 512)).cost_bits - cost.cost_bits == 2 * 512 + 2
    # the restoring divider has no multiplier; the reciprocal one three per divider
    names = [m.name for m in multipliers(cfg)]
    assert sum("divider" in n for n in names) == 6
    rest = cfg.with_(divider="restoring")
    assert not any("divider" in m.name for m in multipliers(rest))
    assert config_cost(rest, (512, 512)).dsp < cost.dsp
    # hoisted per-frame products cost nothing
    assert all(m.dsp == 0 for m in multipliers(cfg) if m.hoisted)
    assert register_bits(cfg, "stereo") > register_bits(cfg, "motion")


@pytest.mark.parametrize("pipeline", list(PIPELINES))
def test_cost_matches_model_memories(pipeline):
    """The cost model's buffers are the model's: line buffers (sweep buffers included,
    P2) and the frame store, for every design variant, on a motion case where the
    pipeline models one (P1's frame store), else stereo."""
    pipe = PIPELINES[pipeline]
    case = scene_case("runway" if "motion" in pipe.modes else "lab", [24, 32])
    assert len(pipe.variants) >= 1
    for design in pipe.variants.values():
        cfg = pipe.default_config(**design)
        res = runner.run_case(pipe, case, cfg)
        cost = pipe.cost(cfg, case.shape, case.mode)
        assert cost.line_buffer_bits == res.line_buffer_bits + res.sweep_buffer_bits > 0
        assert cost.frame_store_bits == res.frame_store_bits
        assert cost.frame_store_bits > 0 if case.mode == "motion" else cost.frame_store_bits == 0


@pytest.mark.parametrize("pipeline", list(PIPELINES))
def test_cost_weights_follow_the_cost(pipeline):
    """One more bit of a signal's word costs what the cost model says; a line-buffered
    signal costs at least a line per bit, the input pixel of a stereo pair two words."""
    pipe = PIPELINES[pipeline]
    cfg, shape = pipe.default_config(), (32, 40)
    weights = pipe.cost_weights(cfg, shape)
    assert set(weights) == set(cfg.signals()) and min(weights.values()) >= 0
    heaviest = max(weights, key=weights.get)
    assert weights[heaviest] >= shape[1]
    f = cfg.formats[heaviest]
    wider = cfg.with_formats(**{heaviest: FixedFormat(f.signed, f.word + 1, f.frac, f.quant,
                                                      f.overflow)})  # fmt: skip
    assert pipe.cost(wider, shape).cost_bits - pipe.cost(cfg, shape).cost_bits == weights[heaviest]


# ----------------------------------------------------------------------- optimiser
@pytest.mark.parametrize("pipeline", list(PIPELINES))
def test_optimiser_meets_budget_and_saves_bits(pipeline):
    pipe = PIPELINES[pipeline]
    case = scene_case("lab", [48, 64])
    start = pipe.default_config()
    budget = Budget(0.01, 0.99)
    res = optimise(case, start, budget, workers=2, progress=False)
    assert type(res.config) is type(start)  # the start's pipeline, found in the registry
    assert budget.met(res.figures)
    # independent re-verification of the chosen config
    figs = compare_ranges(
        runner.run_case(pipe, case, res.config), pipe.golden(case, res.config).result
    )
    assert figs["median_rel_range_diff"] <= 0.01 and figs["valid_agreement"] >= 0.99
    assert figs["median_rel_range_diff"] == res.figures["median_rel_range_diff"]
    c_opt = pipe.cost(res.config, case.shape, case.mode).cost_bits
    c_def = pipe.cost(start, case.shape, case.mode).cost_bits
    assert c_opt < c_def
    assert res.steps and res.evaluations > len(res.steps)
    assert res.config.formats[start.signals()[0]] == start.formats[start.signals()[0]]


def _tried(case, start, budget, **kw) -> tuple[set[str], WordLengthConfig]:
    """Signals whose format some candidate changed, and the result's config."""
    seen: set[str] = set()

    def on_eval(cfg, _figs):
        seen.update(n for n, f in cfg.formats.items() if f != start.formats[n])

    res = optimise(case, start, budget, progress=False, on_eval=on_eval, **kw)
    return seen, res.config


@pytest.mark.parametrize(("pipeline", "named"), [("p1", "k_t_reg"), ("p2", "p2_m_reg")])
def test_optimiser_leaves_host_registers_alone_by_default(pipeline, named):
    """Host-written registers keep the start formats unless --tune-registers (or named)."""
    case = scene_case("lab", [32, 40])
    start = PIPELINES[pipeline].default_config()
    registers = set(start.HOST_REGISTERS)
    assert named in registers and (pipeline != "p1" or registers == set(HOST_REGISTERS))
    budget = Budget(0.01, 0.99)
    tried, cfg = _tried(case, start, budget)
    assert tried and not tried & registers
    assert start.signals()[0] not in tried  # the input pixel is the sensor's
    assert all(cfg.formats[r] == start.formats[r] for r in registers)
    tried, cfg = _tried(case, start, budget, tune_registers=True)
    assert registers <= tried  # every register is a candidate; some may narrow
    assert any(cfg.formats[r] != start.formats[r] for r in registers)
    tried, _ = _tried(case, start, budget, signals=[named])  # named: tuned
    assert tried == {named}


def test_optimiser_rejects_unsafe_start():
    case = scene_case("lab", [32, 40])
    cfg = P1Config.default()
    f = cfg.formats["col_state"]
    bad = cfg.with_formats(
        col_state=FixedFormat(f.signed, f.word - 14, f.frac - 12, f.quant, f.overflow)
    )
    with pytest.raises(UserError, match="misses the budget"):
        optimise(case, bad, Budget(1e-4, 0.999), progress=False)
    with pytest.raises(ValueError, match="budget"):
        Budget(-1.0)


def test_cli_optimise_json(capsys):
    rc = cli.main(
        [
            "optimise",
            "--scene",
            "lab",
            "--size",
            "32",
            "40",
            "--verify",
            "runway",
            "--signals",
            "col_state",
            "row_state",
            "--json",
        ]
    )
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["cost_bits"] <= out["default_cost_bits"]
    assert out["median_rel_range_diff"] <= 0.01 and out["valid_agreement"] >= 0.99
    assert "[signals]" in out["config_toml"]
    P1Config.from_toml(out["config_toml"])  # loads back
    assert out["verify"]["scene"] == "runway" and out["verify"]["mode"] == "motion"
    # the default guard band: tuned to half the budget
    assert out["margin"] == 0.5 and out["tuning_budget"]["median_rel_range_diff"] == 0.005
    assert out["median_rel_range_diff"] <= 0.005


def _no_rotation(cfg: P1Config) -> P1Config:
    """``k_m_reg`` s4.3: the rotation terms round to (almost) nothing. Harmless on the
    stereo ``lab`` pair (no rotation), ruinous on ``runway`` (motion with rotation)."""
    f = cfg.formats["k_m_reg"]
    return cfg.with_formats(k_m_reg=FixedFormat(f.signed, 4, 3, f.quant, f.overflow))


def test_multi_scene_rejects_a_config_that_fails_one_scene():
    lab, runway = scene_case("lab", [32, 40]), scene_case("runway", [32, 40])
    budget = Budget(0.01, 0.99)
    start = P1Config.default()
    bad = _no_rotation(start)
    goldens = [P1.golden(lab, start).result, P1.golden(runway, start).result]
    # meets the budget on lab, misses it on runway
    on_lab, on_runway = evaluate_scenes([lab, runway], bad, goldens, budget)
    assert budget.met(on_lab) and not budget.met(on_runway)
    # scenes run in order, stopping at the first miss: runway first, lab never runs
    assert len(evaluate_scenes([runway, lab], bad, goldens[::-1], budget)) == 1
    optimise(lab, bad, budget, signals=["row_state"], progress=False)  # accepted on lab alone
    with pytest.raises(UserError, match="misses the budget on 'runway'"):
        optimise([lab, runway], bad, budget, signals=["row_state"], progress=False)
    # tuned on lab alone, the rotation registers go; tuned on both, they stay and the
    # result meets the budget on each scene (checked independently of the optimiser)
    only_lab = optimise(lab, start, budget, signals=["k_m_reg"], progress=False)
    both = optimise([lab, runway], start, budget, signals=["k_m_reg"], progress=False)
    assert only_lab.config.formats["k_m_reg"].word < both.config.formats["k_m_reg"].word
    assert not budget.met(compare_ranges(runner.run_case(P1, runway, only_lab.config), goldens[1]))
    for case, golden, figs in zip((lab, runway), goldens, both.scene_figures, strict=True):
        check = compare_ranges(runner.run_case(P1, case, both.config), golden)
        assert budget.met(check)
        assert check["median_rel_range_diff"] == figs["median_rel_range_diff"]
    assert both.figures == worst_case(both.scene_figures)
    # every candidate runs on lab, runway only after lab passed (k_m_reg: always here)
    assert both.scene_runs[0] == both.evaluations >= both.scene_runs[1] > 0
    assert both.figures["median_rel_range_diff"] == max(
        f["median_rel_range_diff"] for f in both.scene_figures
    )


def test_worst_case_of_scene_figures():
    a = {"median_rel_range_diff": 1e-3, "p95_rel_range_diff": 5e-2, "valid_agreement": 0.999,
         "n_valid_both": 10}  # fmt: skip
    b = {"median_rel_range_diff": 2e-3, "p95_rel_range_diff": 1e-2, "valid_agreement": 0.995,
         "n_valid_both": 7}  # fmt: skip
    w = worst_case([a, b])
    assert w == {"median_rel_range_diff": 2e-3, "p95_rel_range_diff": 5e-2,
                 "valid_agreement": 0.995, "n_valid_both": 7}  # fmt: skip
    assert math.isnan(worst_case([a, {**b, "median_rel_range_diff": math.nan}])[
        "median_rel_range_diff"
    ])  # fmt: skip
    assert not Budget(0.01).met(worst_case([a, {**b, "median_rel_range_diff": math.nan}]))


def test_motorcycle_is_a_p1_stereo_case():
    case = real_pair_case("motorcycle")
    assert case.mode == "stereo" and case.image1.shape == (26, 39)
    assert case.image1.dtype.kind == "i" and 0 <= case.image1.min() <= case.image1.max() <= 255
    cfg = P1Config.default()
    figs = compare_ranges(runner.run_case(P1, case, cfg), P1.golden(case, cfg).result)
    # the default config agrees with golden there (in mm the baseline would saturate
    # k_t_reg and every range would be off by 1 - 128/193 = 0.34)
    assert figs["median_rel_range_diff"] < 1e-3 and figs["valid_agreement"] > 0.99
    assert figs["n_valid_both"] > 300
    with pytest.raises(UserError, match="unknown real pair"):
        real_pair_case("kitti")


def test_plane_is_a_held_out_p1_stereo_case():
    case = held_out_case("plane", (32, 40))
    assert case.mode == "stereo" and case.image1.shape == (32, 40) and case.scene.name == "plane"
    assert case.image1.dtype.kind in "iu" and case.image1.dtype.itemsize == 1  # grey levels
    assert case.settings["ranging"].range_max == 10.0 == case.settings["riccati"].range_max
    assert float(case.scene.depth1.max()) == 5.0
    # 30 deg field of view kept at any size (f = 955 px, disparity 0.96 px at 512 wide)
    assert case.camera.f_px == pytest.approx(20 / math.tan(math.radians(15)))
    cfg = P1Config.default()
    figs = compare_ranges(runner.run_case(P1, case, cfg), P1.golden(case, cfg).result)
    assert figs["median_rel_range_diff"] < 1e-2 and figs["n_valid_both"] > 0
    with pytest.raises(UserError, match="unknown held-out scene 'hill'"):
        held_out_case("hill")


def test_cli_optimise_verify_on_the_held_out_plane(capsys):
    rc = cli.main(
        ["optimise", "--scene", "lab", "--size", "32", "40", "--signals", "k_m_reg",
         "--verify", "plane", "--json"]
    )  # fmt: skip
    assert rc == 0
    v = json.loads(capsys.readouterr().out)["verify"]
    assert v["scene"] == "plane" and v["mode"] == "stereo" and v["size"] == [32, 40]
    assert 0 <= v["median_rel_range_diff"] < 0.01 and 0.99 <= v["valid_agreement"] <= 1
    assert v["meets_budget"] is True
    for key in ("p95_rel_range_diff", "cost_bits", "default_cost_bits",
                "default_median_rel_range_diff", "default_valid_agreement"):  # fmt: skip
        assert key in v


def test_cli_optimise_tune_registers_flag_in_json(capsys):
    argv = ["optimise", "--scene", "lab", "--size", "32", "40", "--signals", "k_m_reg", "--json"]
    assert cli.main(argv) == 0
    assert json.loads(capsys.readouterr().out)["tune_registers"] is False
    assert cli.main([*argv, "--tune-registers"]) == 0
    assert json.loads(capsys.readouterr().out)["tune_registers"] is True


def test_cli_optimise_several_scenes_json(capsys):
    rc = cli.main(
        ["optimise", "--scene", "lab", "runway", "--size", "32", "40", "--signals", "k_m_reg",
         "row_state", "--verify", "motorcycle", "--json"]
    )  # fmt: skip
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["tuning_scenes"] == ["lab", "runway"] and out["scene"] == "lab"
    assert out["cost_scene"] == "lab" and out["mode"] == "stereo"
    scenes = out["scenes"]
    assert set(scenes) == {"lab", "runway"}
    assert scenes["runway"]["mode"] == "motion" and scenes["lab"]["mode"] == "stereo"
    for sf in scenes.values():
        assert sf["median_rel_range_diff"] <= 0.01 and sf["valid_agreement"] >= 0.99
        assert sf["cost_bits"] < sf["default_cost_bits"]
        for key in ("p95_rel_range_diff", "start_median_rel_range_diff", "size"):
            assert key in sf
    assert out["cost_bits"] == scenes["lab"]["cost_bits"]
    assert scenes["lab"]["runs"] == out["evaluations"] >= scenes["runway"]["runs"]
    assert out["default_cost_bits"] == scenes["lab"]["default_cost_bits"]
    assert out["bits_saved"] == out["default_cost_bits"] - out["cost_bits"]
    assert out["median_rel_range_diff"] == max(s["median_rel_range_diff"] for s in scenes.values())
    assert out["valid_agreement"] == min(s["valid_agreement"] for s in scenes.values())
    cfg = P1Config.from_toml(out["config_toml"])
    assert cfg.formats["k_m_reg"].word > 4  # runway keeps the rotation registers
    v = out["verify"]
    assert v["scene"] == "motorcycle" and v["mode"] == "stereo" and v["size"] == [26, 39]
    for key in ("median_rel_range_diff", "valid_agreement", "meets_budget", "cost_bits",
                "default_cost_bits", "default_median_rel_range_diff"):  # fmt: skip
        assert key in v


def test_budget_tightened_by_a_margin():
    b = Budget(0.01, 0.99)
    assert b.tightened(0) is b and b.tightened(0.0) is b
    t = b.tightened(0.5)
    assert t.median == pytest.approx(0.005) and t.agreement == pytest.approx(0.995)
    assert b.tightened(0.75).agreement == pytest.approx(0.9975)  # disagreement 0.01 -> 0.0025
    figs = {"median_rel_range_diff": 0.007, "valid_agreement": 0.999}
    assert b.met(figs) and not t.met(figs)
    for bad in (1, 1.0, -0.1, math.nan, math.inf, True, "0.5", None):
        with pytest.raises(UserError, match=r"--margin must be a number in \[0, 1\)"):
            b.tightened(bad)


def test_margin_tightens_acceptance():
    lab, runway = scene_case("lab", [32, 40]), scene_case("runway", [32, 40])
    budget, start = Budget(0.01, 0.99), P1Config.default()
    sig = ["col_state", "row_state"]
    plain = optimise([lab, runway], start, budget, signals=sig, progress=False)
    guarded = optimise([lab, runway], start, budget, margin=0.5, signals=sig, progress=False)
    tight = budget.tightened(0.5)
    assert plain.tuning_budget is budget and guarded.tuning_budget == tight
    # without the margin runway ends above the tightened median: the margin bites
    assert not tight.met(plain.figures)
    goldens = [P1.golden(lab, start).result, P1.golden(runway, start).result]
    for case, golden, figs in zip((lab, runway), goldens, guarded.scene_figures, strict=True):
        check = compare_ranges(
            runner.run_case(P1, case, guarded.config), golden
        )  # independent re-run
        assert check["median_rel_range_diff"] <= 0.005 and check["valid_agreement"] >= 0.995
        assert check["median_rel_range_diff"] == figs["median_rel_range_diff"]
    shape = lab.image1.shape
    assert (
        config_cost(plain.config, shape, "stereo").cost_bits
        < config_cost(guarded.config, shape, "stereo").cost_bits
        < config_cost(start, shape, "stereo").cost_bits
    )
    # a start that meets the budget but not the tightened one is refused, naming the band
    with pytest.raises(UserError, match=r"misses the budget tightened by the margin 0\.5 on 'lab'"):
        optimise([lab, runway], plain.config, budget, margin=0.5, signals=sig, progress=False)
    optimise([lab, runway], plain.config, budget, signals=["row_state"], progress=False)


def test_margin_zero_reproduces_the_plain_optimiser():
    """Margin 0 chooses what the optimiser chose before margins existed (formats and
    run counts recorded from commit 58c8325 on this case)."""
    lab, runway = scene_case("lab", [32, 40]), scene_case("runway", [32, 40])
    sig = ["col_state", "row_state"]
    res = optimise([lab, runway], P1Config.default(), Budget(0.01, 0.99), margin=0,
                   signals=sig, progress=False)  # fmt: skip
    assert {s: str(res.config.formats[s]) for s in sig} == {
        "col_state": "u11.3",
        "row_state": "u10.2",
    }
    assert res.evaluations == 19
    only_lab = optimise(lab, P1Config.default(), Budget(0.01, 0.99), margin=0.0,
                        signals=sig, progress=False)  # fmt: skip
    assert {s: str(only_lab.config.formats[s]) for s in sig} == {
        "col_state": "u10.3",
        "row_state": "u11.3",
    }
    assert only_lab.evaluations == 20


def test_cli_optimise_margin_json(capsys):
    rc = cli.main(
        ["optimise", "--scene", "lab", "runway", "--size", "32", "40", "--signals", "col_state",
         "row_state", "--margin", "0.5", "--verify", "motorcycle", "--json"]
    )  # fmt: skip
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["margin"] == 0.5
    assert out["budget"] == {"median_rel_range_diff": 0.01, "valid_agreement": 0.99}
    tb = out["tuning_budget"]
    assert tb["median_rel_range_diff"] == pytest.approx(0.005)
    assert tb["valid_agreement"] == pytest.approx(0.995)
    for sf in out["scenes"].values():
        assert sf["median_rel_range_diff"] <= 0.005 and sf["valid_agreement"] >= 0.995
    v = out["verify"]  # judged against the user's budget, not the tightened one
    assert v["meets_budget"] == (
        v["median_rel_range_diff"] <= 0.01 and v["valid_agreement"] >= 0.99
    )


def test_cli_optimise_tunes_on_the_real_pair(capsys):
    rc = cli.main(
        ["optimise", "--scene", "motorcycle", "lab", "--size", "32", "40", "--signals", "v_sq",
         "--verify", "runway", "--json"]
    )  # fmt: skip
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["cost_scene"] == "motorcycle" and out["size"] == [26, 39]  # its own size
    assert out["scenes"]["lab"]["size"] == [32, 40]
    for sf in out["scenes"].values():
        assert sf["median_rel_range_diff"] <= 0.01 and sf["valid_agreement"] >= 0.99
    # v_sq with an LSB of 4096 rounds the pair's vx^2 (~102) to 0: the T_g test stops
    # rejecting; a start like that is refused, naming the real pair
    cfg = P1Config.default()
    f = cfg.formats["v_sq"]
    coarse = cfg.with_formats(v_sq=FixedFormat(f.signed, 9, -12, f.quant, f.overflow))
    with pytest.raises(UserError, match="misses the budget on 'motorcycle'"):
        optimise(real_pair_case("motorcycle"), coarse, Budget(0.01, 0.99), progress=False)


@pytest.mark.parametrize("margin", ["1", "1.5", "-0.1", "nan", "inf"])
def test_cli_optimise_bad_margin(error_line, margin):
    assert cli.main(["optimise", "--margin", margin, "--json"]) == 2
    assert error_line().startswith("rangefx: error: --margin must be a number in [0, 1)")


#: --pipeline p2's options P2 has not (its one mode, its own signals)
P2_OPTION_ERRORS = [
    (["--variant", "paper"], "--variant does not apply to pipeline p2"),
    (["--pole", "0.5"], "--pole does not apply to pipeline p2"),
    (["--scene", "runway"], "--scene runway: P2 models stereo mode only"),
    (["--verify", "runway"], "--verify runway: P2 models stereo mode only"),
    (["--signals", "row_state"], "--signals: unknown P2 signal 'row_state'"),
    (["--signals", "p2_stt"], "(did you mean 'p2_st'?)"),
]


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        # a tuning scene is never the held-out one
        (["--scene", "lab", "runway", "--verify", "runway"], "--verify runway: it is a tuning"),
        (["--scene", "lab", "--verify", "lab"], "--verify lab: it is a tuning scene"),
        (["--scene", "lab", "lab"], "named twice"),
        (["--scene", "plane"], "--scene plane: it is held out of tuning, for --verify only"),
        (["--scene", "lab", "plane", "--verify", "plane"], "--scene plane: it is held out"),
        *((["--pipeline", "p2", *argv], match) for argv, match in P2_OPTION_ERRORS),
    ],
)
def test_cli_optimise_option_errors(error_line, argv, match):
    assert cli.main(["optimise", *argv, "--size", "32", "40", "--json"]) == 2
    assert match in error_line()


def test_cli_sweep_and_errors(tmp_path, capsys):
    d = tmp_path / "def.toml"
    d.write_text(SMALL.replace("range = [5, 9]", "range = [5, 5]"))
    out = tmp_path / "out"
    assert cli.main(["sweep", str(d), "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["complete"] and (out / "summary.json").exists()
    d.write_text("[sweep]\n")
    assert cli.main(["sweep", str(d), "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err
    assert "rangefx: error:" in err and "def.toml" in err and len(err.strip().splitlines()) == 1
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "x").write_text("x")
    d.write_text(SMALL)
    assert cli.main(["sweep", str(d), "--out", str(busy)]) == 2
    assert cli.main(["optimise", "--budget", "-1"]) == 2


def test_example_definition_has_200_configs():
    from rangefx.tools.studies.sweep import load_sweep
    from rangefx.tools.studies.sweepdir import example_path

    defn = load_sweep(example_path())
    points = expand(defn)
    ok = {p.key for p in points if p.config is not None}
    assert len(ok) >= 200
    assert load_results(Path("/nonexistent/results.jsonl")) == {}


def test_p1_buildup_along_rows_and_columns():
    case = scene_case("lab", [32, 40])
    profiles = buildup_for(P1, case, P1Config.default())
    assert set(profiles) == {"row", "col"}
    assert profiles["row"]["index"].tolist() == list(range(40))  # one value per column
    assert profiles["col"]["index"].tolist() == list(range(32))  # one value per row
    # the row filter's error at column 0 is zero (init = first copies the exact input)
    assert profiles["row"]["e2.row_state"][0] == 0
    assert profiles["row"]["e2.row_state"][1:].max() > 0


def test_p2_buildup_along_the_backward_sweep():
    case = scene_case("lab", [32, 40])
    cfg = P2.default_config()
    profiles = buildup_for(P2, case, cfg)
    assert set(profiles) == {"riccati"}
    prof = profiles["riccati"]
    assert prof["index"].tolist() == list(range(39))  # columns n - 2 .. 0
    assert set(prof) == {"index", "range.rel", "e", "e.lsb_rms"}
    # e_0 = 0 in the model and in G5: the last position (column 0) has no error
    assert prof["e"][-1] == 0 and prof["e"][:-1].max() > 0
    assert prof["e.lsb_rms"][0] == 2.0 ** -cfg.formats["p2_e"].frac / math.sqrt(12)
    rel = prof["range.rel"][np.isfinite(prof["range.rel"])]
    assert rel.size > 0 and rel.max() < 0.1
    # e with one fraction bit (LSB 0.5, from 13): its error rises above the default's
    coarse = cfg.with_formats(p2_e=FixedFormat(True, 22 - 12, 13 - 12, *_modes(cfg, "p2_e")))
    coarse_e = buildup_for(P2, case, coarse)["riccati"]["e"]
    assert np.mean(coarse_e[:-1]) > 1.5 * np.mean(prof["e"][:-1])


def _modes(cfg, name):
    f = cfg.formats[name]
    return f.quant, f.overflow


def test_golden_cache_keys_on_what_the_golden_reads():
    """P2's G5 reads no config field, P1's golden its estimator settings: the sweep's
    golden cache shares P2's golden across dividers and keeps P1's poles apart."""
    case = scene_case("lab", [32, 40])
    key = ("lab", (32, 40), 0)
    a, b = P2.default_config(), P2.default_config(divider="restoring")
    assert P2.golden_key(a) == P2.golden_key(b) == ()
    assert cached_golden(P2, case, a, key, False) is cached_golden(P2, case, b, key, False)
    g_a, g_b = P2.golden(case, a).result, P2.golden(case, b).result
    assert np.array_equal(g_a.range, g_b.range) and np.array_equal(g_a.valid, g_b.valid)
    c, d = P1.default_config(), P1.default_config(pole=0.375, filter_form="direct")
    assert P1.golden_key(c) != P1.golden_key(d)
    assert P1.golden_key(c) == P1.golden_key(c.with_(divider="restoring"))
    assert cached_golden(P1, case, c, key, False) is not cached_golden(P1, case, d, key, False)
    assert not np.array_equal(P1.golden(case, c).result.range, P1.golden(case, d).result.range)


def test_example_p2_definition():
    from rangefx.tools.studies.sweep import load_sweep
    from rangefx.tools.studies.sweepdir import example_path

    defn = load_sweep(example_path().with_name("p2_lab.toml"))
    assert defn.pipeline == "p2" and defn.base == P2.default_config() and defn.size is None
    points = expand(defn)
    assert len({p.key for p in points if p.config is not None}) >= 150
    assert all(set(a.signals) <= set(P2.default_config().signals()) for a in defn.axes)


# ----------------------------------------------------------------------- P2 command line
def test_cli_optimise_p2_json(capsys):
    rc = cli.main(
        ["optimise", "--pipeline", "p2", "--scene", "lab", "--size", "32", "40",
         "--verify", "motorcycle", "--json"]
    )  # fmt: skip
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["pipeline"] == "p2" and out["golden"] == "g5_riccati" and "variant" not in out
    assert out["cost_bits"] < out["default_cost_bits"]
    assert out["default_cost_bits"] == P2.cost(P2.default_config(), (32, 40)).cost_bits
    cfg = P2.config_from_toml(out["config_toml"])  # loads back as a P2 config
    assert out["cost_bits"] == P2.cost(cfg, (32, 40)).cost_bits
    assert all(cfg.formats[r] == P2.default_config().formats[r] for r in cfg.HOST_REGISTERS)
    lab = out["scenes"]["lab"]  # tuned with the default guard band: half the budget
    assert lab["median_rel_range_diff"] <= 0.005 and lab["valid_agreement"] >= 0.995
    assert lab["saturated_registers"] == []
    v = out["verify"]
    assert v["scene"] == "motorcycle" and v["mode"] == "stereo" and v["size"] == [26, 39]
    assert v["meets_budget"] == (
        v["median_rel_range_diff"] <= 0.01 and v["valid_agreement"] >= 0.99
    )
    for key in ("p95_rel_range_diff", "cost_bits", "default_cost_bits", "saturated_registers",
                "default_median_rel_range_diff", "default_saturated_registers"):  # fmt: skip
        assert key in v


def test_cli_sweep_p2_end_to_end(tmp_path, capsys):
    d = tmp_path / "p2.toml"
    d.write_text(SMALL_P2.replace("range = [4, 7]", "range = [6, 7]"))
    out = tmp_path / "out"
    assert cli.main(["sweep", str(d), "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["complete"] and summary["pipeline"] == "p2" and summary["n_points"] == 5
    assert summary["n_ok"] == 5 and "variant" not in summary
    assert (out / "buildup_base_riccati.csv").stat().st_size > 0
    assert json.loads((out / "summary.json").read_text())["buildup"]
    # re-running the command resumes: nothing left to compute
    assert cli.main(["sweep", str(d), "--out", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["computed_this_run"] == 0
