"""The golden methods and the fixed-point pipelines on real stereo data with ground truth
(SPEC §12, §15): what ``rangefx eval`` computes, as one call (:func:`evaluate_pair`).

``rangefx eval --dataset motorcycle [--factor N] [--json]`` loads the Middlebury 2014
motorcycle pair shipped by scikit-image (:mod:`rangefx.golden.realdata`), down-sampled
by ``N`` (default: the factor where the median disparity is about 2 px), runs G2, G3
(``paper`` and ``consistent`` estimators) and G5, and prints for each the density,
the median relative depth error and the fractions within 5 % and 10 %
(:func:`rangefx.golden.realdata.evaluate`); then every registered fixed-point pipeline
beside its golden on the same pair (:func:`evaluate_fixed_point`).

Settings are not tuned on this pair: G2 and G3 use the lab thresholds (T_E = T_g = 2
grey levels); G5 uses Bryson's rule (eqs 14-16) with the error scales implied by the
paper's weights and ``z_max`` = half the maximum scene depth; ``range_max`` is twice the
largest known depth.

Two protocols (``--protocol``):

``middlebury`` (default)
    The Middlebury 2014 figures (:func:`rangefx.golden.realdata.middlebury_metrics`):
    density over all pixels, disparity MAE (avgerr), bad-0.5 / bad-1 / bad-2 (percent of
    the scored pixels) and the median relative metric-depth error with ``doffs``, at the
    factors 4, 8, 16 and the default one (or the one ``--factor``), for every method of
    :data:`MIDDLEBURY_METHODS` (G6 included) and for the fixed-point pipelines of
    :data:`MIDDLEBURY_PIPELINES` (P3, the fixed-point G6, on the pair's integer grey
    levels, shipped default config). ``--peers`` adds OpenCV's StereoSGBM and StereoBM
    under the same protocol in the same run (extra ``rangefx[peers]``; without OpenCV a
    one-line note, and they are skipped), padded on the left (:func:`run_peers`).

    No setting comes from the ground truth (SPEC §12): the headline runs every method
    with what a user has, ``--max-disparity`` (px of the input) or, without it, each
    method's own choice (G6 and P3: 1/8 of the width; the peers: OpenCV's sample rule,
    the width / 8 rounded up to 16). Beside it, labelled ``gt_informed``, G6, P3 and the
    peers given the dataset's search range (:func:`~rangefx.golden.realdata.search_range`,
    Middlebury's ``ndisp``); and, per peer, P3 and the peer scored over the pixels valid
    in both (``valid_in_both``). ``--perturb`` changes the right image as a real rig
    does (:class:`~rangefx.golden.realdata.Perturbation`) before everything runs.
``report``
    The figures this command printed before: density among the pixels with known truth
    and the relative error of ``f B / d`` (no ``doffs``), one factor.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rangefx.golden.central import CentralConfig
from rangefx.golden.methods import run_method
from rangefx.golden.multiscale import MultiscaleConfig
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.realdata import (
    Perturbation,
    StereoData,
    disparity_from_range,
    evaluate,
    load_motorcycle,
    middlebury_metrics,
    perturb_right,
    search_range,
)
from rangefx.golden.riccati import bryson_config
from rangefx.rtl_model.registry import PIPELINES

from ..errors import UserError
from ..report import atomic_output_dir, atomic_write_text, json_safe
from .cases import real_pair_case
from .runner import golden_case, load_config, run_case

__all__ = [
    "DATASETS",
    "EVAL_METHODS",
    "MIDDLEBURY_FACTORS",
    "MIDDLEBURY_KEYS",
    "MIDDLEBURY_METHODS",
    "MIDDLEBURY_PIPELINES",
    "PEERS",
    "PROTOCOLS",
    "EvalResult",
    "evaluate_dataset",
    "evaluate_fixed_point",
    "evaluate_middlebury",
    "evaluate_pair",
    "load_dataset",
    "peer_disparities",
    "run_peers",
]

EVAL_METHODS: tuple[str, ...] = ("g2_central", "g3_consistent", "g3_paper", "g5_riccati")
#: Methods scored under the Middlebury protocol: the report's and G6.
MIDDLEBURY_METHODS: tuple[str, ...] = (*EVAL_METHODS, "g6_multiscale")


def middlebury_pipelines() -> tuple[str, ...]:
    """The registered pipelines scored as methods under the Middlebury protocol: those
    with a :attr:`~rangefx.rtl_model.pipeline.Pipeline.search_range_field` (dense stereo),
    at the shipped default config and the user's search range."""
    return tuple(name for name, p in PIPELINES.items() if p.search_range_field)


