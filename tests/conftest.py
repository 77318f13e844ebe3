"""Fixtures shared by the test modules, and where their helper modules come from.

Helper modules (``oracles.py``, ``oracle_p1.py``, ``oracle_p2.py``, ``oracle_p3.py``,
``bitexact_cases.py``, ``ap_types.py``) are plain modules beside the tests, not test
modules, imported by name (``from oracles import ORACLES``): ``tests/`` has no
``__init__.py``, so pytest (its default ``prepend`` import mode) puts this file's folder
on ``sys.path`` before it imports this conftest or any test module. No test module
imports another test module or edits ``sys.path`` itself
(``tests/test_architecture.py`` checks both).
"""

from __future__ import annotations

import pytest

from rangefx.golden.scenes import Scene, render_scene


@pytest.fixture(scope="session")
def lab() -> Scene:
    """The ``lab`` scene preset at its full size (512 x 512), rendered once per session."""
    return render_scene("lab")
