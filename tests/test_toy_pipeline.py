"""A pipeline is one folder and one registry entry (SPEC §10, issue 37): a toy pipeline
defined in this file alone — a 3x3 box filter of E2 and two casts, with its config,
formats, taps, settings, cost and golden — registered with ``register_pipeline`` runs
through ``run``, vector generation, check and diff, a sweep and the optimiser, from
Python and from the command line (``main([...])`` in-process), without a line of it
anywhere else in the repository."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from rangefx.golden.ranging import RangeResult
from rangefx.rtl_model import Case, TimingConfig, WordLengthConfig
from rangefx.rtl_model.cost import CostReport
from rangefx.rtl_model.fixedpoint import cast_array
from rangefx.rtl_model.pipeline import (
    VALID_FORMAT,
    GoldenReference,
    Pipeline,
    PipelineResult,
    TapSpec,
    build_result,
)
from rangefx.rtl_model.registry import PIPELINES, register_pipeline, unregister_pipeline
from rangefx.rtl_model.runtime import RegisterFile
from rangefx.rtl_model.stream import input_cycles
from rangefx.tools.cli import main
from rangefx.tools.studies.cases import scene_case
from rangefx.vectors.generate import build_vectors, check_vectors, diff_dump, write_vectors

# -- the toy pipeline: everything it is, in this file ----------------------------------
TOY_DEFAULT = """\
[design]
coef = 0.1111111111111111

[signals]
toy_pix = { format = "u8.0", quant = "TRN", overflow = "SAT" }
toy_coef = { format = "u17.16", quant = "RND", overflow = "SAT" }
toy_box = { format = "u14.6", quant = "RND", overflow = "SAT" }
toy_out = { format = "u12.4", quant = "RND", overflow = "SAT" }
"""
#: Cycles of the box filter (two line buffers and a row of three) and of the output cast.
BOX_LATENCY, OUT_LATENCY = 2, 1


@dataclass(frozen=True, kw_only=True)
class ToyConfig(WordLengthConfig):
    """Formats of the toy datapath: pixel -> 3x3 sum times ``coef`` -> box -> out."""

    PIPELINE: ClassVar[str] = "toy"
    SIGNAL_TABLE: ClassVar[tuple[tuple[str, str], ...]] = (
        ("toy_pix", "input pixel of E2"),
        ("toy_coef", "the box filter's weight register (1/9)"),
        ("toy_box", "the 3x3 mean"),
        ("toy_out", "the output: the mean, as the pipeline's 'range'"),
    )
    HOST_REGISTERS: ClassVar[tuple[str, ...]] = ("toy_coef",)
    DOC: ClassVar[str] = "tests/test_toy_pipeline.py"

    coef: float = 1.0 / 9.0

    @classmethod
    def default(cls, **design: Any) -> ToyConfig:
        config = cls.from_toml(TOY_DEFAULT, name="default")
        return config.with_(**design) if design else config


@dataclass(frozen=True)
class ToySettings:
    """The toy's own settings in a case (not a field of :class:`Case`)."""

    range_max: float = 255.0


def box_sum(image: np.ndarray) -> np.ndarray:
    """The 3x3 sum of every pixel with zero padding (exact in int64 and in float64)."""
    padded = np.pad(np.asarray(image), 1)
    m, n = np.shape(image)
    return sum(padded[i : i + m, j : j + n] for i in range(3) for j in range(3))


def interior(shape: tuple[int, int]) -> np.ndarray:
    mask = np.zeros(shape, dtype=bool)
    mask[1:-1, 1:-1] = True
    return mask


