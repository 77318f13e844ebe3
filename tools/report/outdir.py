"""Atomic writes of output files and output directories.

A result is either complete or absent: files are written to a temporary name in the
destination directory, flushed to disk and renamed into place; an output directory is
filled under a temporary name and put in place only when the work succeeded (SPEC §8:
"never a partial output presented as complete"). A file that rangefx did not write is
never deleted or overwritten (docs/guarantees.md).
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path

from ..errors import UserError
from ..interrupts import (
    Interrupted,
    cleanup_if_stuck,
    deferred_signals,
    raise_if_interrupted,
)
from .lock import hidden_stem, output_lock

__all__ = [
    "MARKER_NAME",
    "atomic_output_dir",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output_dir",
    "check_output_file",
    "refuse_links",
    "remove_leftovers",
]

MARKER_NAME = ".rangefx-output"
"""File that marks a directory as written by rangefx, hence safe to replace."""

_MARKER_TEXT = (
    "This directory was written by rangefx. A re-run replaces or removes only the files\n"
    "listed below; any other file in it is yours and is never touched.\n"
)


def _sibling_name(path: Path, kind: str) -> Path:
    return path.parent / f".{hidden_stem(path.name)}.{kind}-{os.getpid()}-{secrets.token_hex(4)}"


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc) or type(exc).__name__


def _fsync_dir(directory: Path) -> None:
    """Flush a directory entry to disk where the platform allows it (POSIX)."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the new one, never a part.

    The bytes go to a temporary file in the same directory (``.<name>.tmp-<pid>-<random>``),
    which is fsynced and then renamed over ``path`` with :func:`os.replace`. On any error
    the temporary file is removed and ``path`` is left as it was. The new file gets the
    usual permissions (``0o666`` less the umask).

    Parameters
    ----------
    path
        Destination file; its directory must exist.
    data
        The complete new contents.
    """
    path = Path(path)
    tmp = _sibling_name(path, "tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_dir(path.parent)


def atomic_write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically; see :func:`atomic_write_bytes`.

    Parameters
    ----------
    path
        Destination file; its directory must exist.
    text
        The complete new contents, written with ``\\n`` line ends as given.
    encoding
        Text encoding, UTF-8 by default.
    """
    atomic_write_bytes(path, text.encode(encoding))


def _is_ours(path: Path) -> bool:
    marker = path / MARKER_NAME
    return marker.is_file() and not marker.is_symlink()


def _marker_text(files: list[str], state: str = "complete") -> str:
    return _MARKER_TEXT + f"state: {state}\n" + "".join(f"file: {f}\n" for f in files)


def _plain_inside(entry: str) -> bool:
    """A marker entry rangefx may act on: a relative path of plain names, no ``..``."""
    parts = entry.split("/")
    return (
        bool(entry)
        and not entry.startswith("/")
        and all(p not in ("", ".", "..") and "\\" not in p and "\0" not in p for p in parts)
    )


def _symlink_on_the_way(root: Path, entry: str) -> str | None:
    """The first component of ``entry`` below ``root`` that is a symbolic link, if any."""
    here = root
    for part in entry.split("/"):
        here = here / part
        if here.is_symlink():
            return str(here.relative_to(root))
    return None


_REPORTED: set[Path] = set()  # markers whose foreign entries were reported in this process