#: :func:`middlebury_pipelines` of the package's own pipelines (P3, beside its golden G6).
MIDDLEBURY_PIPELINES: tuple[str, ...] = middlebury_pipelines()
#: Factors of the Middlebury tables (the default factor is added).
MIDDLEBURY_FACTORS: tuple[int, ...] = (4, 8, 16)
#: The figures of every method under the Middlebury protocol (``--json``).
MIDDLEBURY_KEYS: tuple[str, ...] = (
    "density",
    "mae_px",
    "bad_0_5",
    "bad_1",
    "bad_2",
    "rel_depth_error",
    "n_scored",
)
#: OpenCV peers (``--peers``).
PEERS: tuple[str, ...] = ("opencv_sgbm", "opencv_bm")
PROTOCOLS: tuple[str, ...] = ("middlebury", "report")
DATASETS: tuple[str, ...] = ("motorcycle",)
_THRESHOLD = 2.0  # grey levels (T_E, T_g), the lab setting


def _method_results(
    data: StereoData, methods: tuple[str, ...], max_disparity: float | None = None
) -> dict:
    """Range results of ``methods`` on ``data`` with the settings of the module docstring;
    G6 is given ``max_disparity`` (None: its own choice)."""
    ranging = RangingConfig(
        threshold_e=_THRESHOLD, threshold_g=_THRESHOLD, range_max=data.range_max
    )
    central = CentralConfig(
        threshold_e=_THRESHOLD, threshold_g=_THRESHOLD, range_max=data.range_max
    )
    riccati = bryson_config(
        data.camera.width,
        data.range_max / 2,
        threshold_e=_THRESHOLD,
        range_max=data.range_max,
    )
    multiscale = MultiscaleConfig(max_disparity=max_disparity)
    out = {}
    for m in methods:
        out[m] = run_method(m, data.image1, data.image2, data.camera, data.motion,
                            ranging=ranging, central=central, riccati=riccati,
                            multiscale=multiscale)  # fmt: skip
    return out


def evaluate_dataset(data: StereoData) -> dict[str, dict[str, float | int]]:
    """Run :data:`EVAL_METHODS` on ``data`` and score each against ``data.depth``
    (the ``report`` protocol)."""
    return {
        m: evaluate(r.range, r.valid, data.depth)
        for m, r in _method_results(data, EVAL_METHODS).items()
    }


def _middlebury(data: StereoData, disparity: np.ndarray, valid: np.ndarray) -> dict:
    return middlebury_metrics(
        disparity,
        valid,
        data.disparity,
        data.metric_depth,
        data.doffs_px,
        data.camera.f_px,
        abs(float(data.motion.camera_displacement[1])),
    )


