"""The guidance settings name the settings, the field and the bad value in one message
(``rangefx.guidance.checks``, shared by every settings dataclass of the guidance)."""

from __future__ import annotations

import math

import pytest

from rangefx.guidance.avoid import AvoidConfig
from rangefx.guidance.extraction import ExtractionConfig
from rangefx.guidance.model import VehicleParams
from rangefx.guidance.simulate import SimulationConfig


@pytest.mark.parametrize(
    ("settings", "kw", "message"),
    [
        (
            AvoidConfig,
            {"clearance_ft": 0.0},
            "avoid clearance_ft must be a positive number, not 0.0",
        ),
        (AvoidConfig, {"track_damping": "0.9"}, "avoid track_damping must be a positive number"),
        (AvoidConfig, {"when_blocked": "x"}, "avoid when_blocked must be one of manoeuvre, "),
        (ExtractionConfig, {"link_ft": -1.0}, "extraction link_ft must be a positive number"),
        (ExtractionConfig, {"grow_k": -1.0}, "extraction grow_k must be a number >= 0, not -1.0"),
        (ExtractionConfig, {"error_model": "q"}, "extraction error_model must be one of motion"),
        (SimulationConfig, {"max_time": math.inf}, "simulation max_time must be a positive number"),
        (VehicleParams, {"rho": math.nan}, "vehicle parameter rho must be a positive number"),
    ],
)
def test_a_bad_field_is_named(settings, kw, message):
    with pytest.raises(ValueError, match=f"^{message}"):
        settings(**kw)


def test_zero_is_a_number_at_least_zero():
    assert ExtractionConfig(grow_k=0.0, noise_sigma=0).grow_k == 0.0
