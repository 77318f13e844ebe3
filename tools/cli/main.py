"""The ``rangefx`` command line (SPEC §8): a thin argparse dispatch, one module per
subcommand.

Every command that reports figures takes ``--json`` and then prints one JSON object on
stdout. User mistakes print one ``rangefx: error: ...`` line and exit with status 2; no
output directory is left looking complete after a failure. SIGINT, SIGTERM and SIGHUP
print one line and exit with 128 + the signal (:mod:`rangefx.tools.interrupts`); an
output directory has one writer at a time (:mod:`rangefx.tools.report.lock`).
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import signal
import sys
from collections.abc import Iterator, Sequence
from types import ModuleType

from ..errors import UserError
from ..interrupts import (
    Interrupted,
    exit_now,
    handle_stop_signals,
    pending_signal,
    raise_if_interrupted,
    set_stop_line,
)

__all__ = ["DIR_OUTPUT_COMMANDS", "EXIT_INTERRUPTED", "build_parser", "main"]


def _commands() -> tuple[ModuleType, ...]:
    """Subcommand modules, in ``--help`` order; each has ``add_parser(sub)``. Imported
    when needed, after the signal handlers are in place: the imports (numba, matplotlib)
    take about a second, and a Ctrl-C or ``kill`` then is handled as at any other time."""
    from . import bench, config, demo, eval, guide, hdl, run, sweep, track, vectors

    return (demo, run, config, bench, vectors, hdl, sweep, eval, track, guide)


def build_parser() -> argparse.ArgumentParser:
    from .demo import package_version

    parser = argparse.ArgumentParser(
        prog="rangefx",
        description="Bit-accurate, cycle-faithful models of FPGA ranging pipelines "
        "(NASA 1991 report), their golden models, test vectors and word-length studies",
    )
    parser.add_argument("--version", action="version", version=f"rangefx {package_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in _commands():
        module.add_parser(sub)
    return parser


#: Commands whose ``--out`` is an output directory (``atomic_output_dir``): checked for
#: writability and locked (with ``sweep``'s) before the work starts.
DIR_OUTPUT_COMMANDS = {"demo", "run", "guide", "track", "degrees", "optimise", "vectors gen"}
#: Exit status after Ctrl-C, as a shell reports SIGINT (128 + 2); SIGTERM and SIGHUP
#: exit with 128 + their number likewise (:mod:`rangefx.tools.interrupts`).
EXIT_INTERRUPTED = 128 + signal.SIGINT


def _command_name(args: argparse.Namespace) -> str:
    sub = getattr(args, "vectors_command", None)
    return f"{args.command} {sub}" if args.command == "vectors" and sub else args.command


@contextlib.contextmanager
def _output_locked(args: argparse.Namespace) -> Iterator[None]:
    """Check and lock the command's output directory, if it writes one, for the whole
    run (docs/guarantees.md): a second writer is refused before any work."""
    name = _command_name(args)
    out = getattr(args, "out", None)
    if not out or (name not in DIR_OUTPUT_COMMANDS and name != "sweep"):
        yield
        return
    from ..report.lock import output_lock
    from ..report.outdir import check_output_dir

    if name != "sweep":
        check_output_dir(out)
    with output_lock(out):
        yield


def _interrupted_message(args: argparse.Namespace | None, exc: BaseException) -> str:
    if getattr(exc, "output_in_place", None):
        return f"interrupted after the output was put in place in {exc.output_in_place}"
    if args is not None and args.command == "sweep":
        return "interrupted; finished points are saved: re-run the same command to resume"
    return "interrupted; no output was written (an earlier output is left as it was)"


def main(argv: Sequence[str] | None = None) -> int:
    restore = handle_stop_signals(watchdog=argv is None)
    args = None
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        set_stop_line(_interrupted_message(args, KeyboardInterrupt()))
        # the ~175,000 objects of the imports (numba's most of them) are permanent: kept
        # out of the collector, whose passes over them took ~5 % of a model run
        # (measured: P1 paper, one thread, 49.1 -> 46.5-47.3 ns/pixel median;
        # docs/performance.md)
        gc.freeze()
        with _output_locked(args):
            status = args.func(args)
            raise_if_interrupted()  # one a finaliser swallowed ends the command all the same
        return status
    except UserError as exc:
        if pending_signal() is not None:  # the error came from the interrupted work
            return _report_interrupt(args, Interrupted(pending_signal()), argv is None)
        print(f"rangefx: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        return _report_interrupt(args, exc, argv is None)
    except Exception:
        # an interrupt inside an extension's import comes out as an ImportError (seen in
        # 1 of 50 SIGHUPs to "rangefx demo"): any failure after a stop signal is the stop
        if pending_signal() is None:
            raise
        return _report_interrupt(args, Interrupted(pending_signal()), argv is None)
    finally:
        restore()


def _report_interrupt(args: argparse.Namespace | None, exc: BaseException, as_program: bool) -> int:
    """Print the one line; as the program (not called from Python with ``argv``) end the
    process now (:func:`~rangefx.tools.interrupts.exit_now`): the cleanup is done."""
    signum = exc.signum if isinstance(exc, Interrupted) else (pending_signal() or signal.SIGINT)
    with contextlib.suppress(OSError):  # SIGHUP: the terminal may be gone
        print(f"\nrangefx: {_interrupted_message(args, exc)}", file=sys.stderr)
    if as_program:
        exit_now(128 + signum)
    return 128 + signum


if __name__ == "__main__":
    sys.exit(main())
