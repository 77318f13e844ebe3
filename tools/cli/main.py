"""The ``rangefx`` command line (SPEC §8): a thin argparse dispatch, one module per
subcommand.

Every command that reports figures takes ``--json`` and then prints one JSON object on
stdout. User mistakes print one ``rangefx: error: ...`` line and exit with status 2; no
output directory is left looking complete after a failure.
"""

from __future__ import annotations

import argparse
import gc
import sys
from collections.abc import Sequence

from ..errors import UserError
from ..report.outdir import check_output_dir
from . import bench, config, demo, eval, guide, hdl, run, sweep, track, vectors

__all__ = ["DIR_OUTPUT_COMMANDS", "EXIT_INTERRUPTED", "build_parser", "main"]

#: Subcommand modules, in ``--help`` order; each has ``add_parser(sub)``.
COMMANDS = (demo, run, config, bench, vectors, hdl, sweep, eval, track, guide)


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


#: Commands whose ``--out`` is an output directory (``atomic_output_dir``): checked for
#: writability before the work starts.
DIR_OUTPUT_COMMANDS = {"demo", "run", "guide", "track", "degrees", "optimise", "vectors gen"}
#: Exit status after Ctrl-C, as a shell reports SIGINT (128 + 2).
EXIT_INTERRUPTED = 130


def _command_name(args: argparse.Namespace) -> str:
    sub = getattr(args, "vectors_command", None)
    return f"{args.command} {sub}" if args.command == "vectors" and sub else args.command


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    # the ~175,000 objects of the imports (numba's most of them) are permanent: kept out of
    # the collector, whose passes over them took ~5 % of a model run (measured: P1 paper,
    # one thread, 49.1 -> 46.5-47.3 ns/pixel median; docs/performance.md)
    gc.freeze()
    try:
        if _command_name(args) in DIR_OUTPUT_COMMANDS and getattr(args, "out", None):
            check_output_dir(args.out)
        return args.func(args)
    except UserError as exc:
        print(f"rangefx: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        if args.command == "sweep":
            msg = "interrupted; finished points are saved: re-run the same command to resume"
        else:
            msg = "interrupted; no output was written (an earlier output is left as it was)"
        print(f"\nrangefx: {msg}", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
