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
    :func:`replay` (the vectors through the Verilog of their pipeline, P1 or P2, in a
    simulator).
Word-length studies
    :func:`sweep` (resumable), :func:`optimise` (with held-out verification).
Hardware
    :func:`synth` (Yosys area of a pipeline's RTL), :func:`timing` (Fmax after place and
    route).
Beyond
    :func:`demo` (the main job on the lab scene), :func:`evaluate` (the golden methods
    and pipelines on the real pair with ground truth), :func:`guide` (chapter-6 guidance
    on obstacles a pipeline ranged), :func:`track` (G1, irradiance tracking at one
    pixel), :func:`degrees` (the G3 ranging polynomial of degree 1 to 4).

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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rangefx.golden.estimator import EstimatorConfig
from rangefx.golden.ranging import RangeResult, RangingConfig
from rangefx.rtl_model.config import TimingConfig, WordLengthConfig
from rangefx.rtl_model.pipeline import Case, Pipeline, PipelineResult
from rangefx.rtl_model.registry import PIPELINES, get_pipeline
from rangefx.tools import report
from rangefx.tools.errors import UserError, require_memory
from rangefx.tools.report import atomic_output_dir, atomic_write_bytes, atomic_write_text, json_safe
from rangefx.tools.studies import cases as _cases
from rangefx.tools.studies.banded import plan_bands, run_in_bands
from rangefx.tools.studies.evaluation import EvalResult
from rangefx.tools.studies.flights import DEFAULT_PIPELINE, GuideResult
from rangefx.tools.studies.runner import (
    check_input_levels,
    golden_case,
    load_config,
    pipeline_figures,
    run_case,
)
from rangefx.tools.studies.sweep import SweepDef, SweepOutcome
from rangefx.tools.studies.timing import TimingResult
from rangefx.tools.studies.tracking import DegreesResult, TrackResult
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
    "DegreesResult",
    "DemoResult",
    "DiffReport",
    "EvalResult",
    "GuideResult",
    "HdlReport",
    "OptimiseReport",
    "ReplayResult",
    "RunResult",
    "SweepResult",
    "TrackResult",
    "UserError",
    "VectorsResult",
    "check_vectors",
    "degrees",
    "demo",
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
    "synth",
    "timing",
    "track",
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
    settings: Mapping[str, Any] | None = None,
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
    settings
        Settings key -> settings replacing the scene's measured presets (``"ranging"``:
        a :class:`~rangefx.golden.ranging.RangingConfig` for P1, P3 and the golden
        methods; ``"riccati"``: a :class:`~rangefx.golden.riccati.RiccatiConfig` for P2;
        a registered pipeline's own ``settings_key``).

    Returns
    -------
    Case
        Images, camera, motion, mode (the scene's kind), every pipeline's settings in
        ``case.settings`` (the scene's measured presets, :meth:`Case.from_scene`) and the
        scene with its truth (``case.scene``).
    """
    case = _cases.scene_case(name, size, seed)
    case = _cases.crop_case(case, list(crop) if crop is not None else None)
    return case.with_settings(settings) if settings else case


def real_pair_case(name: str = "motorcycle", factor: int | None = None) -> Case:
    """The stereo case of a real pair: the Middlebury 2014 motorcycle pair shipped by
    scikit-image, down-sampled by ``factor`` (default 26x39 px, median disparity 2 px),
    integer grey levels, lengths in metres (:func:`rangefx.tools.studies.cases.real_pair_case`)."""
    return _cases.real_pair_case(name, factor)


def image_case(
    left: np.ndarray | str | Path,
    right: np.ndarray | str | Path,
    *,
    threshold_e: float | None = None,
    threshold_g: float | None = None,
    range_max: float | None = None,
    **geometry: Any,
) -> Case:
    """A stereo case from your own image pair: :meth:`Case.from_images`, with one-line
    :class:`UserError` for a mistake.

    Parameters
    ----------
    left, right
        E1 (left camera) and E2 (right camera): 2-D arrays of grey levels, or paths of
        ``.npy`` or image files.
    threshold_e, threshold_g, range_max
        The thresholds (grey levels) and largest range, applied to the settings of every
        registered pipeline that reads them (its ``case_options``).
    **geometry
        :meth:`Case.from_images`'s keywords: ``f_px`` and ``baseline`` (focal length in
        pixels, principal point at the centre, and stereo baseline in the range's unit),
        or ``camera`` (a :class:`~rangefx.golden.geometry.PinholeCamera`) and ``motion``
        (a :class:`~rangefx.golden.geometry.MotionIncrement`); ``settings`` (settings
        key -> settings, as :func:`scene_case`; absent keys: the defaults); ``label``.

    Returns
    -------
    Case
        The fixed-point pipelines need integer grey levels: :func:`run` refuses an image
        with fractions, naming it.
    """
    try:
        case = Case.from_images(left, right, **geometry)
    except (TypeError, ValueError) as exc:
        raise UserError(str(exc)) from None
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
            range_max, title = _method_ranging(self.case).range_max, self.method
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


def _method_ranging(case: Case) -> RangingConfig:
    """The golden methods' thresholds and ``range_max``: the case's ``"ranging"`` settings
    (those of P1 and P3, which share them)."""
    return case.setting("ranging", RangingConfig)


def _run_method(case: Case, method: str, estimator: EstimatorConfig) -> RunResult:
    from rangefx.golden.methods import run_method

    try:
        result = run_method(
            method, case.image1, case.image2, case.camera, case.motion,
            estimator=estimator, ranging=_method_ranging(case),
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
            try:
                pipe.check_mode(full)
            except ValueError as exc:
                raise UserError(str(exc)) from None
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
        Guard band in ``[0, 1)`` (default
        :data:`rangefx.tools.studies.tuning.DEFAULT_MARGIN`): while tuning, candidates meet
        the budget tightened by it (:meth:`~rangefx.tools.studies.optimiser.Budget.tightened`);
        the result is reported against the budget itself.
    verify
        A held-out scene (``plane``, or a preset that is not a tuning scene).
    size
        ``(height, width)`` the synthetic scenes are rendered at (default 512x512).
    signals, tune_registers, workers
        As :func:`rangefx.tools.studies.optimiser.optimise`.
    cost, synth_target
        ``"proxy"`` minimises ``cost_bits``; ``"synth"`` the Yosys LUT + FF of the
        pipeline's whole RTL on ``synth_target``.
    fmax_min, timing_stage, timing_speed
        Keep a narrowing only if the RTL (``timing_stage`` ``"top"`` or, P1,
        ``"frontend"``) still places and routes at ``>= fmax_min`` MHz on an LFE5U-85F of
        speed grade ``timing_speed`` (:func:`rangefx.tools.studies.timing.fmax_measure`;
        the start must meet it too). None: no clock-rate floor.
    progress
        Show a progress bar on stderr.

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
    pipeline: str = DEFAULT_PIPELINE,
    seed: int = 0,
    jobs: int = 1,
    out: str | Path | None = None,
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
        ``pipeline`` (default P3, which flew them better than P1:
        :data:`rangefx.tools.studies.flights.DEFAULT_PIPELINE`), a true vehicle on or
        near the nominal path, instead.
    jobs
        Worker processes of the stress programme (the same rows for any count).
    out
        The stress programme's output directory (created if absent): each finished
        layout is appended to its ``stress_layouts.jsonl`` as one JSON line, and the
        layouts already there with the same settings are not flown again (an
        interrupted programme resumes). ``None``: no journal.

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
        out=out,
    )  # fmt: skip


def track(
    xp: float = 40.0,
    zp: float = 30.0,
    *,
    duration: float = 5.0,
    taus: Sequence[float] = (0.1, 0.4),
    fraction: float = 0.1,
    threshold: float = 0.1,
    noise: float = 0.0,
    seed: int = 0,
) -> TrackResult:
    """Range one pixel by irradiance tracking (G1, report ch. 2) on the chapter-2 scene.

    Parameters
    ----------
    xp, zp
        The pixel, from the image centre (``xp`` right, ``zp`` up).
    duration
        Simulated time, s.
    taus
        Time constants (s) of the low-pass filters applied to the raw range.
    fraction
        The frame interval as a fraction of the sampling bound of eq 9.
    threshold
        Smallest ``|h dE_M/dt|`` (grey levels per frame) that updates the range.
    noise, seed
        Sensor noise sigma (grey levels) and its seed.

    Returns
    -------
    TrackResult
        ``result.run`` the time series, ``result.to_dict()`` the figures (sampling bound,
        final and tail errors, raw and filtered), ``result.write(dir)`` Figs 3-7
        look-alikes, ``tracking.csv`` and ``summary.json``.

    Raises
    ------
    UserError
        A non-positive duration, a pixel outside the scene or a bad filter setting.
    """
    from rangefx.tools.studies.tracking import track_pixel

    return track_pixel(
        xp, zp, duration=duration, taus=taus, fraction=fraction, threshold=threshold,
        noise=noise, seed=seed,
    )  # fmt: skip


def degrees(
    scene: str = "lab",
    *,
    variant: str = "consistent",
    order: int | None = None,
    size: Sequence[int] | None = None,
    seed: int = 0,
) -> DegreesResult:
    """Range a scene preset with the SPIE ranging polynomial (G3) of degree 1 to 4.

    Parameters
    ----------
    scene
        A preset of :data:`rangefx.golden.scenes.SCENE_NAMES`.
    variant
        The causal estimator: ``"consistent"`` or ``"paper"``.
    order
        The estimator order for every degree (degrees up to it); default: two settings,
        order equal to the degree and order 4 for every degree (the same derivatives, so
        only the polynomial changes).
    size, seed
        ``(height, width)`` to render at, and the scene's noise seed.

    Returns
    -------
    DegreesResult
        ``result.to_dict()['settings']``: setting -> ``degree<d>`` -> per-object table,
        valid fraction and median relative error; ``result.write(dir)`` ``table.md`` and
        ``summary.json``.
    """
    from rangefx.tools.studies.tracking import degree_tables

    return degree_tables(scene, variant=variant, order=order, size=size, seed=seed)


@dataclass(frozen=True)
class DemoResult:
    """The demo's figures and files (:func:`demo`).

    ``summary`` is ``summary.json``: the golden methods' per-object tables, every
    pipeline beside its golden, the end-to-end flight and the paper estimator's
    diagnostics; ``warnings`` the end-to-end flight's; ``files`` every file the demo
    wrote (relative path -> bytes: range maps, histograms, tables, ``guide/``)."""

    summary: dict[str, Any]
    warnings: tuple[str, ...]
    files: Mapping[str, bytes] = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The figures as JSON-able values (``rangefx demo --json``)."""
        return json_safe(self.summary)

    def write(self, out: str | Path) -> Path:
        """Write every file of the demo into directory ``out``, atomically."""
        with atomic_output_dir(Path(out)) as tmp:
            self.write_into(tmp)
        return Path(out)

    def write_into(self, directory: Path) -> None:
        """Write every file into ``directory``, an output directory being written (the
        temporary one of :func:`rangefx.tools.report.atomic_output_dir`)."""
        for name, data in self.files.items():
            (directory / name).parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(directory / name, data)


def demo(
    *,
    seed: int = 0,
    pole: float | None = None,
    bias: float | None = None,
    pipelines: Sequence[str] | None = None,
    step: Callable[[str], None] | None = None,
) -> DemoResult:
    """The main job on the ``lab`` scene: the golden methods, every registered pipeline
    beside its golden, and the end-to-end chain (runway, P1 in motion mode, obstacles,
    guidance).

    Parameters
    ----------
    seed
        The scene's noise seed.
    pole, bias
        The filter pole ``c`` per pixel and the input bias ``B`` (eq 19), for the golden
        estimator and the pipelines that have them alike (default 0.5 and 16).
    pipelines
        The fixed-point pipelines to run (default: every registered one).
    step
        Called with the name of each step of
        :data:`rangefx.tools.studies.demo.DEMO_STEPS` as it starts (a progress bar).

    Returns
    -------
    DemoResult
        What ``rangefx demo --out DIR`` writes, in memory: ``result.write(dir)``.
    """
    import tempfile

    from rangefx.tools.studies.demo import demo_into

    changes = {k: v for k, v in (("pole", pole), ("bias", bias)) if v is not None}
    try:
        estimator = EstimatorConfig(**changes)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    for name in pipelines or ():
        _pipeline(name)
    with tempfile.TemporaryDirectory(prefix="rangefx-demo-") as tmp:
        summary, notes = demo_into(
            Path(tmp), seed=seed, est=estimator, design=changes, pipelines=pipelines,
            step=step or (lambda name: None),
        )  # fmt: skip
        files = {
            p.relative_to(tmp).as_posix(): p.read_bytes()
            for p in sorted(Path(tmp).rglob("*"))
            if p.is_file()
        }
    return DemoResult(summary, tuple(notes), files)


@dataclass(frozen=True)
class HdlReport:
    """Figures of the Verilog of a pipeline: its Yosys area (:func:`synth`) or its timing
    after place and route (:func:`timing`). ``figures`` is what ``rangefx hdl synth
    --json`` / ``rangefx hdl timing --json`` prints; ``result`` the study's own result
    (a :class:`rangefx.tools.studies.timing.TimingResult` for timing, else None)."""

    kind: str
    figures: dict[str, Any]
    result: TimingResult | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The figures as JSON-able values."""
        return json_safe(self.figures)

    def write(self, out: str | Path) -> Path:
        """Write ``<kind>.json`` (``synth.json`` or ``timing.json``) into directory
        ``out``, atomically."""
        with atomic_output_dir(Path(out)) as tmp:
            atomic_write_text(tmp / f"{self.kind}.json", _json_text(self.figures))
        return Path(out)


def synth(
    pipeline: Pipeline | str = "p1",
    config: WordLengthConfig | str | Path | None = None,
    *,
    target: str = "xcup",
    shape: Sequence[int] = (512, 512),
    mode: str = "stereo",
    stage: str = "all",
    use_cache: bool = True,
    probes: bool = True,
    **design: Any,
) -> HdlReport:
    """The Yosys area (LUT, FF, carry, DSP, BRAM) of a pipeline's RTL in ``hdl/``.

    Parameters
    ----------
    pipeline
        A pipeline with RTL (:data:`rangefx.tools.studies.synth.RTL_TOPS`: P1, P2).
    config, design
        The word-length config and design fields, as :func:`run`.
    target
        The Yosys flow (:data:`rangefx.tools.studies.synth.TARGETS`: ``xc7``, ``xcup``,
        ``ecp5``, ``ice40``).
    shape
        ``(height, width)`` the line buffers and counters are sized for.
    mode
        ``"stereo"`` (two front ends) or ``"motion"`` (one and the frame store).
    stage
        ``"top"`` (the whole top, its probes apart), a P1 stage (``"frontend"``,
        ``"range"``) or ``"all"`` (the top and every stage; P2: the top).
    use_cache, probes
        Take a cached synthesis where one exists; also synthesise the top with its taps
        and overflow counters to report what they cost.

    Returns
    -------
    HdlReport
        ``report.figures``: ``headline``, its ``lut``, ``ff``, ``carry``, ``dsp``,
        ``bram``, ``probes``, ``stages`` and the cost proxy beside them.

    Raises
    ------
    UserError
        A pipeline without RTL, a mode or stage its RTL has not, Yosys missing.
    """
    from rangefx.tools.studies.synth import STAGES, rtl_top, synth_pipeline

    pipe = _pipeline(pipeline)
    rtl = rtl_top(pipe.name)  # one line for a pipeline without RTL, before any work
    cfg = _config(pipe, config, design)
    if stage not in ("top", *STAGES, "all"):
        raise UserError(f"stage must be top, {', '.join(STAGES)} or all, not {stage!r}")
    parts = ("top", *rtl.stages) if stage == "all" else (stage,)
    figures = synth_pipeline(
        pipe.name, cfg, target, (int(shape[0]), int(shape[1])), mode, parts,
        use_cache=use_cache, probes=probes,
    )  # fmt: skip
    return HdlReport("synth", {"pipeline": pipe.name, "config": cfg.name, **figures})


def timing(
    pipeline: Pipeline | str = "p1",
    config: WordLengthConfig | str | Path | None = None,
    *,
    stage: str = "top",
    mode: str = "stereo",
    shape: Sequence[int] = (512, 512),
    device: str | None = None,
    package: str | None = None,
    speed: int | None = None,
    seeds: int = 3,
    freq_mhz: float = 148.5,
    target: str = "ecp5",
    use_cache: bool = True,
    **design: Any,
) -> HdlReport:
    """Fmax, critical path and utilisation of a pipeline's RTL after Yosys and nextpnr
    place and route (the ``yowasp`` builds from PyPI, or the tools on ``PATH``).

    Parameters
    ----------
    pipeline
        A pipeline with RTL (P1, P2).
    config, design
        The word-length config and design fields, as :func:`run`.
    target, device, package, speed
        The FPGA family (:data:`rangefx.tools.studies.timing.TARGETS`: ``ecp5``,
        ``ice40``), its device (ECP5 LFE5U-25F/-45F/-85F: ``"25k"``, ``"45k"``, ``"85k"``,
        default ``"85k"``; iCE40: ``"up5k"`` (default), ``"hx8k"``), package (default: the
        device's first) and speed grade (ECP5: default 6, the slowest; iCE40: none).
    seeds
        nextpnr runs with seeds 1..``seeds``; Fmax is their median.
    freq_mhz
        The frequency nextpnr's placement and routing aim at (it does not cap Fmax).
    shape, mode
        ``(height, width)`` the counters are sized for; ``"stereo"`` or ``"motion"``.
    stage
        ``"top"`` (the whole top) or, P1 only, ``"frontend"`` (one stream's front end: a
        small, fast check).
    use_cache
        Take cached runs where they exist (keyed by the design and the seed).

    Returns
    -------
    HdlReport
        ``report.figures``: ``fmax_mhz`` per clock, ``critical_path``, ``seeds``,
        ``utilisation``, ``cells``, ``pins``; ``report.result`` the
        :class:`~rangefx.tools.studies.timing.TimingResult`.

    Raises
    ------
    UserError
        A pipeline without RTL, an unknown device, package, speed grade, mode or stage, a
        missing tool, or a tool failing on the design.
    """
    from rangefx.tools.studies.synth import rtl_top
    from rangefx.tools.studies.timing import time_top

    pipe = _pipeline(pipeline)
    rtl_top(pipe.name)  # one line for a pipeline without RTL, before any work
    cfg = _config(pipe, config, design)
    result = time_top(
        pipe.name, cfg, target=target, device=device, package=package, speed=speed,
        seeds=seeds, freq_mhz=freq_mhz, shape=(int(shape[0]), int(shape[1])), mode=mode,
        stage=stage, use_cache=use_cache,
    )  # fmt: skip
    return HdlReport("timing", result.to_dict(), result)
