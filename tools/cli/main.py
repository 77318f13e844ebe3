"""The ``rangefx`` command line (SPEC §8): a thin argparse dispatch, one module per
subcommand.

Every command that reports figures takes ``--json`` and then prints one JSON object on
stdout. User mistakes print one ``rangefx: error: ...`` line and exit with status 2; no
output directory is left looking complete after a failure.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ..errors import UserError
from . import bench, config, demo, eval, guide, run, sweep, track, vectors

__all__ = ["build_parser", "main"]

#: Subcommand modules, in ``--help`` order; each has ``add_parser(sub)``.
COMMANDS = (demo, run, config, bench, vectors, sweep, eval, track, guide)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rangefx",
        description="Bit-accurate, cycle-faithful models of FPGA ranging pipelines "
        "(NASA 1991 report), their golden models, test vectors and word-length studies",
    )
    parser.add_argument("--version", action="version", version=f"rangefx {demo.package_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in COMMANDS:
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except UserError as exc:
        print(f"rangefx: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
