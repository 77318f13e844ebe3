"""Accuracy of each filter structure of P1 (``python -m rangefx.tools.studies.row_filter``;
issue 35): the rows are the project's own run beside its golden at the same pole."""

from __future__ import annotations

import json

import pytest

from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.registry import get_pipeline
from rangefx.tools.studies import row_filter
from rangefx.tools.studies.cases import scene_case
from rangefx.tools.studies.row_filter import FilterStructure, accuracy_rows, markdown_table
from rangefx.tools.studies.runner import compare_ranges

SIZE = (48, 64)
STRUCTURES = (FilterStructure("shift", 0.25), FilterStructure("direct", 0.375))


def test_each_row_is_the_run_of_its_structure_beside_its_own_golden():
    rows = accuracy_rows(STRUCTURES, ["lab"], size=SIZE)
    variants = list(get_pipeline("p1").variants)
    assert [(r["variant"], r["filter_form"], r["pole"]) for r in rows] == [
        (v, s.filter_form, s.pole) for v in variants for s in STRUCTURES
    ]
    pipe = get_pipeline("p1")
    case = scene_case("lab", SIZE)
    for r in rows:  # independently: the config built by hand, its run, its golden
        cfg = P1Config.default(variant=r["variant"], filter_form=r["filter_form"], pole=r["pole"])
        figs = compare_ranges(pipe.run(case, cfg), pipe.golden(case, cfg).result)
        assert r["median_rel_range_diff"] == figs["median_rel_range_diff"]
        assert r["valid_agreement"] == figs["valid_agreement"]
        assert r["shape"] == list(SIZE) and r["case"] == "lab"
    table = markdown_table(rows).splitlines()
    assert len(table) == 2 + len(rows)
    assert "| lab | 48x64 | paper | direct | 0.375 |" in table[3]


def test_the_command_prints_the_rows_and_refuses_a_bad_case(capsys):
    assert row_filter.main(["--case", "lab", "--size", "32", "40", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {(r["filter_form"], r["pole"]) for r in rows} == {
        (s.filter_form, s.pole) for s in row_filter.STRUCTURES
    }
    assert row_filter.main(["--case", "motorcycle/0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error: ")


def test_the_shift_form_cannot_take_a_pole_that_is_no_power_of_two():
    with pytest.raises(ValueError, match="filter_form 'shift' needs a pole 2\\^-k"):
        P1Config.default(filter_form="shift", pole=0.375)


@pytest.mark.parametrize("variant", list(get_pipeline("p1").variants))
@pytest.mark.parametrize("pole", [0.5, 0.25])
def test_at_a_pole_2_to_the_minus_k_the_shift_form_is_the_direct_form_bit_for_bit(variant, pole):
    """Why the two forms' rows agree at 0.5 and 0.25: a product by 2^-k in the pole's
    format is a shift of the same word, so the maps are identical, not merely close."""
    pipe = get_pipeline("p1")
    case = scene_case("lab", SIZE)
    shift, direct = (
        pipe.run(case, P1Config.default(variant=variant, filter_form=form, pole=pole))
        for form in ("shift", "direct")
    )
    assert (shift.range == direct.range).all() and (shift.valid == direct.valid).all()
