"""rangefx's Python API: the three jobs of SPEC §1 as documented calls (SPEC §15).

Every ``rangefx`` command is one of these calls with its arguments parsed and its result
printed; a script gets the same results, the same files and the same one-line
:class:`~rangefx.tools.errors.UserError` for a mistake.

Build a case
    :func:`scene_case` (a synthetic scene preset, optionally cropped),
    :func:`real_pair_case` (the Middlebury motorcycle pair),
    :func:`image_case` (a user's image pair: arrays or files, with a camera).
Run
    :func:`run`: a bit-accurate pipeline beside its golden, or one golden method.
Test vectors
    :func:`generate_vectors` (from a case, a scene name or an existing :class:`RunResult`;
    atomic), :func:`check_vectors`, :func:`diff_vectors` (an RTL dump against a tap),
    :func:`replay` (the vectors through the Verilog of P1 in a simulator).
Word-length studies
    :func:`sweep` (resumable), :func:`optimise` (with held-out verification).
Beyond
    :func:`evaluate` (the golden methods and pipelines on the real pair with ground
    truth), :func:`guide` (chapter-6 guidance on obstacles a pipeline ranged).

Each returns a typed result with ``to_dict()`` (the figures the command's ``--json``
prints) and ``write(dir)`` (the files the command's ``--out`` writes; atomically: a
directory rangefx did not write is never replaced, a user's file never overwritten).

Example::

    from rangefx import api

    case = api.scene_case("lab", crop=(248, 256, 240, 256))
    result = api.run(case, pipeline="p1")
    print(result.to_dict()["median_rel_range_diff"])
    api.generate_vectors(result, "vec")          # the same run's taps, not re-run
    assert api.check_vectors("vec").ok
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rangefx.golden.estimator import EstimatorConfig
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.ranging import RangeResult
from rangefx.rtl_model.config import TimingConfig, WordLengthConfig
from rangefx.rtl_model.pipeline import Case, Pipeline, PipelineResult
from rangefx.rtl_model.registry import PIPELINES, get_pipeline
from rangefx.tools import report
from rangefx.tools.errors import UserError, require_memory
from rangefx.tools.report import atomic_output_dir, atomic_write_text, json_safe
from rangefx.tools.studies import cases as _cases
from rangefx.tools.studies.banded import plan_bands, run_in_bands
from rangefx.tools.studies.evaluation import EvalResult
from rangefx.tools.studies.flights import GuideResult
from rangefx.tools.studies.runner import (
    check_input_levels,
    golden_case,
    load_config,
    pipeline_figures,
    run_case,
)
from rangefx.tools.studies.sweep import SweepDef, SweepOutcome
from rangefx.tools.studies.tuning import DEFAULT_MARGIN, OptimiseReport
from rangefx.vectors.generate import (
    FORMATS,
    CheckReport,
    DiffReport,
    VectorSet,
    build_vectors,
    stream_memory_bytes,
    write_report,
    write_vectors,
)
from rangefx.vectors.generate import check_vectors as _check_files
from rangefx.vectors.replay import ReplayReport

__all__ = [
    "DEFAULT_METHOD",
    "PIPELINES",
    "Case",
    "CheckReport",
    "DiffReport",
    "EvalResult",
    "GuideResult",
    "OptimiseReport",
    "ReplayResult",
    "RunResult",
    "SweepResult",
    "UserError",
    "VectorsResult",
    "check_vectors",
    "diff_vectors",
    "evaluate",
    "generate_vectors",
    "guide",
    "image_case",
    "optimise",
    "real_pair_case",
    "replay",
    "run",
    "scene_case",
    "sweep",
]

#: The golden method :func:`run` runs with ``pipeline="golden"`` and no ``method``.
DEFAULT_METHOD = "g3_consistent"


def _json_text(data: Any) -> str:
    return json.dumps(json_safe(data), indent=2) + "\n"


def _pipeline(pipeline: Pipeline | str) -> Pipeline:
    if isinstance(pipeline, Pipeline):
        return pipeline
    try:
        return get_pipeline(pipeline)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def _config(
    pipe: Pipeline, config: WordLengthConfig | str | Path | None, design: Mapping[str, Any]
) -> WordLengthConfig:
    """``config`` itself (with ``design`` applied), a TOML file's, or the shipped default."""
    if isinstance(config, WordLengthConfig):
        design = {k: v for k, v in design.items() if v is not None}
        try:
            return config.with_(**design) if design else config
        except ValueError as exc:
            raise UserError(str(exc)) from None
    return load_config(pipe, str(config) if config is not None else None, **design)


