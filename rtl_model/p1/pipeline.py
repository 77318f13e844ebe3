"""P1 behind the one pipeline interface (SPEC §10)."""

from __future__ import annotations

from typing import Any, ClassVar

from rangefx.golden.estimator import EstimatorConfig
from rangefx.golden.methods import run_method
from rangefx.golden.ranging import RangingConfig
from rangefx.golden.taps import p1_golden_taps

from ..config import WordLengthConfig
from ..pipeline import MODES, Case, GoldenReference, Pipeline, TapSpec
from . import buildup, cost, model, taps
from .config import HOST_REGISTERS, P1_SIGNALS, P1Config

__all__ = ["FRONTEND_SIGNALS", "P1Pipeline"]

#: The per-stream signals (bias, row and column filters, x-derivative).
FRONTEND_SIGNALS: tuple[str, ...] = (
    "bias_in",
    "row_state",
    "row_r1",
    "row_r2",
    "col_state",
    "col_s1",
    "col_s2",
    "col2_state",
    "col2_out",
    "div_quot",
)


class P1Pipeline(Pipeline):
    """P1, derivative-based ranging: bias → row/column filters → x-derivative per stream,
    the eq-28 range stage, thresholds (docs/p1_datapath.md). Its golden is the float64
    eq-28 method ``g4_<variant>`` with the same estimator settings, so that "fixed vs
    golden" isolates the word lengths."""

    name: ClassVar[str] = "p1"
    title: ClassVar[str] = "P1 derivative-based ranging (eq 28)"
    config_type: ClassVar[type[WordLengthConfig]] = P1Config
    modes: ClassVar[tuple[str, ...]] = MODES
    options: ClassVar[tuple[str, ...]] = ("variant", "divider", "pole", "bias", "filter_form")
    variants: ClassVar[dict[str, dict[str, Any]]] = {
        "paper": {"variant": "paper"},
        "consistent": {"variant": "consistent"},
    }
    golden_fields: ClassVar[tuple[str, ...] | None] = ("variant", "pole", "bias", "init")
    settings_key: ClassVar[str] = "ranging"
    settings_type: ClassVar[type] = RangingConfig
    case_options: ClassVar[tuple[str, ...]] = ("threshold_e", "threshold_g", "range_max")
    buildup_axes: ClassVar[dict[str, str]] = buildup.AXES
    run_model = staticmethod(model.run_p1)
    latency_model = staticmethod(model.stage_latencies)
    cost_model = staticmethod(cost.config_cost)
    buildup_model = staticmethod(buildup.buildup_profiles)
    sweep_examples: ClassVar[tuple[str, ...]] = ("tools/studies/sweeps/p1_lab.toml",)
    area_features: ClassVar[dict[str, tuple[str, ...]]] = cost.AREA_FEATURES
    calibration_configs: ClassVar[dict[str, tuple[str | None, dict[str, Any], bool]]] = (
        cost.CALIBRATION_CONFIGS
    )
    area_calibration: ClassVar[str] = "rtl_model/p1/synth_calibration.toml"
    run_bytes_per_pixel: ClassVar[int | None] = 363  # measured 316, with 15 % headroom

    @property
    def signal_groups(self) -> dict[str, tuple[str, ...]]:
        groups = super().signal_groups
        groups["frontend"] = FRONTEND_SIGNALS
        groups["range_stage"] = tuple(
            s
            for s in P1_SIGNALS
            if s not in HOST_REGISTERS and s not in FRONTEND_SIGNALS and s != "pix_in"
        )
        return groups

    def reference(self, case: Case, config: WordLengthConfig, taps: bool) -> GoldenReference:
        est = EstimatorConfig(
            pole=config.pole, variant=config.variant, bias=config.bias, init=config.init
        )
        result = run_method(
            f"g4_{config.variant}", case.image1, case.image2, case.camera, case.motion,
            estimator=est, ranging=self.settings(case),
        )  # fmt: skip
        values = {}
        if taps:
            values = p1_golden_taps(case.image1, case.image2, case.camera, case.motion, est)
        return GoldenReference(result, values)

    def golden_label(self, config: WordLengthConfig) -> str:
        return f"g4_{self.check_config(config).variant}"

    def tap_table(self, config: WordLengthConfig, mode: str = "stereo") -> tuple[TapSpec, ...]:
        config = self.check_config(config)
        return taps.tap_table(config, model.stage_latencies(config))

    def area_terms(
        self, config: WordLengthConfig, shape: tuple[int, int], mode: str = "stereo"
    ) -> dict[str, float]:
        return dict(cost.area_terms(self.check_config(config), shape, mode))

    def rejected_weight(self, signal: str) -> int:
        return sum(cost.REGISTER_INSTANCES[signal])
