"""Atomic writes of output files and output directories.

A result is either complete or absent: files are written to a temporary name in the
destination directory, flushed to disk and renamed into place; an output directory is
filled under a temporary name and swapped in only when the work succeeded (SPEC §8:
"never a partial output presented as complete").
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
from collections.abc import Iterator
from pathlib import Path

from ..errors import UserError

__all__ = ["MARKER_NAME", "atomic_output_dir", "atomic_write_bytes", "atomic_write_text"]

MARKER_NAME = ".rangefx-output"
"""File that marks a directory as written by rangefx, hence safe to replace."""

_MARKER_TEXT = "This directory was written by rangefx; rangefx may replace it.\n"


def _sibling_name(path: Path, kind: str) -> Path:
    return path.parent / f".{path.name}.{kind}-{os.getpid()}-{secrets.token_hex(4)}"


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
    return (path / MARKER_NAME).is_file()


def _check_replaceable(path: Path) -> None:
    """Raise :class:`UserError` unless ``path`` is absent, empty, or a directory we wrote."""
    if path.is_symlink():
        raise UserError(f"output path {str(path)!r} is a symbolic link; refusing to replace it")
    if not path.exists():
        return
    if not path.is_dir():
        raise UserError(f"output path {str(path)!r} exists and is not a directory")
    if _is_ours(path):
        return
    if any(path.iterdir()):
        raise UserError(
            f"output directory {str(path)!r} is not empty and was not written by rangefx "
            f"(no {MARKER_NAME} file); refusing to overwrite it, choose another --out"
        )


def _commit(tmp: Path, path: Path) -> None:
    _check_replaceable(path)
    if not path.exists():
        os.replace(tmp, path)
        return
    if not _is_ours(path):
        os.rmdir(path)  # empty foreign directory: nothing to lose
        os.replace(tmp, path)
        return
    old = _sibling_name(path, "old")
    os.replace(path, old)
    try:
        os.replace(tmp, path)
    except BaseException:
        os.replace(old, path)
        raise
    shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def atomic_output_dir(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Fill an output directory under a temporary name and swap it in on success.

    Yields a fresh, empty directory next to ``path`` (same parent, named
    ``.<name>.tmp-<pid>-<random>``). When the ``with`` body finishes normally, the marker
    file ``.rangefx-output`` is written into it last and it takes the place of ``path``:

    * ``path`` absent (or an empty directory): the temporary directory is renamed to it;
    * ``path`` a directory holding the marker (an earlier rangefx output): it is renamed
      aside, the temporary directory renamed into place, and the old one deleted;
    * anything else (a file, a symbolic link, a non-empty directory without the marker):
      :class:`~rangefx.tools.errors.UserError` naming ``path``; user data is never
      deleted. This is checked before the body runs as well, so no work is wasted.

    If the body raises (including ``KeyboardInterrupt``), the temporary directory is
    deleted, ``path`` is left untouched and the exception propagates.

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
        ``path`` exists and is not a replaceable rangefx output directory.
    """
    path = Path(path)
    if path.name in ("", ".", ".."):
        path = path.resolve()
    _check_replaceable(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"cannot create output directory {str(path.parent)!r}: {exc}") from exc
    tmp = _sibling_name(path, "tmp")
    tmp.mkdir()
    try:
        yield tmp
        atomic_write_text(tmp / MARKER_NAME, _MARKER_TEXT)
        _commit(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    _fsync_dir(path.parent)
