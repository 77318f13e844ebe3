"""``rangefx sweep`` and

Its module imports no model, no pipeline registry and no numpy: a definition of more
than ``--max-points`` points is refused from a light count of its TOML
(:func:`rangefx.tools.sweepbound.precheck_definition`) before the models load.
"""

from __future__ import annotations

import argparse
import json

from ..errors import UserError
from ..sweepbound import MAX_POINTS, SWEEP_SECONDS_PER_PIXEL, precheck_definition
from .argtypes import int_at_least, out_path

_positive_int = int_at_least(1)

__all__ = ["SWEEP_SECONDS_PER_PIXEL", "add_parser", "cmd_sweep"]


def cmd_sweep(args: argparse.Namespace) -> int:
    if args.example:
        from ..studies.sweepdir import example_path

        print(example_path())
        return 0
    if not args.definition or not args.out:
        raise UserError("sweep needs a definition file and --out DIR (or --example)")
    # before the models load (numba's first cache load: 1-2.6 s)
    precheck_definition(args.definition, args.max_points, 1 if args.scheduler else args.workers)
    from rangefx import api

    from ..report import json_safe

    result = api.sweep(
        args.definition, args.out, workers=args.workers, scheduler=args.scheduler,
        max_points=args.max_points, restart=args.restart, cost=args.cost,
        progress=not args.json,
    )  # fmt: skip
    summary = result.summary
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        print(
            f"sweep {result.definition.name!r}: {summary['n_points']} points ({summary['n_ok']} "
            f"ran, {summary['n_invalid']} invalid configs), {summary['computed_this_run']} "
            f"computed now in {summary['wall_seconds_this_run']:.1f} s; results in {result.out}"
        )
        for scene, front in summary["pareto"].items():
            print(f"Pareto front on {scene}: {len(front)} configs")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sweep", help="word-length sweep of any pipeline (resumable, local or dask)")
    p.add_argument("definition", nargs="?", help="sweep definition TOML")
    p.add_argument(
        "--out", type=out_path, help="output directory (re-run the same command to resume)"
    )
    p.add_argument("--scheduler", help="address of a dask.distributed scheduler")
    p.add_argument("--workers", type=_positive_int, default=2, help="local threads (default 2)")
    p.add_argument("--example", action="store_true", help="print the example definition's path")
    p.add_argument("--cost", choices=("proxy", "synth"), default="proxy",
                   help="cost axis of the Pareto fronts: proxy (cost_bits, default) or synth "
                   "(Yosys xcup LUT + FF of the pipeline's RTL per point, P1 or P2, cached; "
                   "adds the synth metrics)")  # fmt: skip
    p.add_argument(
        "--restart", action="store_true",
        help="delete the results of an earlier sweep in --out (another definition) and start over",
    )  # fmt: skip
    p.add_argument(
        "--max-points", type=_positive_int, default=MAX_POINTS,
        help=f"refuse a sweep of more points (default {MAX_POINTS})",
    )  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(func=cmd_sweep)