# -- cases -----------------------------------------------------------------------------------
def scene_case(
    name: str = "lab",
    *,
    seed: int = 0,
    size: Sequence[int] | None = None,
    crop: Sequence[int] | None = None,
) -> Case:
    """The case of a synthetic scene preset (``lab``: stereo, ``runway``: motion, ...).

    Parameters
    ----------
    name
        A preset of :data:`rangefx.golden.scenes.SCENE_NAMES`.
    seed
        The scene's noise seed.
    size
        ``(height, width)`` to render at (default the preset's, 512x512).
    crop
        ``(r0, r1, c0, c1)``: rows ``r0:r1`` and columns ``c0:c1`` of the rendered scene
        (the camera's principal point moves with the crop, so every pixel keeps its
        coordinates: :func:`rangefx.tools.studies.cases.crop_case`).

    Returns
    -------
    Case
        Images, camera, motion, mode (the scene's kind), the scene's measured settings
        and the scene with its truth (``case.scene``).
    """
    case = _cases.scene_case(name, size, seed)
    return _cases.crop_case(case, list(crop) if crop is not None else None)


def real_pair_case(name: str = "motorcycle", factor: int | None = None) -> Case:
    """The stereo case of a real pair: the Middlebury 2014 motorcycle pair shipped by
    scikit-image, down-sampled by ``factor`` (default 26x39 px, median disparity 2 px),
    integer grey levels, lengths in metres (:func:`rangefx.tools.studies.cases.real_pair_case`)."""
    return _cases.real_pair_case(name, factor)


def image_case(
    left: np.ndarray | str | Path,
    right: np.ndarray | str | Path,
    *,
    f_px: float | None = None,
    baseline: float | None = None,
    camera: PinholeCamera | None = None,
    motion: MotionIncrement | None = None,
    threshold_e: float | None = None,
    threshold_g: float | None = None,
    range_max: float | None = None,
) -> Case:
    """A stereo case from your own image pair.

    Parameters
    ----------
    left, right
        E1 (left camera) and E2 (right camera): 2-D arrays of grey levels, or paths of
        ``.npy`` or image files.
    f_px, baseline
        Focal length in pixels (principal point at the centre) and stereo baseline (the
        range's unit), unless ``camera`` and ``motion`` are given.
    camera, motion
        A :class:`~rangefx.golden.geometry.PinholeCamera` and a
        :class:`~rangefx.golden.geometry.MotionIncrement` instead.
    threshold_e, threshold_g, range_max
        The pipelines' thresholds (grey levels) and largest range, where not the defaults.

    Returns
    -------
    Case
        The fixed-point pipelines need integer grey levels: :func:`run` refuses an image
        with fractions, naming it.
    """
    case = _cases.image_case(
        left, right, f_px=f_px, baseline=baseline, camera=camera, motion=motion
    )
    return _cases.with_thresholds(
        case, threshold_e=threshold_e, threshold_g=threshold_g, range_max=range_max
    )


