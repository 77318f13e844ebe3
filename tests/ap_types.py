"""Where the real Vitis HLS ``ap_types`` headers are, for the tests that build C++ against
them (they ship in the hls4ml wheel, ``hls4ml/templates/vivado/ap_types/``): the folder
``$RANGEFX_AP_TYPES``, or an installed hls4ml. Without them (or without g++) those tests
skip; ``RANGEFX_REQUIRE_AP_TYPES=1`` (as CI sets it) turns the skip into a failure."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest


def ap_types_dir() -> Path | None:
    env = os.environ.get("RANGEFX_AP_TYPES")
    if env:
        return Path(env)
    spec = importlib.util.find_spec("hls4ml")
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(next(iter(spec.submodule_search_locations))) / "templates/vivado/ap_types"
    return path if (path / "ap_fixed.h").is_file() else None


def skip_or_fail(reason: str) -> None:
    if os.environ.get("RANGEFX_REQUIRE_AP_TYPES") == "1":
        pytest.fail(f"RANGEFX_REQUIRE_AP_TYPES=1 but {reason}")
    pytest.skip(reason)
