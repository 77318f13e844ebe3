"""``rangefx track`` (G1, report ch. 2) and ``rangefx degrees`` (G3 degree 1..4 table).

``track`` runs the irradiance-tracking navigation scheme on the ch. 2 scene at one
pixel and writes the report's Figs 3-7 look-alikes (scene section and trajectory, raw
range, range after a fast and a slow low-pass filter), the time series as CSV and a
``summary.json``. ``degrees`` ranges a scene preset with the SPIE ranging polynomial of
degree 1..4 and prints the per-object table of each degree: once with the estimator
order equal to the degree, once with order 4 for every degree (the same derivatives, so
only the polynomial changes). Each is one call: :func:`rangefx.api.track`,
:func:`rangefx.api.degrees`.
"""

from __future__ import annotations

import argparse
import json
import sys

from rangefx.golden.scenes import SCENE_NAMES

from .. import report
from .options import int_at_least, out_path

__all__ = ["add_parser", "cmd_degrees", "cmd_track"]


def cmd_track(args: argparse.Namespace) -> int:
    from rangefx import api

    result = api.track(
        args.xp, args.zp, duration=args.duration, taus=args.tau, fraction=args.fraction,
        threshold=args.threshold, noise=args.noise, seed=args.seed,
    )  # fmt: skip
    out = result.write(args.out)
    summary, unit = result.summary, result.scene.unit
    if args.json:
        print(json.dumps(result.to_dict()))
        return 0
    bound = summary["sampling_bound"]
    print(
        f"G1 at pixel ({args.xp:g}, {args.zp:g}): h = {summary['h']:.4g} s "
        f"({args.fraction:g} x eq-9 bound {bound['absolute']:.4g} s), {summary['steps']} frames"
    )
    print(
        f"final depth {summary['final_truth']:.2f} {unit}; "
        f"last valid raw {summary['final_raw']:.2f}; "
        f"raw median relative error {summary['raw_median_rel_error']:.3f}"
    )
    for key, v in summary["filtered"].items():
        print(
            f"low-pass tau {key} s: final {v['final']:.2f} "
            f"({100 * v['final_rel_error']:+.1f}%), max error over the last "
            f"{summary['tail_window']:g} s {100 * v['tail_max_rel_error']:.1f}%"
        )
    print(f"results written to {out}/")
    return 0


def cmd_degrees(args: argparse.Namespace) -> int:
    from rangefx import api

    result = api.degrees(
        args.scene, variant=args.variant, order=args.order, size=args.size, seed=args.seed
    )
    if args.out:
        result.write(args.out)
    if args.json:
        print(json.dumps(result.to_dict()))
        return 0
    scene = result.scene
    for name, per_degree in result.summary["settings"].items():
        print(f"## {scene.name}, {args.variant} estimator, {name}")
        print(
            report.format_side_by_side(
                {f"degree {v['degree']} (order {v['estimator_order']})": v["table"]
                 for v in per_degree.values()},
                scene.unit,
            )
        )  # fmt: skip
        for v in per_degree.values():
            print(
                f"degree {v['degree']}: valid fraction {v['valid_fraction']:.3f}, median "
                f"relative error {v['median_rel_error']:.4f} (on the {v['common_pixels']} "
                f"pixels valid for every degree: {v['common_median_rel_error']:.4f})"
            )
        print()
    return 0


# --------------------------------------------------------------------------- parser


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``track`` and ``degrees`` on the ``rangefx`` subparsers."""
    p = sub.add_parser("track", help="G1: range by irradiance tracking on the ch. 2 scene")
    p.add_argument("--out", type=out_path, default="rangefx-track", help="output directory")
    p.add_argument("--xp", type=float, default=40.0, help="pixel x_p from the centre (right)")
    p.add_argument("--zp", type=float, default=30.0, help="pixel z_p from the centre (up)")
    p.add_argument("--duration", type=float, default=5.0, help="simulated time, s")
    p.add_argument(
        "--fraction", type=float, default=0.1, help="frame interval / eq-9 bound (default 0.1)"
    )
    p.add_argument(
        "--tau", type=float, nargs="+", default=[0.1, 0.4], help="low-pass time constants, s"
    )
    p.add_argument(
        "--threshold", type=float, default=0.1, help="min |h dE_M/dt|, grey levels per frame"
    )
    p.add_argument("--noise", type=float, default=0.0, help="sensor noise sigma, grey levels")
    p.add_argument("--seed", type=int, default=0, help="noise seed")
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_track)

    p = sub.add_parser("degrees", help="G3 ranging polynomial of degree 1..4 on a scene")
    p.add_argument("--scene", default="lab", choices=SCENE_NAMES, help="scene preset")
    p.add_argument("--variant", default="consistent", choices=("paper", "consistent"))
    p.add_argument(
        "--order",
        type=int,
        choices=(1, 2, 3, 4),
        help="estimator order for every degree (default: both order = degree and order 4)",
    )
    p.add_argument(
        "--size",
        type=int_at_least(8, "image size"),
        nargs=2,
        metavar=("H", "W"),
        help="render size",
    )
    p.add_argument("--seed", type=int, default=0, help="scene noise seed")
    p.add_argument("--out", type=out_path, help="also write table.md and summary.json here")
    p.add_argument("--json", action="store_true", help="print one JSON object with the figures")
    p.set_defaults(func=cmd_degrees)


if __name__ == "__main__":  # pragma: no cover
    sys.exit("use `rangefx track` or `rangefx degrees`")