class ToyPipeline(Pipeline):
    """3x3 box filter of E2 and an output cast; ``range`` is the filtered grey level."""

    name: ClassVar[str] = "toy"
    title: ClassVar[str] = "toy 3x3 box filter"
    config_type: ClassVar[type[WordLengthConfig]] = ToyConfig
    modes: ClassVar[tuple[str, ...]] = ("stereo",)
    variants: ClassVar[dict[str, dict[str, Any]]] = {"": {}}
    golden_fields: ClassVar[tuple[str, ...] | None] = ()
    settings_key: ClassVar[str] = "toy"
    settings_type: ClassVar[type] = ToySettings
    case_options: ClassVar[tuple[str, ...]] = ("range_max",)
    buildup_axes: ClassVar[dict[str, str]] = {"rows": "row index"}
    #: ``/usr/bin/time -f %M`` of ``rangefx run --pipeline toy`` on a pair at 512x512 and
    #: 2048x2048: 69 B a pixel, with 15 % headroom.
    run_bytes_per_pixel: ClassVar[int | None] = 80

    def stage_latencies(self, config: WordLengthConfig) -> dict[str, int]:
        return {"box": BOX_LATENCY, "out": OUT_LATENCY}

    def tap_table(self, config: WordLengthConfig, mode: str = "stereo") -> tuple[TapSpec, ...]:
        f = self.check_config(config).formats
        pix = [TapSpec(f"{s}.pix_in", "toy_pix", f["toy_pix"], None, 0, s) for s in ("e1", "e2")]
        total = BOX_LATENCY + OUT_LATENCY
        return (
            *pix,
            TapSpec("box", "toy_box", f["toy_box"], "box", BOX_LATENCY),
            TapSpec("valid", "valid", VALID_FORMAT, "out", total),
            TapSpec("range", "toy_out", f["toy_out"], "out", total),
        )

    def simulate(self, case: Case, config: WordLengthConfig, timing: TimingConfig, taps: bool,
                 threads: int, log: bool = True) -> PipelineResult:  # fmt: skip
        f = config.formats
        img = np.asarray(case.image2, dtype=np.int64)
        pix, ov_pix = cast_array(img, 0, f["toy_pix"])
        coef, ov_coef = cast_array(np.array([round(config.coef * 2**20)]), 20, f["toy_coef"])
        box, ov_box = cast_array(box_sum(pix) * coef[0], f["toy_coef"].frac, f["toy_box"])
        out, ov_out = cast_array(box, f["toy_box"].frac, f["toy_out"])
        value = np.ldexp(out.astype(np.float64), -f["toy_out"].frac)
        range_max = self.range_max(case)
        valid = interior(img.shape) & (value > 0) & (value <= range_max)
        cycles = input_cycles(img.shape, timing)[0]
        latency = BOX_LATENCY + OUT_LATENCY
        signals = {"toy_pix": pix, "toy_box": box, "toy_out": out}
        regs = RegisterFile(config)
        regs.hold("coef", int(coef[0]), "toy_coef", config.coef)
        overflows = {"toy_pix": ov_pix, "toy_coef": ov_coef, "toy_box": ov_box, "toy_out": ov_out}
        minmax = {
            s: tuple(float(np.ldexp(float(v), -f[s].frac)) for v in (a.min(), a.max()))
            for s, a in signals.items()
        }
        tap_arrays = {"e2.pix_in": pix, "box": box, "valid": valid.astype(np.int64), "range": out}
        return build_result(
            self.name, config, timing, case.mode, range_raw=out,
            range_float=np.where(valid, value, range_max), valid=valid,
            taps=tap_arrays if taps else {}, stats=(overflows, minmax), log=log,
            cycles=(cycles, cycles + latency), stage_latency=self.stage_latencies(config),
            registers=regs, buffers={"line_buffer_bits": 2 * img.shape[1] * f["toy_pix"].word},
            latency=latency,
        )  # fmt: skip

    def reference(self, case: Case, config: WordLengthConfig, taps: bool) -> GoldenReference:
        mean = box_sum(np.asarray(case.image2, dtype=np.float64)) / 9.0
        range_max = self.range_max(case)
        valid = interior(mean.shape) & (mean > 0) & (mean <= range_max)
        result = RangeResult(range=np.where(valid, mean, range_max), valid=valid)
        return GoldenReference(result, {"box": mean, "range": mean} if taps else {})

    def golden_label(self, config: WordLengthConfig) -> str:
        return "box_mean"

    def cost(
        self, config: WordLengthConfig, shape: tuple[int, int], mode: str = "stereo"
    ) -> CostReport:
        f = self.check_config(config).formats
        line = 2 * shape[1] * f["toy_pix"].word
        return CostReport(config.register_bits(), line, 0, bram18=0, dsp=1)

    def buildup_profiles(
        self, result: PipelineResult, golden: GoldenReference
    ) -> dict[str, dict[str, np.ndarray]]:
        spec = {t.name: t for t in self.tap_table(result.config)}["box"]
        err = spec.values(result) - golden.taps["box"]
        rms = np.sqrt(np.mean(err**2, axis=1))
        return {"rows": {"index": np.arange(rms.size), "box": rms,
                         "box.lsb_rms": np.full(rms.size, spec.lsb_rms)}}  # fmt: skip


