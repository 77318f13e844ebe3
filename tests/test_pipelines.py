"""The one pipeline interface (SPEC §10), checked for every pipeline of the registry: the
config type, the tap table against a run, the declared cycles, cost against the model's
buffers, golden taps, vectors, and the command line (an option a pipeline does not use
is an error, never ignored)."""

from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np
import pytest

from rangefx import rtl_model
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.rtl_model.config import TimingConfig, WordLengthConfig
from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.pipeline import VALID_FORMAT, Case, PipelineResult
from rangefx.rtl_model.registry import PIPELINES, get_pipeline
from rangefx.rtl_model.runtime import finish_band, reciprocal_lut
from rangefx.tools.cli import main
from rangefx.tools.studies.cases import crop_case, scene_case
from rangefx.tools.studies.runner import RUN_BASE_BYTES, run_memory_bytes
from rangefx.vectors.generate import build_vectors, check_vectors, diff_dump, write_vectors

NAMES = list(PIPELINES)
CROP = ["--crop", "240", "252", "100", "120"]  # 12 x 20 pixels of the lab pair
TIMING = TimingConfig(hblank=4, vblank=3, gap_prob=0.2, seed=5)


@functools.cache
def lab_crop() -> Case:
    return crop_case(scene_case("lab"), [240, 252, 100, 120])


@functools.cache
def run(name: str) -> PipelineResult:
    return PIPELINES[name].run(lab_crop(), timing=TIMING, taps=True)


def test_registry():
    # every pipeline folder of the package is registered (a folder with a pipeline.py)
    folders = {p.parent.name for p in Path(rtl_model.__file__).parent.glob("*/pipeline.py")}
    assert folders and folders <= set(NAMES)
    for name, p in PIPELINES.items():
        assert p.name == name and get_pipeline(name) is p
        assert issubclass(p.config_type, WordLengthConfig)
        # the memory guard's figure is the pipeline's own, and every shipped one is measured
        assert p.run_bytes_per_pixel is not None and p.run_bytes_per_pixel > 0
        assert run_memory_bytes(10, name) == RUN_BASE_BYTES + 10 * p.run_bytes_per_pixel
    with pytest.raises(ValueError, match=f"unknown pipeline 'p9'; choose from {', '.join(NAMES)}$"):
        get_pipeline("p9")


@pytest.mark.parametrize("name", NAMES)
def test_config_type_round_trips_and_names_the_signal(name, tmp_path):
    p = PIPELINES[name]
    cfg = p.default_config()
    assert isinstance(cfg, p.config_type) and cfg.PIPELINE == name
    again = p.config_from_toml(cfg.to_toml())
    assert again == cfg and again.design() == cfg.design()
    path = tmp_path / "c.toml"
    cfg.save(path)
    assert p.load_config(str(path)) == cfg
    assert [f.name for f in tmp_path.iterdir()] == ["c.toml"]  # no temporary left
    first = cfg.signals()[1]
    with pytest.raises(ValueError, match=rf"unknown {name.upper()} signal '{first}x'"):
        cfg.fmt(first + "x")
    bad = cfg.to_toml().replace(f"\n{first} = ", f"\n{first}{first[-1]} = ", 1)
    with pytest.raises(ValueError, match=rf"did you mean '{first}'"):
        p.config_from_toml(bad)
    with pytest.raises(ValueError, match="is a directory"):
        cfg.save(tmp_path)
    other = PIPELINES[next(n for n in NAMES if n != name)].default_config()
    with pytest.raises(ValueError, match=f"{name.upper()} needs a {p.config_type.__name__}"):
        p.run(lab_crop(), other)
    with pytest.raises(ValueError, match="threads must be 1 or 2, not 3"):
        p.run(lab_crop(), threads=3)  # checked once, by run, for every pipeline


@pytest.mark.parametrize("name", NAMES)
def test_tap_table_matches_the_run(name):
    p, res = PIPELINES[name], run(name)
    cfg = res.config
    table = p.tap_table(cfg, "stereo")
    names = [t.name for t in table]
    assert len(names) == len(set(names))
    assert set(names) == set(res.taps) | {"e1.pix_in", "e2.pix_in"}
    for t in table:
        assert t.fmt == (VALID_FORMAT if t.signal == "valid" else cfg.fmt(t.signal)), t.name
        if t.name in res.taps:
            raw = res.taps[t.name]
            assert raw.shape == lab_crop().shape and raw.dtype == np.int64
            assert raw.min() >= t.fmt.raw_min and raw.max() <= t.fmt.raw_max, t.name


