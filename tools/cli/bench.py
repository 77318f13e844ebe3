"""``rangefx bench``: pipeline throughput beside the float64 golden (SPEC §4)."""

from __future__ import annotations

import argparse
import json

from ..errors import UserError
from ..report import json_safe
from ..studies.bench import bench_figures
from ..studies.runner import require_run_memory
from .options import add_pipelines_arg

__all__ = ["add_parser", "cmd_bench"]


def cmd_bench(args: argparse.Namespace) -> int:
    if args.repeats < 1 or args.size < 16:
        raise UserError("bench needs --repeats >= 1 and --size >= 16")
    require_run_memory(f"bench --size {args.size}", args.size * args.size)
    figures = bench_figures(repeats=args.repeats, size=args.size, names=args.pipeline)
    if args.json:
        print(json.dumps(json_safe(figures)))
    else:
        for k, v in figures.items():
            print(f"{k}: {v:.3f}" if isinstance(v, float) else f"{k}: {v}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="throughput of every pipeline (Mpixel/s) beside golden")
    p.add_argument("--repeats", type=int, default=5, help="timed runs per figure (median)")
    p.add_argument("--size", type=int, default=512, help="image side in pixels (default 512)")
    add_pipelines_arg(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_bench)