# -- run ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RunResult:
    """One run: a bit-accurate pipeline beside its golden, or a golden method alone.

    Attributes
    ----------
    pipeline
        The pipeline's name, or ``"golden"`` for a golden method.
    case
        The case run (with integer images for a pipeline).
    result
        The pipeline's :class:`~rangefx.rtl_model.pipeline.PipelineResult` (range, valid,
        taps, overflows, cycles, buffers), or the method's
        :class:`~rangefx.golden.ranging.RangeResult`.
    golden
        The pipeline's golden :class:`~rangefx.golden.ranging.RangeResult` (None for a
        golden method).
    figures
        What ``rangefx run --json`` prints: accuracy against the golden, overflows,
        latency, buffers, and on a scene the per-object tables.
    method
        The golden method's name (None for a pipeline).
    """

    pipeline: str
    case: Case
    result: PipelineResult | RangeResult
    golden: RangeResult | None
    figures: dict[str, Any]
    method: str | None = None

    @property
    def config(self) -> WordLengthConfig | None:
        """The pipeline's word-length config (None for a golden method)."""
        return getattr(self.result, "config", None)

    def to_dict(self) -> dict[str, Any]:
        """The figures as JSON-able values (``rangefx run --json``)."""
        return json_safe(self.figures)

    def write(self, out: str | Path) -> Path:
        """Write ``range.npy``, ``valid.npy``, ``range.png``, ``summary.json`` (and for a
        pipeline ``taps.npz`` and ``config.toml``) into directory ``out``, atomically:
        what ``rangefx run --out`` writes."""
        res = self.result
        if self.method is not None:
            range_max, title = self.case.ranging.range_max, self.method
        else:
            pipe = get_pipeline(self.pipeline)
            range_max, title = pipe.range_max(self.case), f"{self.pipeline.upper()} range"
        with atomic_output_dir(Path(out)) as tmp:
            np.save(tmp / "range.npy", res.range)
            np.save(tmp / "valid.npy", res.valid)
            if self.method is None:
                np.savez_compressed(tmp / "taps.npz", **res.taps)
            report.save_range_map_png(tmp / "range.png", res.range, res.valid, range_max, title)
            if self.method is None:
                atomic_write_text(tmp / "config.toml", res.config.to_toml())
            atomic_write_text(tmp / "summary.json", _json_text(self.figures))
        return Path(out)


def run(
    case: Case,
    config: WordLengthConfig | str | Path | None = None,
    *,
    pipeline: Pipeline | str = "p1",
    timing: TimingConfig | None = None,
    taps: bool = True,
    method: str | None = None,
    estimator: EstimatorConfig | None = None,
    allow_saturated_input: bool = False,
    input_names: tuple[str, str] = ("image1", "image2"),
    band_lines: int | None = None,
    **design: Any,
) -> RunResult:
    """Run a bit-accurate pipeline on ``case`` beside its golden, or a golden method.

    Parameters
    ----------
    case
        From :func:`scene_case`, :func:`real_pair_case` or :func:`image_case`.
    config
        A word-length config, the path of its TOML file, or None (the pipeline's shipped
        default); ``design`` fields (``variant="consistent"``, ``divider=...``) override
        its design where the pipeline has them.
    pipeline
        A pipeline of :data:`PIPELINES` (``"p1"``, ``"p2"``, ``"p3"``) or one of its
        objects; ``"golden"`` runs the float64 ``method`` instead.
    timing
        The input stream's blanking (default none).
    taps
        Record every tap (needed by :func:`generate_vectors` of this result).
    method, estimator
        ``pipeline="golden"``: the golden method (default :data:`DEFAULT_METHOD`) and its
        causal estimator's pole and bias.
    allow_saturated_input
        Accept grey levels outside the input format (saturated, with a warning on stderr).
    input_names
        Names of the two images in error messages.
    band_lines
        A pipeline whose lines are independent (P2): run the frame in bands of this many
        lines (:func:`rangefx.tools.studies.banded.run_in_bands`, the same result bit for
        bit). Default: the whole frame if it fits in the memory available, else bands
        that do; any other pipeline above the bound is refused.

    Returns
    -------
    RunResult

    Raises
    ------
    UserError
        An unknown pipeline or method, a bad config, a case the pipeline does not model,
        grey levels the input format cannot hold.
    """
    if pipeline == "golden":
        if design or config is not None or timing is not None:
            raise UserError("a config, design options and timing apply to the fixed-point "
                            f"pipelines only ({'|'.join(PIPELINES)})")  # fmt: skip
        return _run_method(case, method or DEFAULT_METHOD, estimator or EstimatorConfig())
    if method is not None:
        raise UserError("a golden method applies to pipeline='golden' only")
    pipe = _pipeline(pipeline)
    if case.scene is None:
        case = _cases.integer_case(case, input_names)
    cfg = _config(pipe, config, design)
    signal = cfg.signals()[0]
    check_input_levels(
        dict(zip(input_names, (case.image1, case.image2), strict=True)), cfg.fmt(signal),
        signal, allow=allow_saturated_input,
    )  # fmt: skip
    lines = plan_bands(pipe, case.image1.shape, band_lines)
    if lines is None:
        result = run_case(pipe, case, cfg, timing or TimingConfig(), taps=taps)
        golden = golden_case(pipe, case, cfg).result
    else:
        try:
            result, golden = run_in_bands(
                pipe, case, cfg, timing or TimingConfig(), lines, taps=taps
            )
        except ValueError as exc:
            raise UserError(str(exc)) from None
    return RunResult(pipe.name, case, result, golden, pipeline_figures(result, golden, case.scene))