def _own_files(path: Path) -> set[str] | None:
    """Files (relative paths) an earlier rangefx run listed in ``path``'s marker; ``None``
    for a marker written before the marker listed them.

    The marker is a file in a folder others can write: an entry that is not a plain
    relative path inside ``path`` (absolute, ``..``) is never acted on, and is reported
    once on stderr (a ``file: ../precious.txt`` line once deleted a file outside)."""
    try:
        text = (path / MARKER_NAME).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    lines = text.splitlines()
    if not any(line.startswith("state: ") for line in lines):
        return None
    entries = {line[len("file: ") :] for line in lines if line.startswith("file: ")}
    foreign = sorted(e for e in entries if not _plain_inside(e))
    if foreign and path not in _REPORTED:
        _REPORTED.add(path)
        print(
            f"rangefx: warning: {path / MARKER_NAME} lists {len(foreign)} entries outside "
            f"{str(path)!r} ({', '.join(repr(e) for e in foreign[:3])}"
            f"{', ...' if len(foreign) > 3 else ''}); rangefx did not write them there and "
            "leaves them alone",
            file=sys.stderr,
        )
    return {e for e in entries if _plain_inside(e) and e != MARKER_NAME}


def _files_under(root: Path) -> list[str]:
    return sorted(
        str(p.relative_to(root)) for p in root.rglob("*") if p.is_file() or p.is_symlink()
    )


def _refuse_link(path: Path, link: str) -> UserError:
    return UserError(
        f"output directory {str(path)!r} holds {link!r}, a symbolic link; rangefx never "
        "writes or deletes through a link inside an output directory (remove the link or "
        "choose another --out)"
    )


def refuse_links(directory: str | os.PathLike[str], names: Iterable[str]) -> None:
    """Raise :class:`UserError` if one of the files ``names`` that rangefx writes in place
    in ``directory`` (a sweep's ``results.jsonl``, appended to) is a symbolic link: it
    would write to wherever the link points."""
    directory = Path(directory)
    for name in names:
        if (directory / name).is_symlink():
            raise _refuse_link(directory, name)


def _real_dir(path: Path) -> Path:
    """``path``, or the directory it links to if it is a symbolic link the user made to one
    (the output directory itself may be a link; links inside it are refused)."""
    if path.name in ("", ".", ".."):
        return path.resolve()
    if path.is_symlink():
        if not path.is_dir():
            raise UserError(
                f"output path {str(path)!r} is a symbolic link to no directory; refusing to "
                "replace it"
            )
        return Path(os.path.realpath(path))
    return path


def _check_replaceable(path: Path) -> None:
    """Raise :class:`UserError` unless ``path`` is absent, empty, or a directory we wrote
    whose own files are reached without a symbolic link."""
    if path.is_symlink():
        raise UserError(f"output path {str(path)!r} is a symbolic link; refusing to replace it")
    if not path.exists():
        return
    if not path.is_dir():
        raise UserError(f"output path {str(path)!r} exists and is not a directory")
    if _is_ours(path):
        for f in sorted(_own_files(path) or ()):
            link = _symlink_on_the_way(path, f)
            if link is not None:
                raise _refuse_link(path, link)
        return
    if any(path.iterdir()):
        raise UserError(
            f"output directory {str(path)!r} is not empty and was not written by rangefx "
            f"(no {MARKER_NAME} file); refusing to overwrite it, choose another --out"
        )


_LEFTOVER = re.compile(r"^\.(?P<name>.+)\.(?:tmp|old)-(?P<pid>\d+)-[0-9a-f]{8}$")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True  # someone else's process, or unknowable: leave its directory alone
    return True


def remove_leftovers(path: str | os.PathLike[str]) -> list[Path]:
    """Delete the temporary siblings of ``path`` that a killed rangefx run left behind.

    Only directories and files named as :func:`atomic_output_dir` and
    :func:`atomic_write_bytes` name them (``.<name>.tmp-<pid>-<8 hex>``, ``.old-``) whose
    process is gone are removed: a live run's are left alone, and nothing else is touched.
    Returns what was removed.
    """
    path = Path(path)
    removed: list[Path] = []
    try:
        siblings = list(path.parent.iterdir())
    except OSError:
        return removed
    for p in siblings:
        m = _LEFTOVER.match(p.name)
        if m is None or m["name"] != hidden_stem(path.name) or _pid_alive(int(m["pid"])):
            continue
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                p.unlink()
        removed.append(p)
    return removed


