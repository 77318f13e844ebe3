"""Read only regular files, and only inside the vector directory (docs/guarantees.md).

A manifest entry or an RTL dump path is input the user (or anyone who can write the
directory) controls: a manifest entry that was a symbolic link to ``/dev/zero`` made
``vectors check`` read 9.1 GB in 15 s, one that was a FIFO made it wait forever, and
``vectors diff v /dev/zero`` read 10 GB. :func:`read_regular` opens without blocking
(a FIFO with no writer opens at once), looks at what it opened, and reads only a
regular file; with ``inside`` the file's real path must lie in that directory.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

__all__ = ["read_regular"]

_KINDS = (
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a directory"),
)


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def read_regular(
    path: str | os.PathLike[str], inside: str | os.PathLike[str] | None = None
) -> bytes:
    """The bytes of ``path``, a regular file (``inside`` that directory, if given).

    Raises
    ------
    ValueError
        One line naming ``path``: it is a FIFO, device, socket or directory, or (with
        ``inside``) a symbolic link leading out of the directory.
    OSError
        It cannot be opened or read (missing, no permission).
    """
    path = Path(path)
    if inside is not None:
        real, root = os.path.realpath(path), os.path.realpath(inside)
        if os.path.commonpath([real, root]) != root:
            raise ValueError(
                f"{path} leads out of the vector directory (to {real}); rangefx reads only "
                "files inside it"
            )
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_BINARY", 0))
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise ValueError(
                f"{path} is {_kind(mode)}, not a regular file; rangefx does not read it"
            )
        os.set_blocking(fd, True)
        with os.fdopen(fd, "rb", closefd=False) as f:
            return f.read()
    finally:
        os.close(fd)