def _run_method(case: Case, method: str, estimator: EstimatorConfig) -> RunResult:
    from rangefx.golden.methods import run_method

    try:
        result = run_method(
            method, case.image1, case.image2, case.camera, case.motion,
            estimator=estimator, ranging=case.ranging,
        )  # fmt: skip
    except ValueError as exc:
        raise UserError(str(exc)) from None
    scene = case.scene
    figures: dict[str, Any] = {"method": method, "valid_fraction": result.valid_fraction}
    if scene is not None:
        rows = report.object_table(
            result.range, result.valid, scene.labels1, scene.objects, scene.depth1
        )
        overall = report.overall_metrics(result.range, result.valid, scene.depth1)
        figures.update(scene=scene.name, unit=scene.unit, table=rows, **overall)
    return RunResult("golden", case, result, None, figures, method=method)


# -- test vectors ----------------------------------------------------------------------------
@dataclass(frozen=True)
class VectorsResult:
    """A vector directory written by :func:`generate_vectors`.

    ``out`` is the directory, ``vectors`` the files in memory with the manifest and the
    model run they came from, ``figures`` what ``rangefx vectors gen --json`` prints (file
    count, bytes, seconds)."""

    out: Path
    vectors: VectorSet = field(repr=False)
    figures: dict[str, Any]

    @property
    def manifest(self) -> dict:
        """The parsed ``manifest.json``."""
        return self.vectors.manifest

    def to_dict(self) -> dict[str, Any]:
        """The figures as JSON-able values."""
        return json_safe(self.figures)

    def write(self, out: str | Path) -> Path:
        """Write the same vector directory again, to ``out`` (atomically)."""
        with atomic_output_dir(Path(out)) as tmp:
            write_vectors(tmp, self.vectors)
        return Path(out)


def generate_vectors(
    source: Case | RunResult | str,
    out: str | Path,
    *,
    pipeline: Pipeline | str = "p1",
    config: WordLengthConfig | str | Path | None = None,
    timing: TimingConfig | None = None,
    formats: Sequence[str] = ("mem",),
    seed: int = 0,
    crop: Sequence[int] | None = None,
    description: Mapping[str, Any] | None = None,
    **design: Any,
) -> VectorsResult:
    """Write the hardware test vectors of one case into directory ``out``, atomically.

    Parameters
    ----------
    source
        A scene preset's name (rendered with ``seed`` and cropped to ``crop``: the
        manifest records them, so :func:`check_vectors` can reproduce the inputs, as
        ``rangefx vectors gen`` does), a :class:`Case`, or a :class:`RunResult` of a
        pipeline run with ``taps=True`` (its taps are written; the model is not run again,
        and its pipeline, config and timing are used).
    out
        The vector directory: created, or an earlier rangefx output replaced; a directory
        rangefx did not write is refused and nothing is left half-written.
    pipeline, config, timing, design
        As :func:`run` (for a case or a scene name).
    formats
        Per-tap file formats among :data:`rangefx.vectors.generate.FORMATS` (``mem`` always).
    description
        Recorded as the manifest's ``case`` (a scene's is filled in for you).

    Returns
    -------
    VectorsResult
    """
    bad = [f for f in formats if f not in FORMATS]
    if bad:
        raise UserError(f"--formats: unknown {', '.join(bad)}; choose from {', '.join(FORMATS)}")
    out = Path(out)
    t0 = time.perf_counter()
    result = None
    if isinstance(source, RunResult):
        if source.method is not None:
            raise UserError("a golden method's run has no taps; give a pipeline's RunResult")
        pipe, case, result = get_pipeline(source.pipeline), source.case, source.result
        cfg, timing = result.config, result.timing
        if not result.taps:
            raise UserError("the run recorded no taps: run it with taps=True")
    else:
        pipe = _pipeline(pipeline)
        cfg = _config(pipe, config, design)
        timing = timing or TimingConfig()
        if isinstance(source, str):
            full = _cases.scene_case(source, seed=seed)
            if full.mode not in pipe.modes:
                raise UserError(
                    f"{pipe.name} models {' and '.join(pipe.modes)} mode only; scene "
                    f"{source!r} is {full.mode}"
                )
            case = _cases.crop_case(full, list(crop) if crop is not None else None)
            description = {
                "source": "scene", "scene": source, "seed": seed,
                "scene_shape": list(full.image1.shape),
                "crop": list(crop) if crop is not None else None,
                **dict(description or {}),
            }  # fmt: skip
        else:
            case = _cases.crop_case(source, list(crop) if crop is not None else None)
            if case.scene is None:  # a user's pair: the sensor's integer codes, as run()
                case = _cases.integer_case(case)
        m, n = case.shape
        require_memory(
            f"--hblank {timing.hblank} --vblank {timing.vblank} on {m}x{n} pixels (the input "
            "streams hold every cycle)",
            stream_memory_bytes((m, n), timing, case.mode),
        )
    if description is None:
        description = {"source": "python", "label": case.name}
    t1 = time.perf_counter()
    with atomic_output_dir(out) as tmp:
        try:
            vs = build_vectors(
                pipe, case, cfg, timing, description=description, formats=formats,
                result=result,
            )  # fmt: skip
        except ValueError as exc:
            raise UserError(str(exc)) from None
        t2 = time.perf_counter()
        write_vectors(tmp, vs)
    t3 = time.perf_counter()
    figures = {
        "out": str(out),
        "pipeline": pipe.name,
        "shape": list(vs.manifest["shape"]),
        "mode": vs.manifest["mode"],
        "files": len(vs.files) + 1,
        "total_bytes": vs.manifest["total_bytes"],
        "render_s": t1 - t0,
        "build_s": t2 - t1,
        "write_s": t3 - t2,
        "vectors_s": t3 - t1,
    }
    return VectorsResult(out, vs, figures)


