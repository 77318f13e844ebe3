"""The independent oracles of every registered pipeline, behind the pipelines' ``run``
signature (SPEC §10), so that one parametrised bit-exact test covers every pipeline, as
Amaranth's tests swap ``FIFOModel`` for the design.

Each oracle is a slow, exact reference (apytypes + Python integers) written from the
pipeline's datapath page, not from its model: ``oracle_p1.py`` (docs/p1_datapath.md),
``oracle_p2.py`` (docs/p2_datapath.md) and ``oracle_p3.py`` (docs/multiscale.md). Values
do not depend on timing, so ``timing`` and ``threads`` are accepted and ignored.
"""

from __future__ import annotations

from oracle_exact import OracleResult
from oracle_p1 import oracle_p1
from oracle_p2 import oracle_p2
from oracle_p3 import oracle_p3

from rangefx.rtl_model.config import TimingConfig, WordLengthConfig
from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import PIPELINES


class Oracle:
    """An oracle behind the pipelines' ``run`` signature: :meth:`compute` runs it."""

    def run(
        self,
        case: Case,
        config: WordLengthConfig,
        timing: TimingConfig | None = None,
        *,
        taps: bool = True,
        threads: int = 1,
    ) -> OracleResult:
        return self.compute(case, config)

    def compute(self, case: Case, config: WordLengthConfig) -> OracleResult:
        raise NotImplementedError


class P1Oracle(Oracle):
    def compute(self, case: Case, config: WordLengthConfig):
        return oracle_p1(
            case.image1, case.image2, case.camera, case.motion, config,
            PIPELINES["p1"].settings(case), mode=case.mode,
        )  # fmt: skip


class P2Oracle(Oracle):
    def compute(self, case: Case, config: WordLengthConfig):
        settings = PIPELINES["p2"].settings(case)
        return oracle_p2(case.image1, case.image2, case.camera, case.motion, config, settings)


class P3Oracle(Oracle):
    def compute(self, case: Case, config: WordLengthConfig):
        settings = PIPELINES["p3"].settings(case)
        return oracle_p3(case.image1, case.image2, case.camera, case.motion, config, settings)


#: Pipeline name -> its oracle (same keys as ``rangefx.rtl_model.registry.PIPELINES``).
ORACLES = {"p1": P1Oracle(), "p2": P2Oracle(), "p3": P3Oracle()}
