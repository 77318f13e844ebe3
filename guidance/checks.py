"""Checks of a guidance settings dataclass's fields in its ``__post_init__``: one message
a kind of bad value, naming the settings (``avoid``, ``extraction``, ``simulation``,
``vehicle parameter``) and the field."""

from __future__ import annotations

import math

__all__ = ["check_choice", "check_numbers"]


def check_choice(owner: str, name: str, value: object, choices: tuple[str, ...]) -> None:
    """``ValueError`` unless ``value`` (field ``name`` of ``owner``) is one of ``choices``."""
    if value not in choices:
        raise ValueError(f"{owner} {name} must be one of {', '.join(choices)}, not {value!r}")


def check_numbers(
    owner: str, settings: object, names: tuple[str, ...], *, positive: bool = True
) -> None:
    """``ValueError`` naming the first field of ``names`` of ``settings`` that is not a
    finite number above 0 (``positive``), or at least 0 (not ``positive``)."""
    for name in names:
        v = getattr(settings, name)
        ok = isinstance(v, (int, float)) and math.isfinite(v) and (v > 0 if positive else v >= 0)
        if not ok:
            what = "a positive number" if positive else "a number >= 0"
            raise ValueError(f"{owner} {name} must be {what}, not {v!r}")