def check_vectors(
    directory: str | Path, *, rerun: bool = True, provenance: bool | None = None
) -> CheckReport:
    """Check a vector directory: sizes and SHA-256 of every file, then (``rerun``) the
    model re-run from the manifest must give byte-identical files, then (``provenance``)
    the manifest's scene, seed and crop must reproduce the inputs.

    ``provenance=None`` checks it where the manifest names a scene preset (vectors of your
    own arrays have none); ``True`` requires it, as ``rangefx vectors check`` does.
    The directory is good when ``report.ok``; ``report.problems`` says what is not.
    """
    from rangefx.tools.studies.provenance import provenance_problems, require_rerun_memory

    if rerun:
        require_rerun_memory(directory)
    try:
        result = _check_files(directory, rerun=rerun)
        if result.ok and result.rerun and provenance is not False:
            source = _manifest_source(directory)
            if provenance or source == "scene":
                result.problems += provenance_problems(directory)
                result.provenance = not result.problems
    except ValueError as exc:
        raise UserError(str(exc)) from None
    return result


def _manifest_source(directory: str | Path) -> str | None:
    """The ``source`` the manifest of ``directory`` records for its case."""
    from rangefx.vectors.generate import load_manifest

    return load_manifest(directory).get("case", {}).get("source")


def diff_vectors(directory: str | Path, dump: str | Path, tap: str | None = None) -> DiffReport:
    """Compare an RTL dump (``.mem`` of ``$readmemh`` words or ``.csv`` with a value
    column) with the expected tap of a vector directory: the first mismatch (cycle, row,
    column, expected, got, format) and the count. ``tap`` defaults to the dump's file
    name (``e1.row_r1.mem`` -> ``e1.row_r1``)."""
    from rangefx.vectors.generate import DUMP_BYTES_PER_FILE_BYTE, diff_dump, dump_memory_bytes

    # a sparse or huge dump is refused before it is read (a MemoryError otherwise)
    need = dump_memory_bytes(dump)
    require_memory(f"reading dump {dump} ({need / DUMP_BYTES_PER_FILE_BYTE / 2**30:.2f} GiB)", need)
    try:
        return diff_dump(directory, dump, tap)
    except ValueError as exc:
        raise UserError(str(exc)) from None


