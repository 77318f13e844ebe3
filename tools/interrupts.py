"""SIGINT, SIGTERM and SIGHUP all stop a command the way Ctrl-C does (docs/guarantees.md).

:func:`handle_stop_signals` installs one handler for the three: it records the signal
and raises :class:`Interrupted` (a ``KeyboardInterrupt``), so every ``finally`` and
context manager that cleans up after Ctrl-C (temporary siblings, the sweep's points in
flight, the output lock) does so for ``kill`` and a closed terminal too, and the command
line exits with 128 + the signal's number, as a shell reports it.

Python raises a signal handler's exception in whatever the main thread runs at that
moment; if that is a finaliser (``__del__``) or a weakref callback, the interpreter
prints "Exception ignored in ... KeyboardInterrupt" and carries on, so an interrupt can
be lost (seen once in 28 Ctrl-C of ``rangefx demo``, which then wrote its output and
exited 0). The recorded signal makes that deterministic: :func:`raise_if_interrupted`
at the points of no return (before an output directory is put in place, before a sweep
writes its summary) and the command line at its end raise it again.
"""

from __future__ import annotations

import contextlib
import faulthandler
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from types import FrameType

__all__ = [
    "STOP_SIGNALS",
    "STUCK_DUMP_ENV",
    "WATCHDOG_S",
    "Interrupted",
    "claim_the_end",
    "cleanup_if_stuck",
    "deferred_signals",
    "exit_now",
    "handle_stop_signals",
    "ignore_stop_signals_at_exit",
    "numba_compiling",
    "pending_signal",
    "raise_if_interrupted",
    "set_stop_line",
]

#: The signals handled as Ctrl-C is (those that exist on this platform).
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)


