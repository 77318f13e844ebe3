"""The registry of pipelines (SPEC §10): every consumer takes a pipeline from here.

The three pipelines of the package are registered on import; a pipeline defined outside
the package (a subclass of :class:`~rangefx.rtl_model.pipeline.Pipeline` with its own
config type) joins them with :func:`register_pipeline`, and every command, study and
vector tool then takes it by name as it takes P1.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from .p1.pipeline import P1Pipeline
from .p2.pipeline import P2Pipeline
from .p3.pipeline import P3Pipeline
from .pipeline import Pipeline

__all__ = ["BUILTIN", "PIPELINES", "get_pipeline", "register_pipeline", "unregister_pipeline"]

_REGISTERED: dict[str, Pipeline] = {p.name: p for p in (P1Pipeline(), P2Pipeline(), P3Pipeline())}
#: Pipeline name -> its one instance (read-only: :func:`register_pipeline` adds one).
PIPELINES: Mapping[str, Pipeline] = MappingProxyType(_REGISTERED)
#: The pipelines of the package itself, which cannot be replaced or removed.
BUILTIN: tuple[str, ...] = tuple(_REGISTERED)


def get_pipeline(name: str) -> Pipeline:
    """The registered pipeline ``name``; ``ValueError`` naming the choices otherwise."""
    try:
        return PIPELINES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown pipeline {name!r}; choose from {', '.join(PIPELINES)}") from None


def register_pipeline(pipeline: Pipeline, *, replace: bool = False) -> Pipeline:
    """Add ``pipeline`` (an instance) under its :attr:`~Pipeline.name` and return it;
    ``ValueError`` for a name in use (unless ``replace``, never one of :data:`BUILTIN`),
    a name that is not a lower-case identifier, or an instance missing a class attribute
    of the interface. Command-line parsers built afterwards offer it."""
    if not isinstance(pipeline, Pipeline):
        raise ValueError(
            f"register_pipeline needs a Pipeline instance, not {type(pipeline).__name__}"
        )
    for attr in ("name", "title", "config_type", "modes"):
        if not hasattr(pipeline, attr):
            raise ValueError(f"{type(pipeline).__name__} has no class attribute {attr!r}")
    name = pipeline.name
    if not (isinstance(name, str) and name.isidentifier() and name == name.lower()):
        raise ValueError(f"a pipeline name must be a lower-case identifier, not {name!r}")
    if name in BUILTIN or (name in _REGISTERED and not replace):
        raise ValueError(f"pipeline {name!r} is already registered")
    _REGISTERED[name] = pipeline
    return pipeline


def unregister_pipeline(name: str) -> None:
    """Remove the pipeline ``name`` that :func:`register_pipeline` added; ``ValueError``
    for one of :data:`BUILTIN` or an unknown name."""
    if name in BUILTIN or name not in _REGISTERED:
        raise ValueError(f"pipeline {name!r} was not added by register_pipeline")
    del _REGISTERED[name]
