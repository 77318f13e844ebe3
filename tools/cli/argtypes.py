"""argparse ``type`` functions of the ``rangefx`` options, in a module that imports no
model and no pipeline registry (``rangefx sweep``'s parser uses them before the models
load; :mod:`.options` re-exports them)."""

from __future__ import annotations

import argparse
from collections.abc import Callable

__all__ = ["int_at_least", "out_path"]


def int_at_least(minimum: int, what: str = "value") -> Callable[[str], int]:
    """An argparse ``type``: an integer ``>= minimum``, else a one-line parser error."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if v < minimum:
            raise argparse.ArgumentTypeError(f"{what} must be >= {minimum}, not {v}")
        return v

    return parse


def out_path(text: str) -> str:
    """An argparse ``type`` for ``--out``: an empty (or blank) path names no place to write
    (``Path("")`` would be the working directory), a one-line parser error."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no file or directory")
    return text
