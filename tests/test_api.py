"""The Python API (SPEC §15, :mod:`rangefx.api`): each job as a user calls it, on small
cases; every result's ``to_dict()`` / ``write()`` round trip; and the command line, which
is one API call per command, writes the same files as the API for run, vectors gen and
sweep."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from guarantee_tables import SWEEP as SWEEP_TEMPLATE

import rangefx
from rangefx import api
from rangefx.rtl_model.pipeline import Pipeline
from rangefx.rtl_model.registry import PIPELINES
from rangefx.tools.cli import main
from rangefx.tools.errors import UserError
from rangefx.tools.report import MARKER_NAME
from rangefx.vectors.generate import MANIFEST_NAME, load_manifest

CROP = (248, 256, 240, 256)  # 8x16 pixels of lab
FIXTURES = Path(__file__).parent / "fixtures"
SWEEP = SWEEP_TEMPLATE.format(name="api", values="[6, 8]")


def _pair(tmp_path: Path) -> tuple[Path, Path]:
    """A 24x32 random pair shifted by one pixel, as two .npy files."""
    rng = np.random.default_rng(0)
    left = rng.integers(0, 256, (24, 32)).astype(np.float64)
    np.save(tmp_path / "l.npy", left)
    np.save(tmp_path / "r.npy", np.roll(left, 1, axis=1))
    return tmp_path / "l.npy", tmp_path / "r.npy"


def _files(directory: Path) -> dict[str, bytes]:
    """Every file under ``directory`` (relative name -> bytes)."""
    return {
        str(p.relative_to(directory)): p.read_bytes()
        for p in sorted(directory.rglob("*"))
        if p.is_file()
    }


def _lab_case(pipe: Pipeline):
    """A small case in a mode ``pipe`` models: lab (stereo) or runway (motion)."""
    name = "lab" if "stereo" in pipe.modes else "runway"
    return api.scene_case(name, crop=CROP)


# -- the package --------------------------------------------------------------------------
def test_import_rangefx_stays_cheap_and_gives_the_api():
    """``import rangefx`` imports no numpy (the CLI's start-up); the API's names are the
    package's attributes, imported on first use."""
    code = "import sys, rangefx; print('numpy' in sys.modules, 'rangefx.api' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert out == ["False", "False"]
    assert rangefx.run is api.run and rangefx.api is api
    assert set(rangefx.API_NAMES) <= set(api.__all__)
    with pytest.raises(AttributeError):
        rangefx.no_such_name  # noqa: B018


# -- cases ----------------------------------------------------------------------------------
def test_scene_case_crop_keeps_every_pixels_coordinates():
    full = api.scene_case("lab")
    case = api.scene_case("lab", crop=CROP)
    r0, r1, c0, c1 = CROP
    assert case.shape == (r1 - r0, c1 - c0)
    np.testing.assert_array_equal(case.image1, full.image1[r0:r1, c0:c1])
    cx, cy = full.camera.principal_point
    assert case.camera.principal_point == pytest.approx((cx - c0, cy - r0))
    assert case.camera.f_px == full.camera.f_px
    with pytest.raises(UserError, match="at least 2x2"):
        api.scene_case("lab", crop=(10, 11, 0, 5))


def test_image_case_from_arrays_and_from_files_is_one_case(tmp_path):
    left, right = _pair(tmp_path)
    from_files = api.image_case(left, right, f_px=40.0, baseline=0.1)
    arrays = np.load(left), np.load(right)
    from_arrays = api.image_case(*arrays, f_px=40.0, baseline=0.1, threshold_e=3.0)
    np.testing.assert_array_equal(from_files.image1, from_arrays.image1)
    assert from_files.camera == from_arrays.camera and from_files.mode == "stereo"
    assert from_arrays.settings["ranging"].threshold_e == 3.0
    assert from_arrays.settings["riccati"].threshold_e == 3.0
    assert "ranging" not in from_files.settings  # the defaults
    with pytest.raises(UserError, match="shapes differ"):
        api.image_case(arrays[0], arrays[1][:, :-1], f_px=40.0, baseline=0.1)
    with pytest.raises(UserError, match="--f-px and --baseline"):
        api.image_case(*arrays)
    with pytest.raises(UserError, match="not found"):
        api.image_case(tmp_path / "nope.npy", right, f_px=40.0, baseline=0.1)


# -- run ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(PIPELINES))
def test_run_every_pipeline_and_its_result_round_trips(name, tmp_path):
    pipe = PIPELINES[name]
    result = api.run(_lab_case(pipe), pipeline=name)
    figures = result.to_dict()
    assert figures["pipeline"] == name and result.config == pipe.default_config()
    assert 0 <= figures["valid_agreement"] <= 1 and figures["table"]
    assert json.loads(json.dumps(figures)) == figures  # JSON-able as it is
    out = result.write(tmp_path / "run")
    assert json.loads((out / "summary.json").read_text()) == figures
    np.testing.assert_array_equal(np.load(out / "range.npy"), result.result.range)
    np.testing.assert_array_equal(np.load(out / "valid.npy"), result.result.valid)
    with np.load(out / "taps.npz") as taps:
        assert set(taps.files) == set(result.result.taps) != set()
    assert pipe.load_config(out / "config.toml") == result.config


def test_run_a_golden_method_and_refuse_what_it_does_not_read(tmp_path):
    case = api.scene_case("lab", crop=CROP)
    result = api.run(case, pipeline="golden", method="g2_central")
    assert result.to_dict()["method"] == "g2_central" and result.config is None
    out = result.write(tmp_path / "g")
    assert sorted(p.name for p in out.iterdir() if p.name != MARKER_NAME) == [
        "range.npy", "range.png", "summary.json", "valid.npy",
    ]  # fmt: skip
    with pytest.raises(UserError, match="fixed-point pipelines only"):
        api.run(case, pipeline="golden", variant="paper")
    with pytest.raises(UserError, match="unknown pipeline"):
        api.run(case, pipeline="p9")


def test_run_refuses_fractional_grey_levels_naming_the_image():
    rng = np.random.default_rng(1)
    image = rng.integers(0, 256, (8, 12)).astype(np.float64)
    case = api.image_case(image + 0.5, image, f_px=30.0, baseline=0.1)
    with pytest.raises(UserError, match="left must hold integer grey levels"):
        api.run(case, pipeline="p1", input_names=("left", "right"))


# -- test vectors ---------------------------------------------------------------------------
def test_vectors_from_an_existing_result_are_not_a_second_run(tmp_path, monkeypatch):
    """A result's taps are written as they are: the model is not run again (it would
    raise here), and the directory equals the one generated from the case."""
    case = api.scene_case("lab", crop=CROP)
    result = api.run(case, pipeline="p1")
    from_case = api.generate_vectors(case, tmp_path / "a")

    def no_second_run(*args, **kwargs):
        raise AssertionError("the model ran again")

    monkeypatch.setattr(type(PIPELINES["p1"]), "run", no_second_run)
    from_result = api.generate_vectors(result, tmp_path / "b")
    assert _files(tmp_path / "a") == _files(tmp_path / "b")
    assert from_result.manifest == from_case.manifest
    assert from_result.to_dict()["files"] == len(from_case.vectors.files) + 1
    monkeypatch.undo()
    bare = api.run(case, pipeline="p1", taps=False)
    with pytest.raises(UserError, match="taps=True"):
        api.generate_vectors(bare, tmp_path / "c")
    assert not (tmp_path / "c").exists()


def test_vectors_check_diff_and_their_reports_round_trip(tmp_path):
    vec = api.generate_vectors("lab", tmp_path / "vec", crop=CROP, formats=("mem", "csv")).out
    check = api.check_vectors(vec)
    assert check.ok and check.rerun and check.provenance
    assert json.loads(check.write(tmp_path / "rep").read_text()) == check.to_dict()
    tap = vec / "e1.bias_in.mem"
    assert api.diff_vectors(vec, tap).ok
    words = tap.read_text().splitlines()
    words[5] = format(int(words[5], 16) ^ 1, f"0{len(words[5])}x")  # one bit of one sample
    dump = tmp_path / "e1.bias_in.mem"
    dump.write_text("\n".join(words) + "\n")
    diff = api.diff_vectors(vec, dump)
    assert not diff.ok and diff.mismatches == 1 and diff.first["index"] == 4
    assert json.loads(diff.write(tmp_path / "rep").read_text()) == diff.to_dict()
    manifest = json.loads((vec / MANIFEST_NAME).read_text())
    manifest["case"]["seed"] = 1  # an edited provenance: the inputs no longer reproduce
    (vec / MANIFEST_NAME).write_text(json.dumps(manifest, indent=1) + "\n")
    assert not api.check_vectors(vec).ok


def test_vectors_of_your_own_arrays_check_without_a_scene(tmp_path):
    left, right = _pair(tmp_path)
    case = api.image_case(np.load(left), np.load(right), f_px=40.0, baseline=0.1)
    out = api.generate_vectors(case, tmp_path / "vec").out
    assert load_manifest(out)["case"]["source"] == "python"
    report = api.check_vectors(out)
    assert report.ok and report.rerun and not report.provenance
    assert not api.check_vectors(out, provenance=True).ok  # required, and not a scene


def test_vectors_written_before_the_case_held_settings_by_key_still_check(tmp_path):
    """A P1 vector directory written when ``Case`` had the fields ``ranging`` and
    ``riccati`` (its manifest stores both, P1 on a user's 3x8 pair with T_E = 3): the
    settings load into ``Case.settings`` by key, and a re-run reproduces every data file
    byte for byte and the manifest's case. The fixture was written when P1's input-to-range
    latency was 72 cycles (92 since its products were pipelined through the DSPs'
    registers and the range stage's casts and three-term sums split), so the manifest's
    cycle entries (each file's first valid cycle, the latency, the total cycles) and
    only those differ from a fresh run."""
    old = shutil.copytree(FIXTURES / "vectors_v1_p1_image", tmp_path / "v1")
    manifest = load_manifest(old)
    case = manifest["case"]
    assert case["ranging"]["threshold_e"] == 3.0 == case["riccati"]["threshold_e"]
    assert manifest["latency"]["total"] == 72
    report = api.check_vectors(old)
    assert report.rerun
    cycles_only = "manifest.json: differs from a fresh run in ['files', 'latency', 'total_cycles']"
    assert report.problems == [cycles_only], report.problems


def test_generate_vectors_never_replaces_a_users_directory(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    with pytest.raises(UserError, match="mine"):
        api.generate_vectors("lab", out, crop=CROP)
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    assert (out / "notes.txt").read_text() == "keep me"


@pytest.mark.skipif(shutil.which("iverilog") is None, reason="needs Icarus Verilog")
def test_replay_a_p1_directory_in_a_simulator(tmp_path, monkeypatch):
    pytest.importorskip("cocotb")
    vec = api.generate_vectors("lab", tmp_path / "vec", crop=CROP).out
    hdl = Path(rangefx.__file__).parent / "hdl"
    before = {p: p.stat().st_mtime_ns for p in hdl.rglob("*")}
    result = api.replay(vec, "icarus", dump=tmp_path / "dump")
    assert result.ok and result.to_dict()["value_mismatches"] == 0
    # the simulator's files stay in its work directory, never beside the package's RTL
    assert {p: p.stat().st_mtime_ns for p in hdl.rglob("*")} == before
    assert (tmp_path / "dump" / "status.json").is_file()
    assert json.loads(result.write(tmp_path / "rep").read_text()) == result.to_dict()
    p3 = api.generate_vectors("lab", tmp_path / "p3", crop=CROP, pipeline="p3").out

    def no_build(*args, **kwargs):
        raise AssertionError("the simulator was built for P3 vectors")

    monkeypatch.setattr("rangefx.vectors.replay.simulate", no_build)
    with pytest.raises(UserError, match="the RTL implements P1 and P2; these are p3 vectors"):
        api.replay(p3)  # refused before any build


# -- word-length studies --------------------------------------------------------------------
def test_sweep_resumes_and_writes_its_outputs_elsewhere(tmp_path):
    definition = tmp_path / "api.toml"
    definition.write_text(SWEEP)
    first = api.sweep(definition, tmp_path / "sw")
    summary = first.to_dict()
    assert summary["complete"] and summary["n_points"] == first.summary["n_points"] == 3
    assert summary["computed_this_run"] == 3
    again = api.sweep(definition, tmp_path / "sw")
    assert again.summary["computed_this_run"] == 0
    assert again.outcome.records == first.outcome.records
    with pytest.raises(UserError, match="resume is off"):
        api.sweep(definition, tmp_path / "sw", resume=False)
    copy = again.write(tmp_path / "copy")
    assert (copy / "points.csv").read_bytes() == (tmp_path / "sw" / "points.csv").read_bytes()


def test_optimise_verifies_on_a_held_out_scene_and_writes_its_report(tmp_path):
    report = api.optimise(
        "p1", "lab", size=(32, 40), signals=["k_m_reg"], verify="plane", workers=1
    )
    figures = report.to_dict()
    assert figures["verify"]["scene"] == "plane" and "meets_budget" in figures["verify"]
    assert figures["cost_bits"] <= figures["default_cost_bits"]
    assert report.config.to_toml() == figures["config_toml"]
    out = report.write(tmp_path / "opt")
    assert PIPELINES["p1"].load_config(out / "optimised.toml") == report.config
    assert json.loads((out / "summary.json").read_text()) == figures
    with pytest.raises(UserError, match="tuning scene"):
        api.optimise("p1", ["lab"], size=(32, 40), verify="lab")
    with pytest.raises(UserError, match="held out"):
        api.optimise("p1", ["plane"], size=(32, 40))


# -- evaluation and guidance ----------------------------------------------------------------
def test_evaluate_the_report_protocol_round_trips(tmp_path):
    result = api.evaluate(protocol="report", factor=19, pipelines=["p1"])
    figures = result.to_dict()
    assert set(figures["methods"]) == {"g2_central", "g3_consistent", "g3_paper", "g5_riccati"}
    assert set(figures["fixed_point"]) == {f"p1_{v}" for v in PIPELINES["p1"].variants}
    assert json.loads((result.write(tmp_path / "ev") / "summary.json").read_text()) == figures
    with pytest.raises(UserError, match="middlebury only"):
        api.evaluate(protocol="report", peers=True)


def test_guide_flies_the_report_law_and_writes_its_files(tmp_path):
    result = api.guide("synthetic", law="report", guidance_interval=0.5)
    assert result.programme == "flight" and result.metrics["flight_time_s"] > 0
    out = result.write(tmp_path / "g")
    assert json.loads((out / "summary.json").read_text()) == result.to_dict()
    assert {"trajectory.csv", "obstacles.csv", "extents.csv"} <= {p.name for p in out.iterdir()}
    with pytest.raises(UserError, match="clearance must be a positive number of feet"):
        api.guide(clearance_ft=-1.0)


def test_track_one_pixel_and_write_its_figures(tmp_path):
    result = api.track(40.0, 30.0, duration=0.5, taus=(0.1,))
    figures = result.to_dict()
    assert figures["steps"] == len(result.run.truth) and set(figures["filtered"]) == {"0.1"}
    out = result.write(tmp_path / "t")
    assert json.loads((out / "summary.json").read_text()) == figures
    assert {"tracking.csv", "fig5_raw.png"} <= {p.name for p in out.iterdir()}
    with pytest.raises(UserError, match="--duration must be a positive number"):
        api.track(duration=0.0)


def test_degrees_ranges_each_degree_up_to_the_order(tmp_path):
    result = api.degrees("lab", order=2, size=(32, 32))
    per_degree = result.to_dict()["settings"]["order2"]
    assert [v["degree"] for v in per_degree.values()] == [1, 2]
    assert all(v["estimator_order"] == 2 for v in per_degree.values())
    out = result.write(tmp_path / "d")
    assert json.loads((out / "summary.json").read_text()) == result.to_dict()
    with pytest.raises(UserError, match="unknown scene name"):
        api.degrees("nowhere")


def test_demo_refuses_bad_settings_before_any_work_and_writes_its_files(tmp_path):
    """The whole demo runs in tests/test_cli.py (``rangefx demo`` is one call of
    ``api.demo``); here its one-line errors and the result's atomic write."""
    with pytest.raises(UserError, match="unknown pipeline 'p9'"):
        api.demo(pipelines=["p9"])
    with pytest.raises(UserError, match="pole"):
        api.demo(pole=0.0)
    files = {"summary.json": b"{}\n", "guide/trajectory.csv": b"t,x\n"}
    result = api.DemoResult({"scene": {"name": "lab"}}, (), files)
    out = result.write(tmp_path / "demo")
    assert _files(out) == {**files, MARKER_NAME: (out / MARKER_NAME).read_bytes()}
    assert result.to_dict() == {"scene": {"name": "lab"}}


def test_synth_and_timing_are_what_the_command_line_prints(tmp_path, monkeypatch, capsys):
    """Yosys area of P1's front end and its place-and-route timing on 16-pixel lines (the
    smallest designs): the API synthesises what it is asked (one stage, no probes, the
    frame, the speed grade, the seeds), and ``rangefx hdl synth|timing --json`` prints
    the same figures (the CLI calls the API and prints)."""
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    area = api.synth("p1", stage="frontend", shape=(16, 16), probes=False)
    fig = area.figures
    assert (fig["pipeline"], fig["config"], fig["target"], fig["headline"]) == (
        "p1", "default", "xcup", "stages")  # fmt: skip
    assert fig["shape"] == [16, 16] and set(fig["stages"]) == {"frontend"} and "probes" not in fig
    assert fig["stages"]["frontend"]["lut"] > 0 and not fig["stages"]["frontend"]["cached"]
    argv = ["hdl", "synth", "--stage", "frontend", "--width", "16", "--height", "16",
            "--no-probes", "--json"]  # fmt: skip
    assert main(argv) == 0
    cached = json.loads(capsys.readouterr().out)
    assert cached["stages"]["frontend"]["cached"]
    cached["stages"]["frontend"]["cached"] = False
    assert cached == area.to_dict()
    out = area.write(tmp_path / "s")
    assert json.loads((out / "synth.json").read_text()) == area.to_dict()

    fmax = api.timing("p1", stage="frontend", shape=(8, 16), seeds=1, speed=8)
    fig = fmax.figures
    assert (fig["stage"], fig["shape"], fig["speed"], fig["device"]) == (
        "frontend",
        [8, 16],
        8,
        "85k",
    )
    assert [s["seed"] for s in fig["seeds"]] == [1] and not fig["seeds"][0]["cached"]
    assert fmax.result.fmax_mhz["clk"] == fig["fmax_mhz"]["clk"] > 0
    argv = ["hdl", "timing", "--stage", "frontend", "--width", "16", "--height", "8",
            "--seeds", "1", "--speed", "8", "--json"]  # fmt: skip
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["seeds"][0]["cached"] and again["fmax_mhz"] == fig["fmax_mhz"]
    assert json.loads((fmax.write(tmp_path / "t") / "timing.json").read_text())["pins"] > 0


def test_synth_and_timing_errors_are_one_line(tmp_path, monkeypatch):
    """A pipeline without RTL, Verilog Yosys cannot read (one line with Yosys's error),
    and the device defaults of the family asked for (iCE40's ``up5k``, not ECP5's
    ``85k``: the options pass their checks and the flow reaches its first tool)."""
    from rangefx.tools.studies import synth, timing

    with pytest.raises(UserError, match="pipeline p3 has no RTL"):
        api.synth("p3")
    with pytest.raises(UserError, match="pipeline p3 has no RTL"):
        api.timing("p3")
    monkeypatch.setenv("RANGEFX_CACHE", str(tmp_path / "cache"))
    broken = tmp_path / "hdl"
    shutil.copytree(synth.HDL_DIR, broken)
    frontend = broken / "p1_frontend.v"
    frontend.write_text(frontend.read_text().replace("endmodule", "endmodul", 1))
    monkeypatch.setattr(synth, "HDL_DIR", broken)
    with pytest.raises(UserError, match=r"^yosys failed on frontend \(xcup\): ") as err:
        api.synth("p1", stage="frontend", shape=(16, 16), probes=False, use_cache=False)
    assert "\n" not in str(err.value)

    def no_tool():
        raise AssertionError("a tool ran")

    monkeypatch.setattr(timing, "yosys_command", no_tool)
    with pytest.raises(AssertionError, match="a tool ran"):
        api.timing("p1", target="ice40", stage="frontend", shape=(8, 16), seeds=1)


def test_a_case_holds_every_pipelines_settings_by_key():
    """``Case.from_scene`` puts each registered pipeline's scene preset under its settings
    key; ``settings=`` of the case builders replaces them; a pipeline reads its own."""
    from rangefx.golden.methods import SCENE_RANGING, SCENE_RICCATI
    from rangefx.golden.ranging import RangingConfig
    from rangefx.golden.scenes import render_scene
    from rangefx.rtl_model.pipeline import Case

    scene = render_scene("lab", size=(16, 16))
    case = Case.from_scene(scene)
    assert case.settings == {"ranging": SCENE_RANGING["lab"], "riccati": SCENE_RICCATI["lab"]}
    for pipe in PIPELINES.values():
        assert pipe.settings(case) is case.settings.get(pipe.settings_key, pipe.settings(case))
    loose = RangingConfig(range_max=7.0)
    assert api.scene_case("lab", size=(16, 16), settings={"ranging": loose}).settings == {
        "ranging": loose, "riccati": SCENE_RICCATI["lab"]}  # fmt: skip
    assert PIPELINES["p1"].range_max(Case.from_scene(scene, {"ranging": loose})) == 7.0
    pair = Case.from_images(scene.image1, scene.image2, f_px=40.0, baseline=0.1)
    assert pair.settings == {} and PIPELINES["p2"].range_max(pair) == 100.0  # the defaults
    with pytest.raises(ValueError, match="an image pair needs --f-px and --baseline"):
        Case.from_images(scene.image1, scene.image2)
    with pytest.raises(ValueError, match="must be a RiccatiConfig"):
        PIPELINES["p2"].settings(pair.with_setting("riccati", loose))
    with pytest.raises(ValueError, match=r"settings go in settings=\{key: \.\.\.\}"):
        Case(pair.image1, pair.image2, pair.camera, pair.motion, "stereo", loose)


# -- the command line is one API call -------------------------------------------------------
def test_cli_run_writes_what_the_api_writes(tmp_path, capsys):
    left, right = _pair(tmp_path)
    argv = ["run", "--left", str(left), "--right", str(right), "--f-px", "40", "--baseline",
            "0.1", "--pipeline", "p1", "--json", "--out", str(tmp_path / "cli")]  # fmt: skip
    assert main(argv) == 0
    printed = json.loads(capsys.readouterr().out)
    case = api.image_case(str(left), str(right), f_px=40.0, baseline=0.1)
    result = api.run(case, pipeline="p1", input_names=(str(left), str(right)))
    result.write(tmp_path / "api")
    assert printed == result.to_dict()
    cli, mine = _files(tmp_path / "cli"), _files(tmp_path / "api")
    assert cli.keys() == mine.keys()
    for name in cli.keys() - {"taps.npz"}:  # a zip's members carry their write time
        assert cli[name] == mine[name], name
    with np.load(tmp_path / "cli" / "taps.npz") as a, np.load(tmp_path / "api" / "taps.npz") as b:
        assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files)


def test_cli_vectors_gen_writes_what_the_api_writes(tmp_path, capsys):
    crop = [str(v) for v in CROP]
    argv = ["vectors", "gen", "--scene", "lab", "--crop", *crop, "--pipeline", "p2",
            "--formats", "mem,csv", "--out", str(tmp_path / "cli")]  # fmt: skip
    assert main(argv) == 0
    api.generate_vectors("lab", tmp_path / "api", crop=CROP, pipeline="p2", formats=["mem", "csv"])
    assert _files(tmp_path / "cli") == _files(tmp_path / "api")


def test_cli_sweep_writes_what_the_api_writes(tmp_path, capsys):
    definition = tmp_path / "api.toml"
    definition.write_text(SWEEP)
    assert main(["sweep", str(definition), "--out", str(tmp_path / "cli"), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    result = api.sweep(definition, tmp_path / "api")
    timing = {"wall_seconds_this_run", "seconds"}
    assert {k for k in printed if k not in timing} == {k for k in result.summary if k not in timing}
    assert printed["pareto"] == result.to_dict()["pareto"]

    def records(directory: Path) -> dict:
        lines = (directory / "results.jsonl").read_text().splitlines()
        return {r["key"]: {k: v for k, v in r.items() if "seconds" not in k and k != "wall_s"}
                for r in map(json.loads, lines)}  # fmt: skip

    assert records(tmp_path / "cli") == records(tmp_path / "api")
    cli, mine = _files(tmp_path / "cli"), _files(tmp_path / "api")
    assert cli.keys() == mine.keys()