@dataclass(frozen=True)
class ReplayResult:
    """The vectors of a P1 directory replayed through ``hdl/p1_top.v``.

    ``report`` is the comparison (:class:`rangefx.vectors.replay.ReplayReport`: every
    front-end tap value for value and cycle for cycle, the AXI4-Stream output, the
    overflow counters); ``figures`` what ``rangefx hdl replay --json`` prints (with the
    simulator's time and cycles)."""

    directory: Path
    simulator: str
    report: ReplayReport
    figures: dict[str, Any]

    @property
    def ok(self) -> bool:
        return bool(self.report.ok)

    def to_dict(self) -> dict[str, Any]:
        return json_safe(self.figures)

    def write(self, out: str | Path) -> Path:
        """Write ``replay.json`` (:meth:`to_dict`) into directory ``out``."""
        return write_report(out, "replay.json", self.to_dict())


def replay(
    directory: str | Path,
    simulator: str = "icarus",
    *,
    bench: str = "auto",
    dump: str | Path | None = None,
    time_model: bool = False,
) -> ReplayResult:
    """Replay a P1 or P2 vector directory through its Verilog under ``simulator``
    (``icarus`` or ``verilator``) and compare every tap with the model.

    ``bench``: ``cocotb``, ``plain`` (the Verilog bench) or ``auto`` (cocotb under Icarus,
    plain under Verilator). ``dump``: keep the RTL's dumps (``<tap>.mem``, ``taps.npz``,
    ``status.json``) in this directory (atomically). ``time_model``: also time the model
    on the same case."""
    import shutil
    import tempfile

    from rangefx.vectors.generate import case_from_manifest, load_manifest
    from rangefx.vectors.replay import SimulatorMissing, compare, simulate

    vec = Path(directory)
    try:
        manifest = load_manifest(vec)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if manifest.get("pipeline") not in ("p1", "p2"):  # hdl/p1_top.v, hdl/p2_top.v
        raise UserError(
            f"{vec}: the RTL implements P1 and P2; these are {manifest.get('pipeline')} vectors"
        )
    with tempfile.TemporaryDirectory(prefix="rangefx-hdl-") as tmp:
        try:
            sim = simulate(vec, tmp, simulator, bench)
        except (SimulatorMissing, ValueError) as exc:
            raise UserError(str(exc)) from None
        try:
            rep = compare(vec, sim["dump"])
        except (ValueError, OSError) as exc:
            raise UserError(f"comparing the RTL's dump with {vec}: {exc}") from None
        if dump:
            with atomic_output_dir(dump) as out:
                for f in sorted(sim["dump"].iterdir()):
                    shutil.copy2(f, out / f.name)
    m, n = manifest["shape"]
    cycles = int(sim["status"]["cycles"])
    figures = {
        "dir": str(vec),
        "sim": simulator,
        "bench": sim["bench"],
        "mode": manifest["mode"],
        "shape": [m, n],
        **rep.as_dict(),
        "cycles": cycles,
        "build_s": round(sim["build_s"], 3),
        "sim_s": round(sim["sim_s"], 3),
        "mcycles_per_s": round(cycles / sim["sim_s"] / 1e6, 4),
    }
    if time_model:
        again = case_from_manifest(vec, manifest)
        pipe = again["pipeline"]
        pipe.run(again["case"], again["config"], again["timing"], taps=True)  # compiled
        t0 = time.perf_counter()
        pipe.run(again["case"], again["config"], again["timing"], taps=True)
        model_s = time.perf_counter() - t0
        frames = 2 if manifest["mode"] == "motion" else 1
        figures["model_s"] = round(model_s, 3)
        figures["model_mpix_s"] = round(frames * m * n / model_s / 1e6, 4)
    return ReplayResult(vec, simulator, rep, figures)


# -- word-length studies ---------------------------------------------------------------------
@dataclass(frozen=True)
class SweepResult:
    """A finished sweep in its directory ``out``: the definition as run, the outcome
    (points, records, the keys computed this time) and the summary (``summary.json``:
    point counts, Pareto fronts per scene, timing)."""

    definition: SweepDef
    out: Path
    outcome: SweepOutcome = field(repr=False)
    summary: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """The summary as JSON-able values (``rangefx sweep --json``)."""
        return json_safe(self.summary)

    def write(self, out: str | Path) -> Path:
        """Write the sweep's derived files (points, Pareto fronts, sensitivity, build-up,
        ``summary.json``) from its results into another directory ``out``, atomically."""
        from rangefx.tools.studies.sweep import write_outputs

        with atomic_output_dir(Path(out)) as tmp:
            write_outputs(self.definition, self.outcome, tmp)
        return Path(out)