def _merge(tmp: Path, path: Path) -> None:
    """Move ``tmp``'s files into the earlier rangefx output ``path``, keeping every file
    rangefx did not write there; stale files of the earlier run are removed."""
    new_files = [f for f in _files_under(tmp) if f != MARKER_NAME]
    own = _own_files(path)
    if own is None:  # an old-style marker: only the names this run writes are taken as ours
        own = {f for f in new_files if (path / f).is_file()}
    for f in new_files:
        link = _symlink_on_the_way(path, f)
        if link is not None:
            raise _refuse_link(path, link)
        target = path / f
        for parent in target.parents:
            if parent == path:
                break
            if parent.exists() and not parent.is_dir():
                raise UserError(
                    f"{str(parent)!r} is in the way of {f}; it was not written by rangefx"
                )
        if (target.exists() or target.is_symlink()) and (f not in own or target.is_dir()):
            raise UserError(
                f"output directory {str(path)!r} holds {f!r}, which rangefx did not write; "
                "refusing to overwrite it (move it away or choose another --out)"
            )
    # while files move the marker says "incomplete", and it lists old and new files so a
    # kill here leaves a directory the next run still recognises as its own
    atomic_write_text(path / MARKER_NAME, _marker_text(sorted(own | set(new_files)), "incomplete"))
    for f in sorted(own - set(new_files)):
        if _symlink_on_the_way(path, f) is not None:
            continue  # a link the user put there, or a path through one: not rangefx's file
        with contextlib.suppress(OSError):
            (path / f).unlink()
        for parent in (path / f).parents:
            if parent == path:
                break
            with contextlib.suppress(OSError):
                parent.rmdir()  # only if empty: a user's file keeps its folder
    for f in new_files:
        (path / f).parent.mkdir(parents=True, exist_ok=True)
        os.replace(tmp / f, path / f)
    atomic_write_text(path / MARKER_NAME, _marker_text(new_files))
    shutil.rmtree(tmp, ignore_errors=True)


def _commit(tmp: Path, path: Path) -> None:
    _check_replaceable(path)
    if not path.exists():
        os.replace(tmp, path)
        return
    if not _is_ours(path):
        os.rmdir(path)  # empty foreign directory: nothing to lose
        os.replace(tmp, path)
        return
    _merge(tmp, path)


