"""``rangefx eval``: the golden methods on real stereo data with ground truth.

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

import argparse
import dataclasses
import json
import math
import sys
from collections.abc import Sequence

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
from ..report import json_safe
from ..studies.cases import real_pair_case
from ..studies.runner import golden_case, load_config, run_case
from .options import add_pipelines_arg

__all__ = [
    "EVAL_METHODS",
    "MIDDLEBURY_FACTORS",
    "MIDDLEBURY_KEYS",
    "MIDDLEBURY_METHODS",
    "MIDDLEBURY_PIPELINES",
    "PEERS",
    "add_parser",
    "cmd_eval",
    "evaluate_dataset",
    "evaluate_fixed_point",
    "evaluate_middlebury",
    "run_peers",
]

EVAL_METHODS: tuple[str, ...] = ("g2_central", "g3_consistent", "g3_paper", "g5_riccati")
#: Methods scored under the Middlebury protocol: the report's and G6.
MIDDLEBURY_METHODS: tuple[str, ...] = (*EVAL_METHODS, "g6_multiscale")
#: Fixed-point pipelines scored as methods under the Middlebury protocol (P3 beside its
#: golden G6), at the shipped default config and the user's ``max_disparity``.
MIDDLEBURY_PIPELINES: tuple[str, ...] = ("p3",)
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
        out[m] = run_method(
            m,
            data.image1,
            data.image2,
            data.camera,
            data.motion,
            ranging=ranging,
            central=central,
            riccati=riccati,
            multiscale=multiscale,
        )
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


def _p3_run(data: StereoData, max_disparity: float | None) -> tuple[np.ndarray, np.ndarray, int]:
    """P3 at its shipped default on ``data``'s (possibly perturbed) pair rounded to
    integer grey levels: (disparity, valid, overflows)."""
    case = real_pair_case(DATASETS[0], data.factor)
    image1, image2 = (
        np.clip(np.rint(im), 0, 255).astype(np.int64) for im in (data.image1, data.image2)
    )
    case = dataclasses.replace(case, image1=image1, image2=image2)
    to_dataset_unit = 1e3  # the case is in metres, the dataset's depth in mm
    pipeline = PIPELINES[MIDDLEBURY_PIPELINES[0]]
    config = load_config(pipeline, None, max_disparity=float(max_disparity or 0.0))
    result = run_case(pipeline, case, config, taps=False)
    disparity = disparity_from_range(result.range * to_dataset_unit, data)
    return disparity, result.valid, result.overflow_total


def evaluate_middlebury(
    data: StereoData, *, peers: bool = False, max_disparity: float | None = None
) -> tuple[dict[str, dict], str | None]:
    """Every method of :data:`MIDDLEBURY_METHODS`, P3 (and the OpenCV peers if
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
    p3_disparity, p3_valid, overflows["p3"] = _p3_run(data, max_disparity)
    methods["p3"] = _middlebury(data, p3_disparity, p3_valid)
    d, v, overflows["p3_gt_informed"] = _p3_run(data, gt)
    informed["p3"] = _middlebury(data, d, v)
    note = None
    if peers:
        found, note = run_peers(data, max_disparity)
        for name, (disparity, valid) in found.items():
            methods[name] = _middlebury(data, disparity, valid)
            common = valid & p3_valid
            both[name] = {
                "p3": _middlebury(data, p3_disparity, common),
                name: _middlebury(data, disparity, common),
            }
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


def _factor(factor: str | None) -> int | None:
    if factor is None:
        return None
    try:
        return int(factor)
    except ValueError:
        raise UserError(f"--factor must be an integer, not {factor!r}") from None


def _load(dataset: str, factor: str | None) -> StereoData:
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


def _num(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _print_fixed(fixed: dict[str, dict]) -> None:
    print("fixed point (shipped default configs) beside its golden on the same integer pair:")
    for k, f in fixed.items():
        sat = (
            f", saturated registers {', '.join(f['saturated_registers'])}"
            if f["saturated_registers"]
            else ""
        )
        print(
            f"{k:<14} overflows {f['overflows']}, median |fixed-golden|/golden "
            f"{f['median_rel_range_diff']:.2e}, valid agreement {f['valid_agreement']:.4f}, "
            f"median rel err vs truth {f['fixed_vs_truth']['median_rel_error']:.3f} "
            f"(golden {f['golden']} {f['golden_vs_truth']['median_rel_error']:.3f}){sat}"
        )


def cmd_eval(args: argparse.Namespace) -> int:
    if args.protocol not in PROTOCOLS:
        raise UserError(f"unknown protocol {args.protocol!r}; choose from {', '.join(PROTOCOLS)}")
    if args.protocol == "middlebury":
        return _cmd_middlebury(args)
    for flag, given in (("--peers", args.peers), ("--perturb", args.perturb),
                        ("--max-disparity", args.max_disparity)):  # fmt: skip
        if given:
            raise UserError(f"{flag} applies to --protocol middlebury only")
    data = _load(args.dataset, args.factor)
    figures = evaluate_dataset(data)
    fixed = evaluate_fixed_point(data, args.dataset, _factor(args.factor), args.pipeline)
    if args.json:
        print(
            json.dumps(
                {
                    "dataset": data.name,
                    "factor": data.factor,
                    "size": list(data.image1.shape),
                    "unit": data.unit,
                    "median_disparity_px": data.median_disparity,
                    "methods": {
                        m: {k: (_num(v) if isinstance(v, float) else v) for k, v in f.items()}
                        for m, f in figures.items()
                    },
                    "fixed_point": json_safe(fixed),
                }
            )
        )
        return 0
    h, w = data.image1.shape
    print(
        f"{data.name}: factor {data.factor} ({h}x{w} px), "
        f"median disparity {data.median_disparity:.2f} px, depth in {data.unit}"
    )
    print(
        f"{'method':<14} {'density':>8} {'median rel err':>15} {'within 5%':>10} {'within 10%':>11}"
    )
    for m, f in figures.items():
        print(
            f"{m:<14} {f['density']:>8.3f} {f['median_rel_error']:>15.3f} "
            f"{f['within_5pct']:>10.3f} {f['within_10pct']:>11.3f}"
        )
    _print_fixed(fixed)
    return 0


def parse_perturbation(text: str | None) -> Perturbation:
    """``--perturb gain=1.1,offset=5,noise=2,vshift=0.5,blur=1,seed=0`` (any subset)."""
    if not text:
        return Perturbation()
    names = {f for f in Perturbation.__dataclass_fields__}
    kw: dict[str, float | int] = {}
    for item in text.split(","):
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or key not in names:
            raise UserError(
                f"--perturb: {item!r} is not NAME=VALUE with NAME one of {', '.join(names)}"
            )
        try:
            kw[key] = int(value) if key == "seed" else float(value)
        except ValueError:
            raise UserError(f"--perturb: {key} must be a number, not {value!r}") from None
    try:
        return Perturbation(**kw)
    except ValueError as exc:
        raise UserError(f"--perturb: {exc}") from None


def _max_disparity(text: str | None) -> float | None:
    if text is None:
        return None
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise UserError(f"--max-disparity must be a positive number of pixels, not {text!r}")
    return v


def _print_table(title: str, figures: dict[str, dict]) -> None:
    print(title)
    print(
        f"{'method':<14} {'density':>8} {'MAE px':>7} {'bad0.5%':>8} {'bad1%':>6} "
        f"{'bad2%':>6} {'rel Z err':>9}"
    )
    for m, v in figures.items():
        print(
            f"{m:<14} {v['density']:>8.3f} {v['mae_px']:>7.3f} {v['bad_0_5']:>8.1f} "
            f"{v['bad_1']:>6.1f} {v['bad_2']:>6.1f} {100 * v['rel_depth_error']:>8.1f}%"
        )


def _cmd_middlebury(args: argparse.Namespace) -> int:
    max_disparity = _max_disparity(args.max_disparity)
    perturbation = parse_perturbation(args.perturb)
    default = _load(args.dataset, args.factor)
    if args.factor is not None:
        datasets = [default]
    else:
        factors = sorted({*MIDDLEBURY_FACTORS, default.factor})
        datasets = [default if f == default.factor else load_motorcycle(f) for f in factors]
    datasets = [perturb_right(d, perturbation) for d in datasets]
    tables, note = {}, None
    for data in datasets:
        figures, note = evaluate_middlebury(data, peers=args.peers, max_disparity=max_disparity)
        tables[data.factor] = (data, figures)
    fixed = evaluate_fixed_point(
        default, args.dataset, _factor(args.factor), args.pipeline, perturbation
    )
    if args.json:
        print(
            json.dumps(
                {
                    "dataset": default.name,
                    "protocol": "middlebury",
                    "factor": default.factor,
                    "unit": default.unit,
                    "max_disparity": max_disparity,
                    "perturbation": dataclasses.asdict(perturbation),
                    "peers": {"requested": bool(args.peers), "note": note},
                    "factors": {
                        str(f): {
                            "size": list(data.image1.shape),
                            "median_disparity_px": data.median_disparity,
                            "search_range_px": search_range(data),
                            "doffs_px": data.doffs_px,
                            **json_safe(figures),
                        }
                        for f, (data, figures) in tables.items()
                    },
                    "fixed_point": json_safe(fixed),
                }
            )
        )
        return 0
    if note:
        print(f"rangefx: note: {note}", file=sys.stderr)
    setting = f"--max-disparity {max_disparity:g}" if max_disparity else "each method's own"
    if not perturbation.is_identity:
        print(f"right image perturbed: {perturbation}")
    for f, (data, figures) in tables.items():
        h, w = data.image1.shape
        known = data.disparity[np.isfinite(data.disparity)]
        _print_table(
            f"{data.name} 1/{f} ({h}x{w} px): disparity {known.min():.1f}-{known.max():.1f} px "
            f"(median {data.median_disparity:.2f}), all pixels, disparity range: {setting}",
            figures["methods"],
        )
        print(f"P3 overflows: {figures['overflows']['p3']}")
        for peer, pair in figures["valid_in_both"].items():
            n = pair["p3"]["n_scored"]
            _print_table(f"  over the {n} scored pixels valid in both P3 and {peer}:", pair)
        _print_table(
            f"  gt_informed (given the ground truth's search range, {search_range(data)} px):",
            figures["gt_informed"],
        )
    _print_fixed(fixed)
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``eval`` subcommand on the CLI's subparsers."""
    p = sub.add_parser(
        "eval", help="score G2, G3, G5, G6 (and OpenCV peers) on real stereo data with ground truth"
    )
    p.add_argument("--dataset", default="motorcycle", help="dataset: motorcycle")
    p.add_argument(
        "--factor",
        help="area-mean down-sampling factor (default: median disparity about 2 px; "
        "middlebury: 4, 8, 16 and that one)",
    )
    p.add_argument(
        "--protocol",
        default="middlebury",
        help="middlebury (default: MAE, bad-x, density over all pixels, metric depth with "
        "doffs) or report (density among known truth, relative error of f B / d)",
    )
    p.add_argument(
        "--max-disparity",
        help="largest disparity, px of the input, for G6, P3 and the peers (default: "
        "each chooses it from the image width)",
    )
    p.add_argument(
        "--perturb",
        help="change the right image as a real rig does: gain=G,offset=O,noise=SIGMA,"
        "vshift=PX,blur=SIGMA,seed=N (any subset; seeded)",
    )
    p.add_argument(
        "--peers",
        action="store_true",
        help="also run OpenCV StereoSGBM and StereoBM (extra rangefx[peers])",
    )
    add_pipelines_arg(p)
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_eval)
