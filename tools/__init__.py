"""Orchestration (SPEC §1): :mod:`.cli` (the ``rangefx`` command line), :mod:`.studies`
(cases, the generic runner, sweeps, the optimiser, the benchmark), :mod:`.report` (tables,
plots, output directories), :mod:`.errors` (:class:`UserError`)."""

from .errors import UserError

__all__ = ["UserError"]