def peer_disparities(width: int, max_disparity: float | None) -> int:
    """OpenCV's ``numDisparities`` (a multiple of 16): the user's ``max_disparity``
    rounded up, or without it the rule of OpenCV's ``stereo_match`` sample,
    ``((width / 8) + 15) & -16``."""
    if max_disparity is None:
        return max(16, ((width // 8) + 15) & -16)
    return 16 * math.ceil(max_disparity / 16)


def run_peers(
    data: StereoData, max_disparity: float | None = None
) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], str | None]:
    """OpenCV StereoSGBM and StereoBM on ``data`` (8-bit grey) as their users run them:
    ``({name: (disparity, valid)}, None)``, or ``({}, note)`` when OpenCV is not
    installed.

    ``numDisparities`` = :func:`peer_disparities`. Both images are padded on the left by
    ``numDisparities`` replicated columns and the output cropped back: unpadded, OpenCV
    returns nothing for the leftmost ``numDisparities`` columns (35-41 % of the image at
    1/16 and 1/19). Settings are those OpenCV's documentation and its ``stereo_match``
    sample give, not tuned on this pair: SGBM block 5, ``P1 = 8·cn·5²``, ``P2 =
    32·cn·5²`` (``cn = 1``, grey), ``preFilterCap`` 63, uniqueness 10, speckle filter on
    (window 100, range 2 px: SGBM multiplies its ``speckleRange`` by 16), left-right
    check 1 px (``disp12MaxDiff``); BM block 9, ``preFilterCap`` 31, texture threshold 10,
    uniqueness 15, speckle filter on (window 100, range 32 = 2 px: BM's is in its 1/16 px
    output units), ``disp12MaxDiff`` 1. Pixels with a negative (invalid) output are
    invalid.
    """
    try:
        import cv2
    except ImportError:
        return {}, "OpenCV is not installed (pip install 'rangefx[peers]'): peers skipped"
    ndisp = peer_disparities(data.camera.width, max_disparity)
    left, right = (
        cv2.copyMakeBorder(
            np.clip(np.rint(im), 0, 255).astype(np.uint8), 0, 0, ndisp, 0, cv2.BORDER_REPLICATE
        )
        for im in (data.image1, data.image2)
    )
    block = 5
    sgbm = cv2.StereoSGBM_create(
        minDisparity=0,
        numDisparities=ndisp,
        blockSize=block,
        P1=8 * block * block,
        P2=32 * block * block,
        disp12MaxDiff=1,
        preFilterCap=63,
        uniquenessRatio=10,
        speckleWindowSize=100,
        speckleRange=2,
    )
    bm = cv2.StereoBM_create(numDisparities=ndisp, blockSize=9)
    bm.setPreFilterCap(31)
    bm.setTextureThreshold(10)
    bm.setUniquenessRatio(15)
    bm.setSpeckleWindowSize(100)
    bm.setSpeckleRange(32)
    bm.setDisp12MaxDiff(1)
    out = {}
    for name, matcher in (("opencv_sgbm", sgbm), ("opencv_bm", bm)):
        raw = matcher.compute(left, right)[:, ndisp:]  # int16, 4 fraction bits; < 0 invalid
        out[name] = (raw.astype(np.float64) / 16.0, raw >= 0)
    return out, None


def _pipeline_run(
    name: str, data: StereoData, max_disparity: float | None
) -> tuple[np.ndarray, np.ndarray, int]:
    """Pipeline ``name`` at its shipped default (search range ``max_disparity``, None: its
    own) on ``data``'s (possibly perturbed) pair rounded to integer grey levels:
    (disparity, valid, overflows)."""
    case = real_pair_case(DATASETS[0], data.factor)
    image1, image2 = (
        np.clip(np.rint(im), 0, 255).astype(np.int64) for im in (data.image1, data.image2)
    )
    case = dataclasses.replace(case, image1=image1, image2=image2)
    to_dataset_unit = 1e3  # the case is in metres, the dataset's depth in mm
    pipeline = PIPELINES[name]
    config = load_config(
        pipeline, None, **{pipeline.search_range_field: float(max_disparity or 0.0)}
    )
    result = run_case(pipeline, case, config, taps=False)
    disparity = disparity_from_range(result.range * to_dataset_unit, data)
    return disparity, result.valid, result.overflow_total


def evaluate_middlebury(
    data: StereoData, *, peers: bool = False, max_disparity: float | None = None
) -> tuple[dict[str, dict], str | None]:
    """Every method of :data:`MIDDLEBURY_METHODS`, :func:`middlebury_pipelines` (P3)
    (and the OpenCV peers if
    ``peers``) on ``data`` with the user's ``max_disparity`` (None: each its own
    choice), scored with :func:`~rangefx.golden.realdata.middlebury_metrics`:
    ``{"methods": ..., "gt_informed": ..., "valid_in_both": ..., "overflows": ...}``
    (module docstring) and the note of skipped peers (or None)."""
    gt = float(search_range(data))
    methods, informed, both, overflows = {}, {}, {}, {}
    for m, r in _method_results(data, MIDDLEBURY_METHODS, max_disparity).items():
        methods[m] = _middlebury(data, disparity_from_range(r.range, data), r.valid)
    r = _method_results(data, ("g6_multiscale",), gt)["g6_multiscale"]
    informed["g6_multiscale"] = _middlebury(data, disparity_from_range(r.range, data), r.valid)
    runs = {}
    for name in middlebury_pipelines():
        runs[name] = _pipeline_run(name, data, max_disparity)
        methods[name] = _middlebury(data, *runs[name][:2])
        overflows[name] = runs[name][2]
        d, v, overflows[f"{name}_gt_informed"] = _pipeline_run(name, data, gt)
        informed[name] = _middlebury(data, d, v)
    note = None
    if peers:
        found, note = run_peers(data, max_disparity)
        for peer, (disparity, valid) in found.items():
            methods[peer] = _middlebury(data, disparity, valid)
            common = valid & np.logical_and.reduce([v for _, v, _ in runs.values()])
            both[peer] = {name: _middlebury(data, d, common) for name, (d, _, _) in runs.items()}
            both[peer][peer] = _middlebury(data, disparity, common)
        for name, (disparity, valid) in run_peers(data, gt)[0].items():
            informed[name] = _middlebury(data, disparity, valid)
    out = {"methods": methods, "gt_informed": informed, "valid_in_both": both}
    return {**out, "overflows": overflows}, note


def evaluate_fixed_point(
    data: StereoData,
    name: str,
    factor: int | None,
    pipelines: Sequence[str] | None = None,
    perturbation: Perturbation | None = None,
) -> dict[str, dict]:
    """Every registered pipeline (each variant, shipped default config) on the pair as
    :func:`~rangefx.tools.studies.cases.real_pair_case` builds it (integer grey levels,
    metres), beside its golden on the same case: overflows, saturated host registers,
    median and p95 |fixed - golden| / golden, valid agreement, and both scored against the
    dataset's depth like the golden methods (relative errors, so the unit cancels). With
    ``perturbation``, the right image is ``data``'s perturbed (``--perturb``), rounded to
    grey levels as the Middlebury section's P3 gets it."""
    case = real_pair_case(name, factor)
    if perturbation is not None and not perturbation.is_identity:
        image2 = np.clip(np.rint(perturbation.apply(data.image2)), 0, 255).astype(np.int64)
        case = dataclasses.replace(case, image2=image2)
    to_dataset_unit = 1e3  # the case is in metres, the dataset's depth in mm
    out = {}
    for pipeline in (PIPELINES[n] for n in pipelines or PIPELINES):
        for variant, design in pipeline.variants.items():
            config = load_config(pipeline, None, **design)
            result = run_case(pipeline, case, config)
            golden = golden_case(pipeline, case, config).result
            both = result.valid & golden.valid
            rel = np.abs(result.range[both] - golden.range[both]) / golden.range[both]
            key = f"{pipeline.name}_{variant}" if variant else pipeline.name
            out[key] = {
                "golden": pipeline.golden_label(config),
                "config": config.name,
                "overflows": result.overflow_total,
                "overflow_signals": {k: v for k, v in result.overflows.items() if v},
                "saturated_registers": list(result.saturated_registers),
                "median_rel_range_diff": float(np.median(rel)) if rel.size else math.nan,
                "p95_rel_range_diff": float(np.percentile(rel, 95)) if rel.size else math.nan,
                "valid_agreement": float(np.mean(result.valid == golden.valid)),
                "fixed_vs_truth": evaluate(
                    result.range * to_dataset_unit, result.valid, data.depth
                ),
                "golden_vs_truth": evaluate(
                    golden.range * to_dataset_unit, golden.valid, data.depth
                ),
            }
    return out


def load_dataset(dataset: str = "motorcycle", factor: int | str | None = None) -> StereoData:
    """The real pair ``dataset`` down-sampled by ``factor`` (None: its default factor)."""
    if dataset not in DATASETS:
        raise UserError(f"unknown dataset {dataset!r}; choose from {', '.join(DATASETS)}")
    if factor is None:
        return load_motorcycle()
    try:
        n = int(factor)
    except ValueError:
        raise UserError(f"--factor must be an integer, not {factor!r}") from None
    try:
        return load_motorcycle(n)
    except ValueError as exc:
        raise UserError(f"--factor: {exc}") from None


@dataclass(frozen=True)
class EvalResult:
    """An evaluation on a real pair: ``figures`` (per factor the methods' scores, and the
    fixed-point pipelines beside their golden; NaN where a figure is undefined) and
    ``data``, the pairs evaluated keyed by factor."""

    protocol: str
    figures: dict[str, Any]
    data: dict[int, StereoData] = dataclasses.field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The figures as JSON-able values, NaN as None (``rangefx eval --json``)."""
        return json_safe(self.figures)

    def write(self, out: str | Path) -> Path:
        """Write ``summary.json`` (:meth:`to_dict`) into directory ``out``, atomically."""
        import json

        with atomic_output_dir(Path(out)) as tmp:
            atomic_write_text(tmp / "summary.json", json.dumps(self.to_dict(), indent=2) + "\n")
        return Path(out)


def evaluate_pair(
    dataset: str = "motorcycle",
    *,
    protocol: str = "middlebury",
    factor: int | str | None = None,
    peers: bool = False,
    max_disparity: float | None = None,
    perturbation: Perturbation | None = None,
    pipelines: Sequence[str] | None = None,
) -> EvalResult:
    """Evaluate the golden methods and the fixed-point pipelines on a real pair.

    Parameters
    ----------
    dataset
        A real pair of :data:`DATASETS`.
    protocol
        ``"middlebury"`` (every factor of :data:`MIDDLEBURY_FACTORS` and the default one,
        or ``factor`` alone) or ``"report"`` (one factor; the module docstring).
    factor
        The down-sampling factor (None: the pair's default, median disparity ~2 px).
    peers, max_disparity, perturbation
        ``middlebury`` only: the OpenCV peers, the user's disparity range (px), and a
        change of the right image as a real rig makes.
    pipelines
        The fixed-point pipelines to run beside their golden (default: all).
    """
    if protocol not in PROTOCOLS:
        raise UserError(f"unknown protocol {protocol!r}; choose from {', '.join(PROTOCOLS)}")
    factor_n = None if factor is None else _int_factor(factor)
    if protocol == "report":
        for flag, given in (("--peers", peers), ("--perturb", perturbation),
                            ("--max-disparity", max_disparity)):  # fmt: skip
            if given:
                raise UserError(f"{flag} applies to --protocol middlebury only")
        data = load_dataset(dataset, factor)
        figures = evaluate_dataset(data)
        fixed = evaluate_fixed_point(data, dataset, factor_n, pipelines)
        return EvalResult(protocol, {
            "dataset": data.name,
            "factor": data.factor,
            "size": list(data.image1.shape),
            "unit": data.unit,
            "median_disparity_px": data.median_disparity,
            "methods": figures,
            "fixed_point": fixed,
        }, {data.factor: data})  # fmt: skip
    perturbation = perturbation or Perturbation()
    default = load_dataset(dataset, factor)
    if factor is not None:
        datasets = [default]
    else:
        factors = sorted({*MIDDLEBURY_FACTORS, default.factor})
        datasets = [default if f == default.factor else load_motorcycle(f) for f in factors]
    datasets = [perturb_right(d, perturbation) for d in datasets]
    tables, note = {}, None
    for data in datasets:
        figures, note = evaluate_middlebury(data, peers=peers, max_disparity=max_disparity)
        tables[data.factor] = (data, figures)
    fixed = evaluate_fixed_point(default, dataset, factor_n, pipelines, perturbation)
    result = {
        "dataset": default.name,
        "protocol": "middlebury",
        "factor": default.factor,
        "unit": default.unit,
        "max_disparity": max_disparity,
        "perturbation": dataclasses.asdict(perturbation),
        "peers": {"requested": bool(peers), "note": note},
        "factors": {
            str(f): {
                "size": list(data.image1.shape),
                "median_disparity_px": data.median_disparity,
                "search_range_px": search_range(data),
                "doffs_px": data.doffs_px,
                **figures,
            }
            for f, (data, figures) in tables.items()
        },
        "fixed_point": fixed,
    }
    return EvalResult(protocol, result, {f: data for f, (data, _) in tables.items()})


def _int_factor(factor: int | str) -> int:
    try:
        return int(factor)
    except ValueError:
        raise UserError(f"--factor must be an integer, not {factor!r}") from None
