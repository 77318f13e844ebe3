"""One writer per output directory: a lock file beside it (docs/guarantees.md).

Two rangefx runs writing one output directory at once lose results (a ``sweep --restart``
deleted the ``results.jsonl`` another sweep was appending to; two identical sweeps
computed every point twice). Every command that writes an output directory therefore
holds :func:`output_lock` on it for the whole run; a second writer is refused with one
line naming the holder.

The lock is ``.<name>.rangefx-lock`` in the directory's parent (the directory itself may
not exist yet; it is put in place by a rename), held with ``flock``: the kernel releases
it when its process ends however it ends (SIGKILL included), so a lock file left by a
killed run is stale by construction and the next run simply takes it; no PID test, no
race between two runs that both find it stale. The file holds the holder's PID, host and
command, for the refusal message only. The lock is keyed by the directory's real path,
so ``--out link`` and ``--out target`` of a symbolic link are one directory. It is
re-entrant within a process (the command line takes it before the work, the writer of
the output directory again at the end).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import os
import socket
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from ..errors import UserError
from ..interrupts import cleanup_if_stuck

__all__ = ["LOCK_SUFFIX", "hidden_stem", "lock_path", "output_lock"]

LOCK_SUFFIX = ".rangefx-lock"
"""The lock of output directory ``D`` is ``.<D's name>`` + this, in ``D``'s parent."""

_HELD: dict[Path, int] = {}  # lock file -> depth, for re-entry within this process
_HELD_LOCK = threading.Lock()


def hidden_stem(name: str) -> str:
    """``name`` as the stem of a hidden sibling ``.<stem>.<suffix>`` (a temporary
    directory, a lock): ``name`` itself, or for a name longer than 200 characters a
    prefix and a digest of it, so that the sibling's name stays within the 255 bytes a
    file name may have (a valid ``--out`` of 236-255 characters was refused)."""
    if len(name.encode("utf-8", "surrogateescape")) <= 200:
        return name
    digest = hashlib.sha256(name.encode("utf-8", "surrogateescape")).hexdigest()[:12]
    return name.encode("utf-8", "surrogateescape")[:160].decode("utf-8", "ignore") + "~" + digest


def lock_path(directory: str | os.PathLike[str]) -> Path:
    """The lock file of output directory ``directory`` (by its real path)."""
    real = Path(os.path.realpath(directory))
    return real.parent / f".{hidden_stem(real.name)}{LOCK_SUFFIX}"


def _holder_text(lock: Path) -> str:
    try:
        with open(lock, encoding="utf-8", errors="replace") as f:
            fields = dict(line.split("=", 1) for line in f.read(4096).splitlines() if "=" in line)
    except OSError:
        fields = {}
    if "pid" not in fields:
        return "another rangefx run"
    since = fields.get("since", "?")
    return (
        f"another rangefx run (PID {fields['pid']} on host {fields.get('host', '?')}, "
        f"`{fields.get('command', '?')}`, since {since})"
    )


def _acquire(lock: Path, shown: str) -> int:
    """Open and ``flock`` ``lock``, retrying if the file was replaced meanwhile; the fd."""
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise UserError(
                f"cannot lock output directory {shown!r}: {lock}: {exc.strerror}"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise UserError(
                    f"output directory {shown!r} is being written by {_holder_text(lock)}; "
                    "wait for it to finish or choose another --out"
                ) from None
            raise UserError(f"cannot lock output directory {shown!r}: {exc.strerror}") from None
        # the holder we waited for may have unlinked the file as it released it: a lock
        # on an unlinked inode excludes nobody, so take the file that is there now
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(lock, follow_symlinks=False))
        except OSError:
            same = False
        if same:
            return fd
        os.close(fd)


@contextlib.contextmanager
def output_lock(directory: str | os.PathLike[str], command: str | None = None) -> Iterator[Path]:
    """Hold the lock of output directory ``directory`` for the ``with`` body.

    Yields the lock file's path. The lock file is created in the parent (created if
    missing), written with this process's PID, host name, ``command`` (default: the
    command line) and start time, and removed on release; a lock file left by a killed
    run is taken over (its ``flock`` died with it).

    Raises
    ------
    UserError
        Another process holds the lock (the message names its PID, host and command), or
        the lock file cannot be created.
    """
    lock = lock_path(directory)
    shown = str(directory)
    with _HELD_LOCK:
        if lock in _HELD:
            _HELD[lock] += 1
            reentered = True
        else:
            reentered = False
    if reentered:
        try:
            yield lock
        finally:
            with _HELD_LOCK:
                _HELD[lock] -= 1
        return
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"cannot write output directory {shown!r}: {exc.strerror}") from None
    fd = _acquire(lock, shown)
    try:
        text = (
            f"pid={os.getpid()}\nhost={socket.gethostname()}\n"
            f"command={command or ' '.join(['rangefx', *sys.argv[1:]])}\n"
            f"since={time.strftime('%Y-%m-%d %H:%M:%S %Z')}\n"
        )
        os.ftruncate(fd, 0)
        os.pwrite(fd, text.encode("utf-8", "replace"), 0)
        with _HELD_LOCK:
            _HELD[lock] = 1
        try:
            # a command the watchdog ends (its main thread inside a long kernel, where no
            # signal handler runs) leaves no lock file: its flock dies with it, the file
            # would not (`vectors gen` on lab, SIGHUP ~3.5 s in: the lock file stayed)
            with cleanup_if_stuck(lambda: os.unlink(lock)):
                yield lock
        finally:
            with _HELD_LOCK:
                del _HELD[lock]
            # unlink while still holding it: a waiter that opened this inode re-checks
            # the path after its flock and starts over on the new file
            with contextlib.suppress(OSError):
                os.unlink(lock)
    finally:
        os.close(fd)
