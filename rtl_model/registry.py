"""The registry of pipelines (SPEC §10): every consumer takes a pipeline from here."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from .p1.pipeline import P1Pipeline
from .p2.pipeline import P2Pipeline
from .p3.pipeline import P3Pipeline
from .pipeline import Pipeline

__all__ = ["PIPELINES", "get_pipeline"]

#: Pipeline name -> its one instance.
PIPELINES: Mapping[str, Pipeline] = MappingProxyType(
    {"p1": P1Pipeline(), "p2": P2Pipeline(), "p3": P3Pipeline()}
)


def get_pipeline(name: str) -> Pipeline:
    """The registered pipeline ``name``; ``ValueError`` naming the choices otherwise."""
    try:
        return PIPELINES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown pipeline {name!r}; choose from {', '.join(PIPELINES)}") from None
