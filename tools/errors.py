"""The one exception type that means "the user made a mistake"."""

from __future__ import annotations

import os

__all__ = ["UserError", "available_memory_bytes", "require_memory"]


class UserError(Exception):
    """A mistake in the user's input or invocation, not a bug in rangefx.

    The command line catches it, prints ``rangefx: error: <message>`` on one line and
    exits with status 2, without a traceback. The message must name the culprit (the
    file, option or value at fault).
    """


def _gib(n: float) -> str:
    return f"{n / 2**30:.2f} GiB" if n >= 2**28 else f"{n / 2**20:.1f} MiB"


def available_memory_bytes() -> int:
    """Memory a new allocation can use: ``MemAvailable`` (Linux), else the physical size."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 2**63 - 1  # unknowable: do not refuse


def require_memory(what: str, need: int) -> None:
    """Refuse up front, with one line naming ``what`` (the option and its value), work that
    would need ``need`` bytes, more than this machine has available (a MemoryError or the
    kernel's OOM killer later, after the work so far is lost).

    Raises
    ------
    UserError
    """
    have = available_memory_bytes()
    if need > have:
        raise UserError(
            f"{what} would need about {_gib(need)} of memory, more than the {_gib(have)} "
            "available here"
        )
