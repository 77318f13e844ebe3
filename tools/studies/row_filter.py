"""Accuracy of each structure of P1's row and column filters (issue 35;
``python -m rangefx.tools.studies.row_filter``).

P1's first-order filters (eqs 19-22 of the report's chapter 4) apply the pole ``C`` either
through a multiplier by the pole register (``filter_form = "direct"``, the report's
form, any pole) or as a right shift (``"shift"``, a pole ``2^-k``: no multiplier in the
one-cycle recurrence). Each structure runs through the project's own path
(:func:`~rangefx.tools.studies.runner.run_case` beside
:func:`~rangefx.tools.studies.runner.golden_case` at the same pole, scored by
:func:`~rangefx.tools.studies.runner.compare_ranges`, as ``rangefx run`` and ``rangefx
eval`` do) on the lab scene and the Middlebury motorcycle pair down-sampled by 4 and 8
(:func:`~rangefx.tools.studies.cases.real_pair_case`), for every P1 variant with the
shipped default word lengths.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass

from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import get_pipeline

from ..errors import UserError
from .cases import real_pair_case, scene_case
from .runner import compare_ranges, golden_case, load_config, run_case

__all__ = ["CASES", "STRUCTURES", "FilterStructure", "accuracy_rows", "main", "markdown_table"]


@dataclass(frozen=True)
class FilterStructure:
    """One way to build the filters: the design's ``filter_form`` and its pole."""

    filter_form: str
    pole: float

    @property
    def label(self) -> str:
        return f"{self.filter_form}, pole {self.pole:g}"


#: The structures measured: both forms at the poles the shift form can take (0.5, the
#: default, and 0.25) and the direct form at a pole that is no power of two.
STRUCTURES: tuple[FilterStructure, ...] = (
    FilterStructure("shift", 0.5),
    FilterStructure("direct", 0.5),
    FilterStructure("shift", 0.25),
    FilterStructure("direct", 0.25),
    FilterStructure("direct", 0.375),
)
#: The cases: a scene preset name, or ``motorcycle/F`` (the real pair down-sampled by F).
CASES: tuple[str, ...] = ("lab", "motorcycle/4", "motorcycle/8")


def _case(name: str, size: Sequence[int] | None) -> Case:
    if name.startswith("motorcycle/"):
        return real_pair_case("motorcycle", int(name.split("/")[1]))
    return scene_case(name, size)


def accuracy_rows(
    structures: Sequence[FilterStructure] = STRUCTURES,
    cases: Sequence[str] = CASES,
    *,
    size: Sequence[int] | None = None,
) -> list[dict]:
    """One row per case, P1 variant and structure: ``case``, ``shape``, ``variant``,
    ``filter_form``, ``pole``, ``median_rel_range_diff`` (median |fixed − golden| /
    golden on pixels valid in both), ``valid_agreement``, ``n_valid_both`` and the
    overflow count. ``size``: render the synthetic scenes at this size (the real pair
    keeps its own)."""
    pipe = get_pipeline("p1")
    rows = []
    for name in cases:
        case = _case(name, size)
        for variant, design in pipe.variants.items():
            for s in structures:
                config = load_config(pipe, None, **design, filter_form=s.filter_form, pole=s.pole)
                result = run_case(pipe, case, config)
                figures = compare_ranges(result, golden_case(pipe, case, config).result)
                rows.append({
                    "case": name, "shape": list(case.shape), "variant": variant,
                    "filter_form": s.filter_form, "pole": s.pole,
                    "median_rel_range_diff": figures["median_rel_range_diff"],
                    "valid_agreement": figures["valid_agreement"],
                    "n_valid_both": figures["n_valid_both"],
                    "overflows": result.overflow_total,
                })  # fmt: skip
    return rows


def _num(x: float, fmt: str) -> str:
    return "—" if x is None or not math.isfinite(x) else format(x, fmt)


def markdown_table(rows: Sequence[dict]) -> str:
    """The rows as a Markdown table (one line per case, variant and structure)."""
    out = [
        "| case | size | variant | filter form | pole | median \\|fixed − golden\\|/golden "
        "| valid agreement | overflows |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        m, n = r["shape"]
        out.append(
            f"| {r['case']} | {m}x{n} | {r['variant']} | {r['filter_form']} | {r['pole']:g} "
            f"| {_num(r['median_rel_range_diff'], '.3e')} "
            f"| {_num(r['valid_agreement'], '.5f')} | {r['overflows']} |"
        )
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rangefx.tools.studies.row_filter [--case C ...] [--size H W] [--json]``."""
    p = argparse.ArgumentParser(prog="python -m rangefx.tools.studies.row_filter",
                                description=__doc__.split("\n\n")[0])  # fmt: skip
    p.add_argument("--case", nargs="+", default=list(CASES),
                   help=f"a scene or motorcycle/F (default {' '.join(CASES)})")  # fmt: skip
    p.add_argument("--size", type=int, nargs=2, metavar=("H", "W"),
                   help="render the synthetic scenes at this size")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the rows as one JSON list")
    args = p.parse_args(argv)
    try:
        rows = accuracy_rows(cases=args.case, size=args.size)
    except (UserError, ValueError) as exc:
        print(f"rangefx: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(rows) if args.json else markdown_table(rows))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