# -- the tests --------------------------------------------------------------------------
CROP = ["--crop", "240", "252", "100", "120"]  # 12 x 20 pixels of the lab pair
SWEEP = """\
[sweep]
name = "toy"
pipeline = "toy"
scenes = ["lab"]
size = [24, 32]
pareto_metric = "median_rel_range_diff"

[[axis]]
signals = ["toy_box"]
param = "frac"
values = [2, 6]
"""


@pytest.fixture
def toy():
    pipe = register_pipeline(ToyPipeline())
    yield pipe
    unregister_pipeline("toy")


def test_the_toy_needs_no_other_file():
    """The toy is defined here only: no file of the package names it."""
    root = Path(__file__).resolve().parent.parent
    hits = [
        p
        for d in ("rtl_model", "vectors", "tools", "golden", "guidance")
        for p in (root / d).rglob("*.py")
        if "ToyPipeline" in p.read_text() or '"toy"' in p.read_text()
    ]
    assert hits == []


def test_register_pipeline_refuses_a_builtin_a_duplicate_and_a_bad_name(toy):
    assert PIPELINES["toy"] is toy
    with pytest.raises(ValueError, match="already registered"):
        register_pipeline(ToyPipeline())
    with pytest.raises(ValueError, match="already registered"):
        register_pipeline(type("P1Again", (ToyPipeline,), {"name": "p1"})())
    with pytest.raises(ValueError, match="lower-case identifier"):
        register_pipeline(type("Bad", (ToyPipeline,), {"name": "Bad name"})())
    with pytest.raises(ValueError, match="not added by register_pipeline"):
        unregister_pipeline("p1")


def test_the_toy_runs_from_python_with_its_own_settings(toy):
    case = scene_case("lab", (24, 32))
    assert "toy" not in case.settings  # absent: the settings' defaults
    result = toy.run(case, taps=True)
    gold = toy.golden(case, taps=True)
    assert result.valid.sum() == 22 * 30 and np.array_equal(result.valid, gold.result.valid)
    assert np.abs(result.range - gold.result.range).max() <= 2.0**-4  # u12.4 output
    # a case option sets the toy's own settings, not P1's
    narrow = toy.with_case_options(case, range_max=50.0)
    assert narrow.settings["toy"].range_max == 50.0
    assert narrow.settings["ranging"] == case.settings["ranging"]
    assert toy.run(narrow).valid.sum() < result.valid.sum()
    with pytest.raises(ValueError, match="does not read case option 'threshold_g'"):
        toy.with_case_options(case, threshold_g=1.0)


def test_the_toy_vectors_check_and_diff_from_python(toy, tmp_path):
    case = scene_case("lab", (24, 32))
    case = toy.with_case_options(case, range_max=200.0)
    out = tmp_path / "vec"
    out.mkdir()
    write_vectors(out, build_vectors(toy, case, description={"scene": "lab"}))
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["pipeline"] == "toy" and manifest["case"]["toy"] == {"range_max": 200.0}
    assert check_vectors(out).ok
    assert diff_dump(out, out / "range.mem").ok
    dump = tmp_path / "bad.mem"
    lines = (out / "range.mem").read_text().splitlines()
    k = next(i for i, line in enumerate(lines) if not line.startswith("//"))
    lines[k] = format(int(lines[k], 16) ^ 1, f"0{len(lines[k])}x")
    dump.write_text("\n".join(lines) + "\n")
    assert not diff_dump(out, dump, tap="range").ok


