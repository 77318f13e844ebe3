"""The float64 golden models of every algorithm of the report (SPEC §3).

Modules: :mod:`.geometry`, :mod:`.estimator`, :mod:`.ranging` (G3, G4), :mod:`.polynomial`,
:mod:`.central` (G2), :mod:`.riccati` (G5), :mod:`.tracking` (G1), :mod:`.methods`,
:mod:`.scenes`, :mod:`.realdata`, :mod:`.taps`. The names below are exported lazily (the
module is imported on first use), so that importing one golden module stays cheap.
"""

from __future__ import annotations

import importlib
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


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
