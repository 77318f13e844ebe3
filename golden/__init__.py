"""The float64 golden models of every algorithm of the report (SPEC §3).

Modules: :mod:`.geometry`, :mod:`.estimator`, :mod:`.ranging` (G3, G4), :mod:`.polynomial`,
:mod:`.central` (G2), :mod:`.riccati` (G5), :mod:`.tracking` (G1), :mod:`.methods`,
:mod:`.scenes`, :mod:`.realdata`, :mod:`.taps`. The names below are exported lazily (the
module is imported on first use), so that importing one golden module stays cheap.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

#: Exported name -> the module that defines it.
_EXPORTS = {
    "PinholeCamera": "geometry",
    "MotionIncrement": "geometry",
    "EstimatorConfig": "estimator",
    "estimate_derivatives": "estimator",
    "RangingConfig": "ranging",
    "RangeResult": "ranging",
    "RiccatiConfig": "riccati",
    "range_g5": "riccati",
    "METHODS": "methods",
    "SCENE_RANGING": "methods",
    "SCENE_RICCATI": "methods",
    "run_method": "methods",
    "SCENE_NAMES": "scenes",
    "Scene": "scenes",
    "render_scene": "scenes",
    "load_motorcycle": "realdata",
    "evaluate": "realdata",
}
__all__ = sorted(_EXPORTS)


def lazy_exports(package: str, exports: dict[str, str]) -> Callable[[str], Any]:
    """A package's module ``__getattr__`` (PEP 562) that imports ``exports[name]`` (a
    submodule of ``package``) on first use of ``name``; the subpackages of rangefx that
    export names lazily use it."""

    def __getattr__(name: str) -> Any:
        if name in exports:
            return getattr(importlib.import_module(f".{exports[name]}", package), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return __getattr__


__getattr__ = lazy_exports(__name__, _EXPORTS)
