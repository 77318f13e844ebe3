"""``rangefx eval``: the golden methods and the fixed-point pipelines on real stereo data
with ground truth, one call of :func:`rangefx.api.evaluate`
(:mod:`rangefx.tools.studies.evaluation` describes the protocols and the settings).
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from rangefx.golden.realdata import Perturbation

from ..errors import UserError
from .options import add_pipelines_arg

__all__ = ["add_parser", "cmd_eval", "parse_perturbation"]


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
    from rangefx import api

    middlebury = args.protocol == "middlebury"  # the report protocol refuses these, parsed or not
    result = api.evaluate(
        args.dataset, protocol=args.protocol, factor=args.factor, peers=args.peers,
        max_disparity=_max_disparity(args.max_disparity) if middlebury else args.max_disparity,
        perturbation=parse_perturbation(args.perturb) if middlebury else args.perturb,
        pipelines=args.pipeline,
    )  # fmt: skip
    if args.json:
        print(json.dumps(result.to_dict()))
    elif middlebury:
        _print_middlebury(result)
    else:
        _print_report(result)
    return 0


def _print_report(result) -> None:
    figures = result.figures
    h, w = figures["size"]
    print(
        f"{figures['dataset']}: factor {figures['factor']} ({h}x{w} px), "
        f"median disparity {figures['median_disparity_px']:.2f} px, depth in {figures['unit']}"
    )
    print(
        f"{'method':<14} {'density':>8} {'median rel err':>15} {'within 5%':>10} {'within 10%':>11}"
    )
    for m, f in figures["methods"].items():
        print(
            f"{m:<14} {f['density']:>8.3f} {f['median_rel_error']:>15.3f} "
            f"{f['within_5pct']:>10.3f} {f['within_10pct']:>11.3f}"
        )
    _print_fixed(figures["fixed_point"])


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


def _print_middlebury(result) -> None:
    figures = result.figures
    note, max_disparity = figures["peers"]["note"], figures["max_disparity"]
    perturbation = Perturbation(**figures["perturbation"])
    if note:
        print(f"rangefx: note: {note}", file=sys.stderr)
    setting = f"--max-disparity {max_disparity:g}" if max_disparity else "each method's own"
    if not perturbation.is_identity:
        print(f"right image perturbed: {perturbation}")
    for f, data in result.data.items():
        table = figures["factors"][str(f)]
        h, w = data.image1.shape
        known = data.disparity[np.isfinite(data.disparity)]
        _print_table(
            f"{data.name} 1/{f} ({h}x{w} px): disparity {known.min():.1f}-{known.max():.1f} px "
            f"(median {data.median_disparity:.2f}), all pixels, disparity range: {setting}",
            table["methods"],
        )
        ours = [k for k in table["overflows"] if not k.endswith("_gt_informed")]
        print("overflows: " + ", ".join(f"{k.upper()} {table['overflows'][k]}" for k in ours))
        for peer, pair in table["valid_in_both"].items():
            n = pair[peer]["n_scored"]
            names = " and ".join([*(k.upper() for k in ours), peer])
            _print_table(f"  over the {n} scored pixels valid in both {names}:", pair)
        _print_table(
            f"  gt_informed (given the ground truth's search range, "
            f"{table['search_range_px']} px):",
            table["gt_informed"],
        )
    _print_fixed(figures["fixed_point"])


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