def check_output_dir(path: str | os.PathLike[str]) -> None:
    """Fail early, before the long work, if :func:`atomic_output_dir` could not write ``path``.

    Raises
    ------
    UserError
        ``path`` is not replaceable (see :func:`atomic_output_dir`), or its parent cannot
        be created or written (read-only file system, no permission, immutable directory).
    """
    path = _real_dir(Path(path))
    _check_replaceable(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        probe = _sibling_name(path, "tmp")
        probe.mkdir()
        probe.rmdir()
        if path.is_dir():  # a merge writes into the directory itself
            probe = _sibling_name(path / MARKER_NAME, "tmp")
            probe.mkdir()
            probe.rmdir()
    except OSError as exc:
        raise UserError(f"cannot write output directory {str(path)!r}: {_reason(exc)}") from None


@contextlib.contextmanager
def atomic_output_dir(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Fill an output directory under a temporary name and put it in place on success.

    Yields a fresh, empty directory next to ``path`` (same parent, named
    ``.<name>.tmp-<pid>-<random>``). When the ``with`` body finishes normally, the marker
    file ``.rangefx-output`` (listing the files rangefx wrote) is written into it and:

    * ``path`` absent (or an empty directory): the temporary directory is renamed to it;
    * ``path`` a directory holding the marker (an earlier rangefx output): the new files
      are moved in, the earlier run's own files that this run did not write are removed,
      and every other file (one the user added) is kept. A file of the user's with the
      name of a new output file is never overwritten: :class:`UserError` naming it;
    * anything else (a file, a link to no directory, a non-empty directory without the
      marker, a symbolic link inside it on the way to a file rangefx wrote or writes):
      :class:`~rangefx.tools.errors.UserError` naming ``path``; user data is never
      deleted. This is checked before the body runs as well, so no work is wasted.

    ``path`` may itself be a symbolic link to a directory: the directory it points to is
    written. The body runs under :func:`~rangefx.tools.report.lock.output_lock` (one writer
    per output directory), and a stop signal during the final renames waits for them.

    If the body raises (including ``KeyboardInterrupt``), the temporary directory is
    deleted, ``path`` is left untouched and the exception propagates. An ``OSError``
    while writing (read-only file system, disk full) becomes a :class:`UserError`.
    Temporary directories of killed earlier runs are removed (:func:`remove_leftovers`).

    Parameters
    ----------
    path
        The output directory. Missing parent directories are created.

    Yields
    ------
    pathlib.Path
        The temporary directory to write results into.

    Raises
    ------
    UserError
        ``path`` exists and is not a replaceable rangefx output directory, or cannot be
        written.
    """
    path = _real_dir(Path(path))
    with output_lock(path):
        yield from _fill_and_commit(path)


def _fill_and_commit(path: Path) -> Iterator[Path]:
    _check_replaceable(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_leftovers(path)
    except OSError as exc:
        raise UserError(f"cannot write output directory {str(path)!r}: {_reason(exc)}") from None
    tmp = _sibling_name(path, "tmp")
    with cleanup_if_stuck(lambda: shutil.rmtree(tmp, ignore_errors=True)):
        yield from _fill(tmp, path)
    _fsync_dir(path.parent)


def _fill(tmp: Path, path: Path) -> Iterator[Path]:
    try:
        tmp.mkdir()  # inside the try: a signal right after it still removes it
        yield tmp
        raise_if_interrupted()  # an interrupt a finaliser swallowed still writes nothing
        atomic_write_text(tmp / MARKER_NAME, _marker_text(_files_under(tmp)))
        try:
            with deferred_signals():  # the output goes in place whole, or not at all
                _commit(tmp, path)
        except Interrupted as exc:
            exc.output_in_place = str(path)  # a signal during the commit: it went through
            raise
    except OSError as exc:
        with deferred_signals():
            shutil.rmtree(tmp, ignore_errors=True)
        raise UserError(f"cannot write output directory {str(path)!r}: {_reason(exc)}") from None
    except BaseException:
        with deferred_signals():
            shutil.rmtree(tmp, ignore_errors=True)
        raise


def check_output_file(
    path: str | os.PathLike[str], written_by_us: bytes, option: str = "--out"
) -> Path:
    """Fail early unless one output file can be written at ``path``.

    ``path`` must not be a directory; its parent must exist and be writable; an existing
    file is replaced only if it starts with ``written_by_us`` (the header rangefx writes),
    so that a file of the user's is never overwritten. ``option`` names the command-line
    option in the message.

    Raises
    ------
    UserError
        Naming ``path`` and the reason.
    """
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{option} {str(path)!r} is a directory; give a file name in it")
    if not path.parent.is_dir():
        raise UserError(f"{option} {str(path)!r}: directory {str(path.parent)!r} does not exist")
    if path.exists() or path.is_symlink():
        try:
            with open(path, "rb") as f:
                head = f.read(len(written_by_us))
        except OSError as exc:
            raise UserError(f"{option} {str(path)!r}: cannot read it: {exc.strerror}") from None
        if path.is_symlink() or head != written_by_us:
            raise UserError(
                f"{option} {str(path)!r} exists and was not written by rangefx; refusing to "
                "overwrite it"
            )
    try:
        probe = _sibling_name(path, "tmp")
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        os.unlink(probe)
    except OSError as exc:
        raise UserError(f"cannot write --out {str(path)!r}: {_reason(exc)}") from None
    return path
