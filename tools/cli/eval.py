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
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence

import numpy as np

from rangefx.golden.central import CentralConfig
from rangefx.golden.methods import run_method
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.realdata import StereoData, evaluate, load_motorcycle
from rangefx.golden.riccati import bryson_config
from rangefx.rtl_model.registry import PIPELINES

from ..errors import UserError
from ..report import json_safe
from ..studies.cases import real_pair_case
from ..studies.runner import golden_case, load_config, run_case
from .options import add_pipelines_arg

__all__ = ["EVAL_METHODS", "add_parser", "cmd_eval", "evaluate_dataset", "evaluate_fixed_point"]

EVAL_METHODS: tuple[str, ...] = ("g2_central", "g3_consistent", "g3_paper", "g5_riccati")
DATASETS: tuple[str, ...] = ("motorcycle",)
_THRESHOLD = 2.0  # grey levels (T_E, T_g), the lab setting


def evaluate_dataset(data: StereoData) -> dict[str, dict[str, float | int]]:
    """Run :data:`EVAL_METHODS` on ``data`` and score each against ``data.depth``."""
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
    out = {}
    for m in EVAL_METHODS:
        r = run_method(
            m,
            data.image1,
            data.image2,
            data.camera,
            data.motion,
            ranging=ranging,
            central=central,
            riccati=riccati,
        )
        out[m] = evaluate(r.range, r.valid, data.depth)
    return out


def evaluate_fixed_point(
    data: StereoData, name: str, factor: int | None, pipelines: Sequence[str] | None = None
) -> dict[str, dict]:
    """Every registered pipeline (each variant, shipped default config) on the pair as
    :func:`~rangefx.tools.studies.cases.real_pair_case` builds it (integer grey levels,
    metres), beside its golden on the same case: overflows, saturated host registers,
    median and p95 |fixed - golden| / golden, valid agreement, and both scored against the
    dataset's depth like the golden methods (relative errors, so the unit cancels)."""
    case = real_pair_case(name, factor)
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


def cmd_eval(args: argparse.Namespace) -> int:
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
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``eval`` subcommand on the CLI's subparsers."""
    p = sub.add_parser("eval", help="score G2, G3 and G5 on real stereo data with ground truth")
    p.add_argument("--dataset", default="motorcycle", help="dataset: motorcycle")
    p.add_argument(
        "--factor",
        help="area-mean down-sampling factor (default: median disparity about 2 px)",
    )
    add_pipelines_arg(p)
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_eval)
