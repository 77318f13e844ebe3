"""P3 behind the one pipeline interface (SPEC §10, §12)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from rangefx.golden.multiscale import disparity_g6, range_g6
from rangefx.golden.ranging import RangingConfig

from ..config import WordLengthConfig
from ..pipeline import Case, GoldenReference, Pipeline
from ..runtime import divider_roms
from . import buildup, cost, model, taps
from .config import MULTISCALE_FIELDS, P3Config

__all__ = ["P3Pipeline"]


class P3Pipeline(Pipeline):
    """P3, the streaming multi-scale G6 datapath (docs/multiscale.md), stereo only. Its
    golden is G6 (:func:`rangefx.golden.multiscale.range_g6`) with the config's G6
    settings and the case's ``range_max``, so "fixed vs golden" isolates the word
    lengths, the Keys ROM and the divider."""

    name: ClassVar[str] = "p3"
    title: ClassVar[str] = "P3 multi-scale G6 (SPEC §12)"
    config_type: ClassVar[type[WordLengthConfig]] = P3Config
    modes: ClassVar[tuple[str, ...]] = ("stereo",)
    options: ClassVar[tuple[str, ...]] = ("divider",)
    variants: ClassVar[dict[str, dict[str, Any]]] = {"": {}}
    golden_fields: ClassVar[tuple[str, ...] | None] = MULTISCALE_FIELDS
    settings_key: ClassVar[str] = "ranging"
    settings_type: ClassVar[type] = RangingConfig
    case_options: ClassVar[tuple[str, ...]] = ("range_max",)
    buildup_axes: ClassVar[dict[str, str]] = buildup.AXES
    latency_model = staticmethod(model.stage_latencies)
    tap_model = staticmethod(taps.tap_table)
    cost_model = staticmethod(cost.config_cost)
    buildup_model = staticmethod(buildup.buildup_profiles)
    cycle_model = staticmethod(model.tap_cycles)
    search_range_field: ClassVar[str | None] = "max_disparity"
    run_model = staticmethod(model.run_p3)
    sweep_examples: ClassVar[tuple[str, ...]] = ("tools/studies/sweeps/p3_lab.toml",)
    run_bytes_per_pixel: ClassVar[int | None] = 742  # measured 645, with 15 % headroom

    @property
    def signal_groups(self) -> dict[str, tuple[str, ...]]:
        """The base groups plus ``window`` (the row and column sums) and ``estimate``
        (``du``, ``u``)."""
        groups = super().signal_groups
        groups["window"] = ("p3_rgg", "p3_rge", "p3_ree", "p3_sgg", "p3_sge", "p3_see")
        groups["estimate"] = ("p3_du", "p3_u")
        return groups

    def reference(self, case: Case, config: WordLengthConfig, taps: bool) -> GoldenReference:
        ms = config.multiscale()
        result = range_g6(
            case.image1, case.image2, case.camera, case.motion, ms, self.settings(case)
        )
        golden_taps = {}
        if taps:  # P3 models the second camera on the right: G6 unmirrored
            traced = disparity_g6(case.image1, case.image2, ms, trace=True)
            names = {t.name for t in self.tap_table(config)}
            golden_taps = {k: v for k, v in traced.items() if k in names}
            golden_taps.update(valid=result.valid, range=result.range)
        return GoldenReference(result, golden_taps)

    def golden_label(self, config: WordLengthConfig) -> str:
        return "g6_multiscale"

    def roms(self, config: WordLengthConfig) -> dict[str, np.ndarray]:
        """The divider's seed ROM and the warp's Keys weight ROM (``keys_rom``: row ``i``
        the 4 weights of fraction ``i 2**-keys_bits``, two's complement words of
        ``p3_keys``, row-major)."""
        config = self.check_config(config)
        word = config.formats["p3_keys"].word
        rom = model.keys_rom(config).ravel() & ((1 << word) - 1)
        return {**divider_roms(config), "keys_rom": rom}
