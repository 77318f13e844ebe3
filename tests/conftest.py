"""Fixtures shared by the test modules, and where their helper modules come from.

Helper modules (``oracles.py``, ``oracle_exact.py``, ``oracle_p1.py``, ``oracle_p2.py``,
``oracle_p3.py``, ``bitexact_cases.py``, ``ap_types.py``) are plain modules beside the
tests, not test modules, imported by name (``from oracles import ORACLES``): ``tests/`` has no
``__init__.py``, so pytest (its default ``prepend`` import mode) puts this file's folder
on ``sys.path`` before it imports this conftest or any test module. No test module
imports another test module or edits ``sys.path`` itself
(``tests/test_architecture.py`` checks both).

Hypothesis runs under one of two profiles (docs/testing.md), chosen by the
``HYPOTHESIS_PROFILE`` environment variable:

* ``ci`` (the default): ``derandomize=True`` and no example database, so the examples
  of a property test are a fixed function of the test's source and the pinned Hypothesis
  version; two runs of the same code try the same examples, and a new counterexample can
  only appear when the code changes, never between two CI runs.
* ``dev``: random examples (a fresh seed each run, or ``--hypothesis-seed=N``) and the
  local example database, to look for counterexamples; ``RANGEFX_HYPOTHESIS_SCALE=K``
  multiplies every test's ``max_examples`` by K.
"""

from __future__ import annotations

import os
from collections.abc import Callable

import pytest
from hypothesis import HealthCheck, settings

from rangefx.golden.scenes import Scene, render_scene

HYPOTHESIS_PROFILES = ("ci", "dev")
settings.register_profile("ci", derandomize=True, database=None, deadline=None, print_blob=True)
settings.register_profile(
    "dev",
    derandomize=False,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
_PROFILE = os.environ.get("HYPOTHESIS_PROFILE", "ci")
if _PROFILE not in HYPOTHESIS_PROFILES:
    raise pytest.UsageError(
        f"HYPOTHESIS_PROFILE={_PROFILE!r} is not one of {', '.join(HYPOTHESIS_PROFILES)}"
    )
# loaded here, before pytest imports any test module, so that every settings object a
# test module builds (``@settings(max_examples=...)``) inherits this profile
settings.load_profile(_PROFILE)


def _example_scale() -> int:
    """The factor RANGEFX_HYPOTHESIS_SCALE asks for (dev profile only), 1 without it."""
    text = os.environ.get("RANGEFX_HYPOTHESIS_SCALE", "1")
    if not text.isdigit() or int(text) < 1:
        raise pytest.UsageError(f"RANGEFX_HYPOTHESIS_SCALE={text!r} is not a positive integer")
    if int(text) > 1 and _PROFILE != "dev":
        raise pytest.UsageError("RANGEFX_HYPOTHESIS_SCALE needs HYPOTHESIS_PROFILE=dev")
    return int(text)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Scale every property test's max_examples by RANGEFX_HYPOTHESIS_SCALE (dev profile)."""
    scale = _example_scale()
    if scale == 1:
        return
    scaled: set[int] = set()  # the items of a parametrised test share one function
    for item in items:
        test = getattr(item, "obj", None)
        if getattr(test, "is_hypothesis_test", False) and id(test) not in scaled:
            scaled.add(id(test))
            # the settings @given reads at call time; Hypothesis has no public per-run
            # multiplier, and a test's own @settings would otherwise pin max_examples
            own = test._hypothesis_internal_use_settings
            test._hypothesis_internal_use_settings = settings(
                own, max_examples=own.max_examples * scale
            )


@pytest.fixture(scope="session")
def lab() -> Scene:
    """The ``lab`` scene preset at its full size (512 x 512), rendered once per session."""
    return render_scene("lab")


@pytest.fixture
def error_line(capsys) -> Callable[[], str]:
    """Read what the command just run printed: nothing on stdout and one ``rangefx:
    error: ...`` line on stderr (docs/guarantees.md); returns that line."""

    def read() -> str:
        captured = capsys.readouterr()
        err = captured.err.strip().splitlines()
        assert captured.out == "" and len(err) == 1, captured
        assert err[0].startswith("rangefx: error: "), err
        return err[0]

    return read