@pytest.mark.parametrize("name", NAMES)
def test_declared_cycles(name):
    """Every tap's cycles follow from the input beats and the declared latencies or
    schedule; the range tap leaves at the output cycle; outputs are one per clock."""
    p, res = PIPELINES[name], run(name)
    table = {t.name: t for t in p.tap_table(res.config, "stereo")}
    cyc = p.tap_cycles(table["range"], res.config, TIMING, res.in_cycles, res.in_cycles)
    assert np.array_equal(cyc, res.out_cycles)
    assert np.unique(res.out_cycles).size == res.out_cycles.size
    assert res.latency == int((res.out_cycles - res.in_cycles).max())
    for t in table.values():
        c = p.tap_cycles(t, res.config, TIMING, res.in_cycles, res.in_cycles)
        assert c.shape == res.in_cycles.shape
        assert (c >= res.in_cycles).all(), t.name  # nothing leaves before it entered
        assert (c <= res.out_cycles.max()).all(), t.name
    assert p.stage_latencies(res.config) == res.stage_latency


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("timing", [TimingConfig(hblank=3), TIMING], ids=["closed", "gaps"])
def test_result_summaries_agree_with_the_result_arrays(name, threads, timing):
    """The figures the bands compute while they fill their rows (the float range map, the
    cycle maps, the latency, the last cycle) are those of the whole arrays, on a frame
    whose 13 lines split unevenly between two threads' bands."""
    case = crop_case(scene_case("lab"), [240, 253, 100, 120])
    p = PIPELINES[name]
    res = p.run(case, timing=timing, taps=False, threads=threads)
    fmt = {t.name: t for t in p.tap_table(res.config, "stereo")}["range"].fmt
    assert np.array_equal(res.range, fmt.to_float(res.range_raw))
    assert res.total_cycles == int(res.out_cycles.max()) + 1
    assert res.latency == int((res.out_cycles - res.in_cycles).max())


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("threads", [1, 2])
def test_every_integer_image_layout_gives_the_same_run(name, threads):
    """The workers convert their own lines of the images (runtime.kernel_image): uint8,
    int16 in a strided view and int64 inputs give the same outputs, taps and counts, and a
    run after one on other images reads none of their lines from the reused buffers."""
    case = crop_case(scene_case("lab"), [240, 253, 100, 120])
    p = PIPELINES[name]
    want = p.run(case, threads=threads)
    m, n = case.image1.shape
    wide = np.zeros((m, 2 * n), dtype=np.int16)
    wide[:, ::2] = case.image2
    for im1, im2 in ((case.image1.astype(np.int64), case.image2.astype(np.int64)),
                     (np.asarray(case.image1, np.uint8), wide[:, ::2])):  # fmt: skip
        p.run(Case(255 - im1, 255 - im2, case.camera, case.motion), threads=threads)
        got = p.run(Case(im1, im2, case.camera, case.motion), threads=threads)
        assert np.array_equal(got.range_raw, want.range_raw)
        assert got.overflows == want.overflows and got.taps.keys() == want.taps.keys()
        assert all(np.array_equal(got.taps[k], want.taps[k]) for k in want.taps)


@pytest.mark.parametrize("frac", [-3, 0, 8, 1022])
def test_finish_band_fills_the_arrays_in_one_pass(frac):
    """runtime.finish_band against the NumPy expressions it replaces: the closed-form input
    cycles or given ones, output cycles from line starts or a latency."""
    rng = np.random.default_rng(frac + 10)
    lines, n = 5, 7
    raw = rng.integers(-(1 << 40), 1 << 40, (lines, n))
    in_starts = np.arange(lines, dtype=np.int64) * 11 + 3
    out_starts = in_starts * 2 + 50
    rf = np.empty((lines, n))
    tin, tout = np.empty((lines, n), np.int64), np.empty((lines, n), np.int64)
    worst, last = finish_band(raw, frac, rf, tin, tout, in_starts=in_starts,
                              out_starts=out_starts, out_step=3)  # fmt: skip
    assert np.array_equal(rf, raw * 2.0**-frac)
    assert np.array_equal(tin, in_starts[:, None] + np.arange(n))
    assert np.array_equal(tout, out_starts[:, None] + 3 * np.arange(n))
    assert (worst, last) == (int((tout - tin).max()), int(tout.max()))
    given = rng.integers(0, 1000, (lines, n))
    tin2 = given.copy()
    worst, last = finish_band(raw, frac, rf, tin2, tout, latency=17)
    assert np.array_equal(tin2, given) and np.array_equal(tout, given + 17)
    assert (worst, last) == (17, int(given.max()) + 17)
    with pytest.raises(ValueError, match="one entry per line"):
        finish_band(raw, frac, rf, tin, tout, in_starts=in_starts[:-1])
    with pytest.raises(ValueError, match="within"):
        finish_band(raw, 1023, rf, tin, tout)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("shape", [(12, 20), (512, 512)])