def sweep(
    definition: str | Path,
    out: str | Path,
    *,
    resume: bool = True,
    workers: int = 2,
    scheduler: str | None = None,
    max_points: int | None = None,
    restart: bool = False,
    cost: str = "proxy",
    progress: bool = False,
) -> SweepResult:
    """Run a word-length sweep definition (TOML, :mod:`rangefx.tools.studies.sweep`) into
    directory ``out``: every point's record in ``results.jsonl`` as it finishes, then the
    derived files and ``summary.json``.

    Parameters
    ----------
    definition
        The sweep definition's path (``rangefx sweep --example`` prints one).
    out
        The sweep directory. With ``resume`` (the default) the points already in it are
        not computed again; ``resume=False`` requires a new or empty directory.
    workers, scheduler
        Local threads, or the address of a dask.distributed scheduler.
    max_points
        Refuse a larger sweep (default :data:`rangefx.tools.studies.sweep.MAX_POINTS`).
    restart
        Delete the results of another definition held in ``out`` and start over.
    cost
        ``"proxy"`` (``cost_bits``) or ``"synth"`` (adds the Yosys area of the
        pipeline's RTL per point: P1 or P2).
    progress
        Show a progress bar on stderr.
    """
    from rangefx.tools.studies.sweep import MAX_POINTS
    from rangefx.tools.studies.sweepdir import sweep_in_dir

    out = Path(out)
    if not resume and out.is_dir() and any(out.iterdir()):
        raise UserError(f"sweep directory {str(out)!r} is not empty and resume is off")
    defn, outcome, summary = sweep_in_dir(
        definition, out, workers=workers, scheduler=scheduler,
        max_points=MAX_POINTS if max_points is None else max_points, restart=restart,
        cost=cost, progress=progress,
    )  # fmt: skip
    return SweepResult(defn, out, outcome, summary)


def optimise(
    pipeline: Pipeline | str = "p1",
    scenes: Sequence[str] | str = ("lab",),
    *,
    config: WordLengthConfig | str | Path | None = None,
    budget: float = 0.01,
    agreement: float = 0.99,
    margin: float = DEFAULT_MARGIN,
    verify: str | None = None,
    size: Sequence[int] | None = None,
    signals: Sequence[str] | None = None,
    tune_registers: bool = False,
    workers: int = 2,
    cost: str = "proxy",
    synth_target: str = "xcup",
    fmax_min: float | None = None,
    timing_stage: str = "top",
    timing_speed: int = 6,
    progress: bool = False,
    **design: Any,
) -> OptimiseReport:
    """The cheapest word lengths of ``pipeline`` meeting an accuracy budget on every
    tuning scene, verified on a scene the optimiser did not see.

    Parameters
    ----------
    pipeline
        A pipeline of :data:`PIPELINES` or its object.
    scenes
        Tuning scene(s): synthetic presets or ``motorcycle`` (the real pair); the cost
        minimised is the first's.
    config, design
        The (safe) starting config, as :func:`run`.
    budget, agreement
        Maximum median relative range error and minimum validity agreement against the
        golden, on every tuning scene.
    margin
        Guard band in ``[0, 1)`` applied while tuning (default
        :data:`rangefx.tools.studies.tuning.DEFAULT_MARGIN`).
    verify
        A held-out scene (``plane``, or a preset that is not a tuning scene).
    size, signals, tune_registers, workers, cost, synth_target, progress
    fmax_min, timing_stage, timing_speed
        As ``rangefx optimise`` (:func:`rangefx.tools.studies.tuning.optimise_on_scenes`).

    Returns
    -------
    OptimiseReport
        ``report.config`` is the optimised config; ``report.figures['verify']`` the
        held-out verification; ``report.write(dir)`` writes ``optimised.toml``, the
        build-up plots and ``summary.json``.
    """
    from rangefx.tools.studies.tuning import optimise_on_scenes

    pipe = _pipeline(pipeline)
    start = _config(pipe, config, design)
    return optimise_on_scenes(
        pipe, start, [scenes] if isinstance(scenes, str) else list(scenes), budget=budget,
        agreement=agreement, margin=margin, verify=verify, size=size, signals=signals,
        tune_registers=tune_registers, workers=workers, cost=cost, synth_target=synth_target,
        fmax_min=fmax_min, timing_stage=timing_stage, timing_speed=timing_speed,
        progress=progress,
    )  # fmt: skip


