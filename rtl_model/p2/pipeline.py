"""P2 behind the one pipeline interface (SPEC §10)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any, ClassVar

import numpy as np

from rangefx.golden.ranging import RangeResult
from rangefx.golden.riccati import RiccatiConfig, range_g5
from rangefx.golden.taps import p2_golden_taps

from ..config import WordLengthConfig
from ..pipeline import Case, GoldenReference, Pipeline
from . import buildup, cost, model, taps
from .config import P2Config

__all__ = ["P2Pipeline", "tap_cycles"]


def tap_cycles(name: str, config: P2Config, in_cycles: np.ndarray, hblank: int) -> np.ndarray:
    """Cycle of every sample of tap ``name``: on the sweep's schedule
    (:func:`rangefx.rtl_model.p2.model.p2_schedule`)."""
    _, info, rows = model.p2_schedule(in_cycles, config, hblank)
    return taps.tap_cycles(name, config, in_cycles, rows, info)


class P2Pipeline(Pipeline):
    """P2, the line-buffered Riccati sweep (docs/p2_datapath.md), stereo only. Its golden
    is G5 (:func:`rangefx.golden.riccati.range_g5`) with the case's Riccati settings, so
    "fixed vs golden" isolates the word lengths and the two bounding choices (γ clamp,
    κ floor)."""

    name: ClassVar[str] = "p2"
    title: ClassVar[str] = "P2 Riccati sweep (ch. 5)"
    config_type: ClassVar[type[WordLengthConfig]] = P2Config
    modes: ClassVar[tuple[str, ...]] = ("stereo",)
    options: ClassVar[tuple[str, ...]] = ("divider",)
    variants: ClassVar[dict[str, dict[str, Any]]] = {"": {}}
    golden_fields: ClassVar[tuple[str, ...] | None] = ()  # G5 reads only the case
    settings_key: ClassVar[str] = "riccati"
    settings_type: ClassVar[type] = RiccatiConfig
    case_options: ClassVar[tuple[str, ...]] = ("threshold_e", "range_max")
    buildup_axes: ClassVar[dict[str, str]] = buildup.AXES
    latency_model = staticmethod(model.stage_latencies)
    tap_model = staticmethod(taps.tap_table)
    cost_model = staticmethod(cost.config_cost)
    buildup_model = staticmethod(buildup.buildup_profiles)
    cycle_model = staticmethod(tap_cycles)
    run_model = staticmethod(model.run_p2)
    sweep_examples: ClassVar[tuple[str, ...]] = ("tools/studies/sweeps/p2_lab.toml",)
    line_independent: ClassVar[bool] = True  # the sweep and G5 run along each line
    area_features: ClassVar[dict[str, tuple[str, ...]]] = cost.AREA_FEATURES
    calibration_configs: ClassVar[dict[str, tuple[str | None, dict[str, Any], bool]]] = (
        cost.CALIBRATION_CONFIGS
    )
    area_calibration: ClassVar[str] = "rtl_model/p2/synth_calibration.toml"
    run_bytes_per_pixel: ClassVar[int | None] = 202  # measured 176, with 15 % headroom

    @property
    def signal_groups(self) -> dict[str, tuple[str, ...]]:
        """The base groups plus ``backward_loop`` (the sweep engine's signals) and
        ``forward_loop`` (the forward pass's), from the stage of each tap."""
        groups = super().signal_groups
        for stage in ("backward_loop", "forward_loop"):
            used = {taps.TAP_SIGNALS[t] for t, s in taps.TAP_STAGE.items() if s == stage}
            groups[stage] = tuple(s for s in P2Config.signals() if s in used)
        return groups

    def golden_lines(
        self, case: Case, lines: tuple[int, int], config: WordLengthConfig | None = None
    ) -> RangeResult:
        self.check_mode(case)
        j0, j1 = lines
        if not 0 <= j0 < j1 <= case.image1.shape[0]:
            raise ValueError(f"lines must be (j0, j1) within the frame's {case.image1.shape[0]}")
        # a camera has 2 lines or more: a 1-line band is computed with a neighbour
        lo = min(j0, max(0, j1 - 2))
        hi = min(max(j1, lo + 2), case.image1.shape[0])
        camera = replace(case.camera, height=hi - lo)  # G5 reads f and b, not the rows' place
        g = range_g5(case.image1[lo:hi], case.image2[lo:hi], camera, case.motion,
                     self.settings(case))  # fmt: skip
        rows = slice(j0 - lo, j1 - lo)
        return RangeResult(range=g.range[rows], valid=g.valid[rows],
                           terms={k: v[rows] for k, v in g.terms.items()})  # fmt: skip

    def reference(self, case: Case, config: WordLengthConfig, taps: bool) -> GoldenReference:
        result = range_g5(case.image1, case.image2, case.camera, case.motion, self.settings(case))
        return GoldenReference(result, p2_golden_taps(result) if taps else {})

    def golden_label(self, config: WordLengthConfig) -> str:
        return "g5_riccati"

    def area_terms(
        self, config: WordLengthConfig, shape: tuple[int, int], mode: str = "stereo"
    ) -> dict[str, float]:
        return dict(cost.area_terms(self.check_config(config), shape, mode))