def test_the_toy_from_the_command_line(toy, tmp_path, capsys):
    rng = np.random.default_rng(0)
    left = rng.integers(0, 256, (24, 32)).astype(np.float64)
    np.save(tmp_path / "l.npy", left)
    np.save(tmp_path / "r.npy", np.roll(left, 1, axis=1))
    pair = ["--left", str(tmp_path / "l.npy"), "--right", str(tmp_path / "r.npy")]
    pair += ["--f-px", "40", "--baseline", "0.1"]
    run = ["run", "--pipeline", "toy", *pair]
    assert main([*run, "--out", str(tmp_path / "run"), "--json"]) == 0
    assert (tmp_path / "run" / "range.npy").is_file()
    assert main([*run, "--range-max", "90"]) == 0
    assert main([*run, "--threshold-g", "2"]) == 2
    assert "--threshold-g does not apply to pipeline toy" in capsys.readouterr().err
    vec = tmp_path / "vec"
    gen = ["vectors", "gen", "--pipeline", "toy", "--scene", "lab", *CROP, "--out", str(vec)]
    assert main(gen) == 0
    assert main(["vectors", "check", str(vec)]) == 0
    assert main(["vectors", "diff", str(vec), str(vec / "box.mem"), "--signal", "box"]) == 0


def test_the_toy_sweeps_and_optimises(toy, tmp_path, capsys):
    definition = tmp_path / "toy.toml"
    definition.write_text(SWEEP)
    out = tmp_path / "sweep"
    assert main(["sweep", str(definition), "--out", str(out), "--json"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] and summary["n_ok"] == 2
    assert summary["buildup"] == ["buildup_base_rows.csv", "buildup_base.png"]  # its profile
    opt = tmp_path / "opt"
    argv = ["optimise", "--pipeline", "toy", "--scene", "lab", "--size", "24", "32"]
    assert main([*argv, "--signals", "toy_box", "toy_out", "--out", str(opt)]) == 0
    report = json.loads((opt / "summary.json").read_text())
    assert report["pipeline"] == "toy" and report["bits_saved"] > 0
    optimised = ToyConfig.load(opt / "optimised.toml")
    assert optimised.register_bits() < toy.default_config().register_bits()


def test_the_memory_guard_reads_the_toys_own_bytes_a_pixel(toy):
    """A run's memory estimate takes the pipeline's own figure; a pipeline that declares
    none is estimated at the largest of the registry's."""
    from rangefx.tools.studies.runner import RUN_BASE_BYTES, run_bytes_per_pixel, run_memory_bytes

    assert run_bytes_per_pixel("toy") == 80
    assert run_memory_bytes(1000, "toy", runs=2) == RUN_BASE_BYTES + 2 * 1000 * 80
    largest = max(p.run_bytes_per_pixel or 0 for p in PIPELINES.values())
    assert largest > 80 and run_bytes_per_pixel() == largest
    unmeasured = type(
        "Unmeasured", (ToyPipeline,), {"name": "unmeasured", "run_bytes_per_pixel": None}
    )
    register_pipeline(unmeasured())
    try:
        assert run_bytes_per_pixel("unmeasured") == largest
    finally:
        unregister_pipeline("unmeasured")


def test_the_real_pair_protocol_takes_its_pipelines_from_the_registry(toy):
    """Which pipelines range the Middlebury pair is a fact of each pipeline (its
    ``search_range_field``): P3's, and a registered pipeline's that declares one."""
    from rangefx.tools.studies.evaluation import middlebury_pipelines

    assert middlebury_pipelines() == ("p3",)
    dense = type("DenseToy", (ToyPipeline,), {"name": "densetoy", "search_range_field": "coef"})
    register_pipeline(dense())
    try:
        assert middlebury_pipelines() == ("p3", "densetoy")
    finally:
        unregister_pipeline("densetoy")
