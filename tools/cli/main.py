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
import importlib
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from typing import NoReturn

from ..errors import UserError
from ..interrupts import (
    Interrupted,
    claim_the_end,
    exit_now,
    handle_stop_signals,
    ignore_stop_signals_at_exit,
    pending_signal,
    raise_if_interrupted,
    set_stop_line,
)
from ..version import package_version

__all__ = [
    "COMMANDS",
    "DIR_OUTPUT_COMMANDS",
    "EXIT_INTERRUPTED",
    "build_parser",
    "command_of",
    "main",
    "package_version",
]


#: Every subcommand: its module (``rangefx.tools.cli.<module>``, whose ``add_parser(sub)``
#: adds it) and its one-line help, in ``--help`` order. The help is here so that
#: ``rangefx --help`` and a command's own run import no other command's module: those
#: import numba, SciPy and matplotlib (about a second), and a refusal (a sweep of 10^8
#: points) should not wait for them. ``tests/test_guarantees.py`` checks each line against
#: the module's own.
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("demo", "the main job on the lab scene: golden, P1, P2, P3, guidance"),
    "run": ("run", "one golden method, or a fixed-point pipeline beside golden"),
    "config": ("config", "a pipeline's word-length config: show, or propose"),
    "bench": ("bench", "throughput of every pipeline (Mpixel/s) beside golden"),
    "vectors": ("vectors", "hardware test vectors: gen, check, diff (SPEC §5)"),
    "hdl": ("hdl", "the Verilog of P1 and P2: vector replay, synthesis area, timing"),
    "sweep": ("sweep", "word-length sweep of any pipeline (resumable, local or dask)"),
    "optimise": ("optimise", "cheapest word lengths meeting an accuracy budget"),
    "eval": (
        "eval",
        "score G2, G3, G5, G6 (and OpenCV peers) on real stereo data with ground truth",
    ),
    "track": ("track", "G1: range by irradiance tracking on the ch. 2 scene"),
    "degrees": ("track", "G3 ranging polynomial of degree 1..4 on a scene"),
    "guide": ("guide", "fly the ch. 6 guidance: the avoiding law (default) or the report's"),
}


class _Parser(argparse.ArgumentParser):
    """argparse with one ``rangefx: error: ...`` line for a bad argument (docs/guarantees.md),
    not its usage block and a second error line; still ``SystemExit(2)``."""

    def error(self, message: str) -> NoReturn:
        where = self.prog.removeprefix("rangefx").strip()
        hint = f"; see rangefx {where} --help".replace("  ", " ") if where else ""
        self.exit(2, f"rangefx: error: {where + ': ' if where else ''}{message}{hint}\n")


def command_of(argv: Sequence[str]) -> str | None:
    """The subcommand ``argv`` names: its first word that is not an option (the top level
    has only ``--help`` and ``--version``, which take no value); None if there is none or
    it names no command (argparse then says so)."""
    word = next((a for a in argv if not a.startswith("-")), None)
    return word if word in COMMANDS else None


def build_parser(command: str | None = None, *, full: bool = True) -> argparse.ArgumentParser:
    """The ``rangefx`` parser. ``full``: every subcommand with all its options (imports
    every command module, as the docs' reference does); else only ``command``'s module is
    imported and the other subcommands are listed with their help line alone."""
    parser = _Parser(
        prog="rangefx",
        description="Bit-accurate, cycle-faithful models of FPGA ranging pipelines "
        "(NASA 1991 report), their golden models, test vectors and word-length studies",
    )
    parser.add_argument("--version", action="version", version=f"rangefx {package_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    if full:
        wanted = {module for module, _ in COMMANDS.values()}
    else:
        wanted = {COMMANDS[command][0]} if command else set()
    added: set[str] = set()
    for name, (module, text) in COMMANDS.items():
        if module in wanted:
            if module not in added:  # one module adds all its commands, in order
                importlib.import_module(f"{__package__}.{module}").add_parser(sub)
                added.add(module)
        else:
            sub.add_parser(name, help=text, add_help=False)
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
    if getattr(exc, "stop_line", None):  # the command says what it kept (guide --stress)
        return exc.stop_line
    if getattr(exc, "output_in_place", None):
        return f"interrupted after the output was put in place in {exc.output_in_place}"
    if args is not None and args.command == "sweep":
        return "interrupted; finished points are saved: re-run the same command to resume"
    return "interrupted; no output was written (an earlier output is left as it was)"


def main(argv: Sequence[str] | None = None) -> int:
    restore = handle_stop_signals(watchdog=argv is None)
    args = None
    try:
        words = sys.argv[1:] if argv is None else list(argv)
        # only the named command's module is imported (a refusal does not wait for the
        # others' numba, SciPy and matplotlib), after the handlers are in place
        args = build_parser(command_of(words), full=False).parse_args(words)
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
        if argv is None:
            # as the program, the command is over: a stop signal while the interpreter
            # exits no longer stops anything (ignore_stop_signals_at_exit)
            ignore_stop_signals_at_exit()


def _report_interrupt(args: argparse.Namespace | None, exc: BaseException, as_program: bool) -> int:
    """Print the one line; as the program (not called from Python with ``argv``) end the
    process now (:func:`~rangefx.tools.interrupts.exit_now`): the cleanup is done."""
    signum = exc.signum if isinstance(exc, Interrupted) else (pending_signal() or signal.SIGINT)
    if not claim_the_end():  # the watchdog woke up first: it prints the line and ends
        threading.Event().wait()
    with contextlib.suppress(OSError):  # SIGHUP: the terminal may be gone
        print(f"\nrangefx: {_interrupted_message(args, exc)}", file=sys.stderr)
    if as_program:
        exit_now(128 + signum)
    return 128 + signum


if __name__ == "__main__":
    sys.exit(main())