def test_cost_counts_the_models_buffers(name, shape):
    p = PIPELINES[name]
    cfg = p.default_config()
    cost = p.cost(cfg, shape, "stereo")
    if shape == (12, 20):
        res = run(name)
        assert cost.line_buffer_bits == res.line_buffer_bits + res.sweep_buffer_bits
        assert cost.frame_store_bits == res.frame_store_bits
    assert cost.register_bits > sum(f.word for f in cfg.formats.values()) // 2
    assert cost.dsp > 0 and cost.bram18 > 0
    weights = p.cost_weights(cfg, shape)
    assert set(weights) == set(cfg.signals()) and all(w >= 0 for w in weights.values())
    assert sum(weights.values()) > 0


@pytest.mark.parametrize("name", NAMES)
def test_golden_taps_are_close_to_the_fixed_point_taps(name):
    """Every tap within 1 % of its golden's largest value (median), on a 40 x 40 crop:
    taller than P3's 17-line box (on 12 lines the box counts the edge lines up to 9 times
    and its sums' rounding noise reaches 1.5 %)."""
    case = crop_case(scene_case("lab"), [240, 280, 100, 140])
    p = PIPELINES[name]
    res = p.run(case, timing=TIMING, taps=True)
    ref = p.golden(case, res.config, taps=True)
    assert ref.taps, "a pipeline offers golden taps"
    table = {t.name: t for t in p.tap_table(res.config)}
    for tap, g in ref.taps.items():
        if tap not in res.taps or tap == "range_q":
            continue
        fx = np.ldexp(res.taps[tap].astype(float), -table[tap].fmt.frac)
        finite = np.isfinite(g)
        err = np.abs(fx - g)[finite]
        scale = max(1.0, float(np.max(np.abs(g[finite]))))
        assert np.median(err) <= 1e-2 * scale, tap


@pytest.mark.parametrize("name", NAMES)
def test_two_thread_runs_from_several_callers_share_the_pool(name):
    """Every model's two-thread runs go to one process-wide pool (runtime.model_pool):
    four callers at once finish (no deadlock: a stuck pool fails here, not hangs) with
    the same range, taps and cycle stamps as a one-thread run, and the pool stays one."""
    from concurrent.futures import ThreadPoolExecutor, wait

    from rangefx.rtl_model.runtime import model_pool

    pipe = PIPELINES[name]
    rng = np.random.default_rng(4)
    im = rng.integers(0, 256, (24, 32))
    case = Case(im, np.roll(im, 1, axis=1), PinholeCamera(32, 24, 400.0),
                MotionIncrement.stereo(0.1))  # fmt: skip
    want = pipe.run(case, threads=1)
    with ThreadPoolExecutor(4) as callers:
        futures = [callers.submit(pipe.run, case, threads=2) for _ in range(4)]
        done, pending = wait(futures, timeout=120)
    assert not pending
    for fut in done:
        got = fut.result()
        assert np.array_equal(got.range_raw, want.range_raw)
        assert np.array_equal(got.out_cycles, want.out_cycles)
        assert got.taps.keys() == want.taps.keys()
        assert all(np.array_equal(got.taps[k], want.taps[k]) for k in want.taps)
    assert model_pool() is model_pool()


def test_run_two_runs_the_second_call_on_the_caller_and_waits_on_an_error():
    """``runtime.run_two``: results in order, the second call on the calling thread, the
    first on a pool worker; when the caller's call raises, the worker's has finished by the
    time the error arrives."""
    import threading
    import time

    from rangefx.rtl_model.runtime import run_two

    finished: list[str] = []

    def call(tag: str, delay: float, fail: bool) -> tuple[str, int]:
        time.sleep(delay)
        if fail:
            raise RuntimeError(tag)
        finished.append(tag)
        return tag, threading.get_ident()

    (a, ta), (b, tb) = run_two(call, ("a", 0.05, False), ("b", 0.0, False))
    assert (a, b) == ("a", "b") and tb == threading.get_ident() != ta
    with pytest.raises(RuntimeError, match=r"^b$"):
        run_two(call, ("slow", 0.3, False), ("b", 0.0, True))
    assert finished[-1] == "slow"