# -- beyond: real data, guidance ------------------------------------------------------------
def evaluate(
    dataset: str = "motorcycle",
    *,
    protocol: str = "middlebury",
    factor: int | None = None,
    peers: bool = False,
    max_disparity: float | None = None,
    perturbation: Any = None,
    pipelines: Sequence[str] | None = None,
) -> EvalResult:
    """Score the golden methods (G2, G3, G5, G6), P3 and optionally OpenCV's StereoSGBM and
    StereoBM on a real pair with ground truth, and every pipeline beside its golden.

    Parameters
    ----------
    dataset
        ``"motorcycle"``: the Middlebury 2014 pair shipped by scikit-image.
    protocol
        ``"middlebury"`` (density, disparity MAE, bad-0.5/1/2, metric depth error, at the
        factors 4, 8, 16 and the default one) or ``"report"`` (the report's figures).
    factor
        One down-sampling factor instead (default: median disparity about 2 px).
    peers, max_disparity, perturbation
        ``middlebury`` only: the OpenCV peers (extra ``rangefx[peers]``), the largest
        disparity in pixels, and a :class:`rangefx.golden.realdata.Perturbation` of the
        right image.
    pipelines
        The fixed-point pipelines run beside their golden (default: all).

    Returns
    -------
    EvalResult
        :mod:`rangefx.tools.studies.evaluation` describes every figure.
    """
    from rangefx.tools.studies.evaluation import evaluate_pair

    return evaluate_pair(
        dataset, protocol=protocol, factor=factor, peers=peers, max_disparity=max_disparity,
        perturbation=perturbation, pipelines=pipelines,
    )  # fmt: skip


def guide(
    obstacles: str = "synthetic",
    *,
    law: str = "avoid",
    clearance_ft: float = 20.0,
    shift: Sequence[float] = (0.0, 0.0, 0.0),
    guidance_interval: float = 0.1,
    replan_interval: float = 0.5,
    layout_sweep: int | None = None,
    stress: int | None = None,
    pipeline: str = "p1",
    seed: int = 0,
    jobs: int = 1,
) -> GuideResult:
    """Fly the report's chapter-6 guidance through obstacles, keeping a clearance.

    Parameters
    ----------
    obstacles
        ``"synthetic"`` (the documented stand-in for the report's range points),
        ``"runway"`` (the runway scene ranged by golden G4) or ``"runway-<pipeline>"``
        (end to end: ranged by that bit-accurate pipeline; P1 in motion mode, a
        stereo-only pipeline such as P3 on the runway's stereo pair).
    law
        ``"avoid"`` (keeps ``clearance_ft`` from every obstacle extent; the report's law
        is flown beside it) or ``"report"`` (eqs 20-69).
    clearance_ft, shift
        Required clearance (ft); a move of every obstacle (ft).
    guidance_interval, replan_interval
        Seconds between guidance updates, and between re-solves of the avoiding law.
    layout_sweep
        Fly the avoiding law over the ±10 ft shift grid and this many random layouts
        instead.
    stress, pipeline, seed
        Fly both laws over this many seeded layouts of the runway scene ranged by
        ``pipeline``, a true vehicle on or near the nominal path, instead.
    jobs
        Worker processes of the stress programme (the same rows for any count).

    Returns
    -------
    GuideResult
        ``result.metrics`` the flown law's headline figures, ``result.write(dir)`` the
        figures, CSVs and ``summary.json``
        (:mod:`rangefx.tools.studies.flights`).
    """
    from rangefx.tools.studies.flights import guide_flight

    return guide_flight(
        obstacles, law=law, clearance_ft=clearance_ft, shift=shift,
        guidance_interval=guidance_interval, replan_interval=replan_interval,
        layout_sweep=layout_sweep, stress=stress, pipeline=pipeline, seed=seed, jobs=jobs,
    )  # fmt: skip