class Interrupted(KeyboardInterrupt):
    """A stop signal arrived; ``signum`` is its number (``SIGINT`` for a plain Ctrl-C)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


_pending: list[int] = []  # the first stop signal received, if any
_deferring: list[int] = []  # depth of deferred_signals() blocks; signals wait meanwhile
_deferred: list[int] = []  # signals received inside such a block


def pending_signal() -> int | None:
    """The number of the first stop signal received since :func:`handle_stop_signals`."""
    return _pending[0] if _pending else None


def raise_if_interrupted() -> None:
    """Raise :class:`Interrupted` if a stop signal arrived, even one whose exception a
    finaliser swallowed; call it before anything that cannot be undone."""
    if _pending:
        raise Interrupted(_pending[0])


#: Seconds after a stop signal at which the watchdog ends a command that is still running
#: (the issue's bound is 2 s; cleanup normally takes well under 0.1 s).
WATCHDOG_S = 1.5
#: A file the watchdog appends every thread's stack to before it ends a stuck command.
STUCK_DUMP_ENV = "RANGEFX_STUCK_DUMP"
_watchdog: list[bool] = [False]  # armed by handle_stop_signals(watchdog=True)
_stop_line: list[str] = ["interrupted; no output was written (an earlier output is left as it was)"]
_cleanups: dict[int, Callable[[], None]] = {}


def set_stop_line(text: str) -> None:
    """The line (after ``rangefx: ``) the watchdog prints for this command."""
    _stop_line[0] = text


@contextlib.contextmanager
def cleanup_if_stuck(cleanup: Callable[[], None]) -> Iterator[None]:
    """Register ``cleanup`` (removing a temporary directory) for the watchdog to run if
    the command is stuck after a stop signal, for the ``with`` body."""
    key = id(cleanup)
    _cleanups[key] = cleanup
    try:
        yield
    finally:
        _cleanups.pop(key, None)


def _end_if_stuck(signum: int, install: int) -> None:
    """The watchdog: a command that has not ended :data:`WATCHDOG_S` after a stop signal
    waits on something that will not come (a worker thread stuck behind a lock the
    interrupted main thread held; one ``demo`` of 108 hung so, > 60 s). Its temporary
    directories are removed, the line is printed, and the process ends with 128 + the
    signal; its lock dies with it (``flock``)."""
    time.sleep(WATCHDOG_S)
    if _installs[0] != install or not claim_the_end():
        return  # the command ended (or, in-process, returned) or is printing its line
    dump = os.environ.get(STUCK_DUMP_ENV)
    if dump:  # where every thread waits, for the cause (tests/test_confinement.py sets it)
        with contextlib.suppress(Exception), open(dump, "a") as fh:
            faulthandler.dump_traceback(fh, all_threads=True)
    for cleanup in list(_cleanups.values()):
        with contextlib.suppress(Exception):
            cleanup()
    with contextlib.suppress(Exception):
        print(f"\nrangefx: {_stop_line[0]}", file=sys.stderr)
    exit_now(128 + signum)


def numba_compiling() -> bool:
    """Whether the calling thread holds numba's compiler lock: it is compiling a kernel or
    loading one from the cache (an ``@njit`` with a signature does so on import). An
    exception raised in there can leave numba's and LLVM's state half-made, and a later
    kernel call crash the process (numba issue #2324: "sometimes gives a segmentation
    fault"; one ``sweep`` of 50 ended by SIGSEGV on SIGHUP); False if numba is not loaded."""
    compiler_lock = sys.modules.get("numba.core.compiler_lock")
    if compiler_lock is None:
        return False
    try:
        return bool(compiler_lock.global_compiler_lock.is_locked())
    except Exception:  # another numba's internals: act on the signal as before
        return False


#: Seconds between looks at whether the main thread has left numba's compiler.
COMPILE_POLL_S = 0.02


_ending: list[threading.Lock] = [threading.Lock()]  # renewed by handle_stop_signals()


def claim_the_end() -> bool:
    """True for the first caller since :func:`handle_stop_signals` only: the one that
    prints the stop line and ends the command, the command's own report or the watchdog
    (both printed it once, a command reporting just as the watchdog woke up)."""
    return _ending[0].acquire(blocking=False)


def _on_signal(signum: int, frame: FrameType | None) -> None:
    if not _pending:
        _pending.append(signum)
        if _watchdog[0]:
            threading.Thread(
                target=_end_if_stuck, args=(signum, _installs[0]), name="rangefx-watchdog",
                daemon=True,
            ).start()  # fmt: skip
    if _deferring:
        _deferred.append(signum)
        return
    if numba_compiling():  # raised once the compile or cache load is over (the watchdog
        # still ends the command 1.5 s after the signal if it is not)
        timer = threading.Timer(COMPILE_POLL_S, _redeliver, (signum, _installs[0]))
        timer.daemon = True
        timer.start()
        return
    raise Interrupted(signum)


@contextlib.contextmanager
def deferred_signals() -> Iterator[None]:
    """Let a stop signal wait until the ``with`` body is done, then raise it: for work
    that must not be cut in two (removing a temporary directory, putting an output in
    place). A flag, not a signal mask: the handler runs in the main thread whichever
    thread the kernel delivered the signal to."""
    _deferring.append(1)
    try:
        yield
    finally:
        _deferring.pop()
        if not _deferring and _deferred:
            signum = _deferred[0]
            _deferred.clear()
            raise Interrupted(signum)


_installs = [0]  # counts handle_stop_signals() calls and restores


def _redeliver(signum: int, install: int) -> None:
    """The signal again, to the main thread: a real one (``pthread_kill``), which also
    wakes a main thread asleep in a wait, as the first did (``_thread.interrupt_main``
    only flags it for the next bytecode)."""
    # only while rangefx's handler is the one in place: a SIGTERM after restore() would
    # end the (test) process
    if _installs[0] == install and signal.getsignal(signum) is _on_signal:
        signal.pthread_kill(threading.main_thread().ident, signum)


def handle_stop_signals(watchdog: bool = False) -> Callable[[], None]:
    """Install the handler for :data:`STOP_SIGNALS` (main thread only; elsewhere a no-op)
    and forget any earlier signal; returns a function that restores the earlier handlers.
    ``watchdog``: as the program, end the process :data:`WATCHDOG_S` after a stop signal
    if it has not ended by then (:func:`_end_if_stuck`)."""
    _pending.clear()
    _deferred.clear()
    _installs[0] += 1
    _ending[0] = threading.Lock()
    _watchdog[0] = watchdog
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    earlier = {s: signal.signal(s, _on_signal) for s in STOP_SIGNALS}
    earlier_hook = sys.unraisablehook

    def quiet(unraisable: sys.UnraisableHookArgs) -> None:
        # a finaliser swallowed the interrupt: deliver it again, to be raised at the main
        # thread's next instruction (Python's "Exception ignored in ..." lines would only
        # break the one-line message)
        if isinstance(unraisable.exc_value, Interrupted):  # from another thread, a moment
            # later: raised here, inside the finaliser, it would be swallowed again
            signum = unraisable.exc_value.signum
            redeliver = threading.Timer(0.05, _redeliver, (signum, _installs[0]))
            redeliver.daemon = True
            redeliver.start()
        else:
            earlier_hook(unraisable)

    sys.unraisablehook = quiet

    def restore() -> None:
        _installs[0] += 1  # a redelivery still on its way is for a command that is over
        for s, h in earlier.items():
            signal.signal(s, h)
        sys.unraisablehook = earlier_hook

    return restore


def ignore_stop_signals_at_exit() -> None:
    """After a command has ended (its output in place or its error printed), as the
    program: :data:`STOP_SIGNALS` are ignored while the interpreter exits, so the process
    ends with the command's status. A Python handler would not do: Python's finalisation
    resets every signal with a Python handler to the default action before it tears the
    modules down (seconds under load), and a SIGTERM or SIGHUP then killed a `sweep` whose
    results were complete (exit -15 / -1, no line). Main thread only."""
    if threading.current_thread() is not threading.main_thread():
        return
    _installs[0] += 1  # a redelivery still on its way is for a command that is over
    for s in STOP_SIGNALS:
        signal.signal(s, signal.SIG_IGN)


def exit_now(status: int) -> None:
    """End the process with ``status`` at once, after flushing stdout and stderr.

    For the command line after an interrupt, once its cleanup is done (temporaries
    removed, the lock released, the line printed). Python's own exit first joins every
    pool thread (one in the middle of a scene render or a sweep point held it seconds)
    and then tears the interpreter down, which took 0.8 s and more after a ``vectors
    gen`` (a stack dump showed no Python frame): neither has anything left to do for a
    stopped command."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(status)