def test_saturated_register_is_reported():
    """A host register outside its format is held at the limit, silently: the result
    names it (helper finding: P2's KA at s28.31 scaled the motorcycle ranges by 1.58x)."""
    p2 = PIPELINES["p2"]
    cfg = p2.default_config()
    # KA = 1 / (f dx) = -1/60: s4.10 holds |KA| < 2^-7
    narrow = cfg.with_formats(p2_ka_reg=FixedFormat(True, 4, 10, Quant.RND, Overflow.SAT))
    rng = np.random.default_rng(0)
    im = rng.integers(0, 256, (4, 12))
    case = Case(
        im, np.roll(im, 1, axis=1), PinholeCamera(12, 4, 600.0), MotionIncrement.stereo(0.1)
    )
    assert p2.run(case, cfg).saturated_registers == ()
    res = p2.run(case, narrow)
    assert res.saturated_registers == ("KA",)
    requested, held = res.registers["KA"]
    assert abs(held) < abs(requested)


# -- vectors of every pipeline ---------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_vectors_of_every_pipeline(name, tmp_path, capsys):
    out = tmp_path / "vec"
    argv = ["vectors", "gen", "--pipeline", name, "--scene", "lab", *CROP, "--out", str(out)]
    assert main([*argv, "--hblank", "4", "--gap-prob", "0.2", "--formats", "mem,csv"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["pipeline"] == name
    cfg = PIPELINES[name].default_config()
    taps = {e["tap"] for e in manifest["files"] if e["kind"] not in ("stream", "rom")}
    assert taps == {t.name for t in PIPELINES[name].tap_table(cfg)}
    # everything a bench needs beyond the streams: the ROM and every register code
    assert cfg.divider == "reciprocal"
    rom = next(e for e in manifest["files"] if e["kind"] == "rom")
    lines = (out / rom["path"]).read_text().splitlines()
    words = [int(w, 16) for w in lines if w and not w.startswith("//")]
    assert words == reciprocal_lut(cfg.recip_lut_bits, cfg.recip_bits).tolist()
    assert manifest["registers"] and not manifest["saturated_registers"]
    for reg, r in manifest["registers"].items():
        fmt = cfg.fmt(r["signal"])
        assert str(fmt) == r["format"] and fmt.raw_min <= r["raw"] <= fmt.raw_max, reg
        assert r["raw"] * 2.0**-fmt.frac == r["value"], reg
    assert main(["vectors", "check", str(out)]) == 0
    capsys.readouterr()
    # a planted mismatch: the first differing sample is found with its cycle, row, col
    entry = next(e for e in manifest["files"] if e["tap"] == "range" and e["path"].endswith(".mem"))
    lines = (out / entry["path"]).read_text().splitlines()
    words = [i for i, line in enumerate(lines) if line and not line.startswith("//")]
    k = 37  # sample index
    word = lines[words[k]]
    lines[words[k]] = format((int(word, 16) ^ 1), f"0{len(word)}x")
    dump = tmp_path / "range.mem"
    dump.write_text("\n".join(lines) + "\n")
    report = diff_dump(out, dump)
    assert report.mismatches == 1
    csv_rows = (out / "range.csv").read_text().splitlines()
    header = csv_rows[0].split(",")
    row = dict(zip(header, csv_rows[1 + k].split(","), strict=True))
    n = manifest["shape"][1]
    assert (report.first["row"], report.first["col"]) == (k // n, k % n)
    assert report.first["cycle"] == int(row["cycle"])
    # a flipped byte in any file is caught
    victim = out / entry["path"]
    data = bytearray(victim.read_bytes())
    data[-2] ^= 0x01
    victim.write_bytes(bytes(data))
    assert not check_vectors(out, rerun=False).ok


@pytest.mark.parametrize("name", NAMES)
def test_vector_cycles_in_the_csv_are_the_models(name, tmp_path):
    p = PIPELINES[name]
    vs = build_vectors(p, lab_crop(), timing=TIMING, formats=("csv",))
    write_vectors(tmp_path, vs)
    res = vs.result
    table = {t.name: t for t in p.tap_table(res.config)}
    for tap in ("range", "e1.pix_in", *list(res.taps)[:3]):
        rows = (tmp_path / f"{tap}.csv").read_text().splitlines()[1:]
        cycles = np.array([int(r.split(",")[0]) for r in rows])
        want = p.tap_cycles(table[tap], res.config, TIMING, res.in_cycles, res.in_cycles)
        assert np.array_equal(cycles, want.ravel()), tap


# -- the command line --------------------------------------------------------------------
def _error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error: "), err
    return err[0]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--pipeline", "p2", "--variant", "paper"], "--variant does not apply to pipeline p2"),
        (["--pipeline", "p2", "--pole", "0.3"], "--pole does not apply to pipeline p2"),
        (["--pipeline", "p2", "--bias", "nan"], "--bias does not apply to pipeline p2"),
        (["--pipeline", "p2", "--threshold-g", "2"], "--threshold-g does not apply to pipeline p2"),
        (["--pipeline", "p3", "--threshold-g", "2"], "--threshold-g does not apply to pipeline p3"),
        (["--pipeline", "p1", "--bias", "nan"], "bias must be a finite non-negative number"),
        (["--pipeline", "p1", "--method", "g3_paper"], "--method applies to --pipeline golden"),
        (["--hblank", "3"], "--hblank applies to the fixed-point pipelines only"),
        (["--divider", "restoring"], "--divider applies to the fixed-point pipelines only"),
        (["--config", "x.toml"], "--config applies to the fixed-point pipelines only"),
        (["--method", "g6_multiscale", "--threshold-g", "2"], "does not apply to method g6"),
        (["--method", "g5_riccati", "--threshold-g", "2"], "does not apply to method g5"),
        (["--method", "g2_central", "--pole", "0.3"], "--pole does not apply to method g2"),
    ],
)
def test_an_option_a_pipeline_does_not_use_is_an_error(capsys, argv, message):
    assert message in _error(capsys, ["run", "--scene", "lab", *argv])


def test_other_commands_reject_unused_options_too(capsys, tmp_path):
    out = str(tmp_path / "v")
    assert "--variant does not apply to pipeline p2" in _error(
        capsys, ["vectors", "gen", "--pipeline", "p2", "--variant", "paper", "--out", out]
    )
    assert "P2 models stereo mode only; case 'runway' is motion" in _error(
        capsys, ["vectors", "gen", "--pipeline", "p2", "--scene", "runway", "--out", out]
    )
    assert "--pole does not apply to pipeline p2" in _error(
        capsys, ["config", "show", "--pipeline", "p2", "--pole", "0.4"]
    )
    assert not Path(out).exists()


def test_design_options_reach_the_p1_config(capsys):
    argv = [
        "run",
        "--scene",
        "lab",
        "--pipeline",
        "p1",
        "--pole",
        "0.375",
        "--bias",
        "8",
        "--filter-form",
        "direct",
    ]
    assert main([*argv, "--variant", "consistent", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["pole"], out["bias"], out["variant"]) == (0.375, 8.0, "consistent")
    assert out["registers"]["pole"][1] == 0.375


@pytest.mark.parametrize("name", NAMES)
def test_config_show_and_propose_for_every_pipeline(name, capsys, tmp_path):
    assert main(["config", "show", "--pipeline", name]) == 0
    text = capsys.readouterr().out
    assert PIPELINES[name].config_from_toml(text) == PIPELINES[name].default_config()
    path = tmp_path / "p.toml"
    argv = ["config", "propose", "--pipeline", name, "--scene", "lab", "--out", str(path)]
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["pipeline"] == name and out["overflows"] == 0
    assert set(out["signals"]) == set(PIPELINES[name].config_type.signals())
    assert PIPELINES[name].load_config(str(path)).name == "p"
    assert "is a directory" in _error(capsys, ["config", "show", "--pipeline", name,
                                               "--out", str(tmp_path)])  # fmt: skip


@pytest.mark.parametrize("name", NAMES)
def test_eval_runs_the_chosen_pipelines_on_the_real_pair(name, capsys):
    """``rangefx eval --pipeline NAME``: the fixed point beside its golden on the
    motorcycle pair, shipped default config: no overflow, no saturated register."""
    assert main(["eval", "--dataset", "motorcycle", "--pipeline", name, "--json"]) == 0
    fixed = json.loads(capsys.readouterr().out)["fixed_point"]
    assert {k.split("_")[0] for k in fixed} == {name}
    for f in fixed.values():
        assert f["overflows"] == 0 and f["saturated_registers"] == []
        assert f["median_rel_range_diff"] < 1e-3 and f["valid_agreement"] > 0.99
