"""Bit-exactness of every registered pipeline against its independent oracle (SPEC §4, §10).

One test, parametrised over :data:`rangefx.rtl_model.registry.PIPELINES`: every tap,
every overflow count and every pre-quantisation min/max of ``Pipeline.run`` must equal
the pipeline's oracle (``tests/oracles.py``) exactly, over small scenes x configs putting
every signal into each quantisation mode and each overflow mode (narrowed so that
overflows happen) x the pipeline's design choices (variants, dividers, modes, design
fields) x three timings (which must not change any value); and the shipped default config
under every timing.

Per pipeline, :data:`SPECS` says how its cases are drawn: P1 over stereo and motion, both
estimator variants and both dividers, on a textured plane and random textures; P2 over
both dividers, four sets of Riccati weights, on ``lab`` crops and random shifted
textures with a flat run (E1 = E2, where the ``c`` floor acts); P3 over both dividers,
1-3 levels, 1-3 warps, radius 1-4, coarse lag 0-2 and 4-8 Keys ROM bits, on ``lab`` crops
and smooth random textures shifted by 0.5-3 px.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from bitexact_cases import assert_bit_exact, lab_crop, p1_case, p3_case
from oracle_exact import OracleResult
from oracles import ORACLES

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.riccati import PAPER_PIXEL_PITCH_IN, RiccatiConfig
from rangefx.rtl_model import fixedpoint
from rangefx.rtl_model.config import TimingConfig, WordLengthConfig
from rangefx.rtl_model.fixedpoint import (
    ANY_MODES,
    PLAIN_MODES,
    FixedFormat,
    Overflow,
    Quant,
    cast_modes,
    plain_modes,
)
from rangefx.rtl_model.p1 import model as p1_model
from rangefx.rtl_model.p2 import model as p2_model
from rangefx.rtl_model.pipeline import Case, Pipeline
from rangefx.rtl_model.registry import PIPELINES
from rangefx.rtl_model.runtime import format_table

TIMINGS = (
    TimingConfig(),
    TimingConfig(hblank=5, vblank=7),
    TimingConfig(hblank=3, vblank=2, gap_prob=0.4, seed=11),
)


def fixed_signals(pipeline: Pipeline) -> tuple[str, ...]:
    """The input pixel and the host-written registers: never narrowed."""
    cfg = pipeline.config_type
    return (cfg.signals()[0], *cfg.HOST_REGISTERS)


def mode_config(
    pipeline: Pipeline,
    quant: Quant,
    overflow: Overflow,
    narrow: bool,
    seed: int,
    int_drop: tuple[int, int],
    **design: Any,
) -> WordLengthConfig:
    """The default config with every signal in ``quant``/``overflow`` (divider quotients
    keep a saturating mode); ``narrow`` drops ``int_drop`` (low, high exclusive) integer
    bits and 0..3 fraction bits of every datapath signal so that overflows happen."""
    base = pipeline.default_config(**design)
    rng = np.random.default_rng(seed)
    keep = fixed_signals(pipeline)
    # a value the host writes from the design alone must fit its register (a config that
    # does not is refused at load): such a signal loses fraction bits only
    values = {signal: abs(v) for *_, v, signal in base.design_register_values()}
    formats = {}
    for name in base.signals():
        f = base.fmt(name)
        ovf = Overflow.SAT if name in base.QUOTIENTS and overflow is Overflow.WRAP else overflow
        word, frac = f.word, f.frac
        if narrow and name not in keep:
            d_int, d_frac = int(rng.integers(*int_drop)), int(rng.integers(0, 4))
            if name in values and values[name] >= 2.0 ** (f.word - f.frac - f.signed - d_int):
                d_int = 0
            word = max(2, word - d_int - d_frac)
            frac -= d_frac
        formats[name] = FixedFormat(f.signed, word, frac, quant, ovf)
    return base.with_(formats=formats)


# -- P1 cases --------------------------------------------------------------------------
# poles that are not 2^-k take the report's direct filter form (the shift form needs 2^-k)
P1_DESIGNS = (
    {},
    {"pole": 0.3, "bias": 5.3, "init": "zero", "filter_form": "direct"},
    {"pole": 0.75, "recip_lut_bits": 5, "recip_bits": 13, "filter_form": "direct"},
    {"pole": 0.61, "bias": 20.7, "recip_lut_bits": 3, "recip_bits": 8, "filter_form": "direct"},
    {"init": "zero", "bias": 0.0, "pole": 0.25},
)


def p1_cases() -> list[dict[str, Any]]:
    out = []
    for i, (quant, overflow) in enumerate(itertools.product(Quant, Overflow)):
        mode = ("stereo", "motion")[(i // 4) % 2]
        kind = "plane" if i % 5 == 0 else "random"
        design = {
            "variant": ("paper", "consistent")[i % 2],
            "divider": ("restoring", "reciprocal")[(i // 2) % 2],
            **P1_DESIGNS[i % len(P1_DESIGNS)],
        }
        out.append(
            dict(
                quant=quant,
                overflow=overflow,
                narrow=i % 5 != 2,
                timing=TIMINGS[(i // 3) % 3],
                seed=1000 + i,
                design=design,
                mode=mode,
                kind=kind,
                case=lambda s=1000 + i, k=kind, m=mode: p1_case(s, k, m),
            )
        )
    return out


def p1_defaults() -> list[tuple[dict[str, Any], Callable[[], Case]]]:
    return [
        ({"variant": v}, lambda m=mode: p1_case(7 if m == "stereo" else 8, "plane", m))
        for v in ("paper", "consistent")
        for mode in ("stereo", "motion")
    ]


# -- P2 cases --------------------------------------------------------------------------
P2_RICCATI = (
    RiccatiConfig(threshold_e=2.0, range_max=100.0),
    RiccatiConfig(alpha=2.0, beta=4e-3, gamma=1e3, threshold_e=1.5, range_max=60.0),
    RiccatiConfig(alpha=1.0, beta=1e-3, gamma=1e6, pixel_pitch=1.0, threshold_e=0.5),
    RiccatiConfig(alpha=0.5, beta=2e-3, gamma=1e8, pixel_pitch=PAPER_PIXEL_PITCH_IN * 2),
)
P2_DESIGNS = (
    {},
    {"kappa_min": 0.1, "recip_lut_bits": 5, "recip_bits": 13},
    {"kappa_min": 2.0**-9, "lanes": 44},
    {"recip_lut_bits": 3, "recip_bits": 8},
)


def stereo_cases(
    seed0: int, designs: tuple[dict[str, Any], ...], make_case: Callable[[int, int, str], Case]
) -> list[dict[str, Any]]:
    """The quantisation x overflow cases of a stereo-only pipeline: every third on a
    ``lab`` crop, both dividers in turn, ``designs`` in turn; ``make_case(i, seed, kind)``."""
    out = []
    for i, (quant, overflow) in enumerate(itertools.product(Quant, Overflow)):
        kind = "lab" if i % 3 == 0 else "random"
        design = {"divider": ("restoring", "reciprocal")[i % 2], **designs[i % len(designs)]}
        out.append(
            dict(
                quant=quant,
                overflow=overflow,
                narrow=i % 5 != 2,
                timing=TIMINGS[(i // 2) % 3],
                seed=seed0 + i,
                design=design,
                mode="stereo",
                kind=kind,
                case=lambda i=i, k=kind: make_case(i, seed0 + i, k),
            )
        )
    return out


def p2_case(seed: int, kind: str, riccati: RiccatiConfig) -> Case:
    """A tiny random stereo case: a crop of ``lab``, or a random texture shifted by a
    fraction of a pixel plus noise with a flat run (E1 = E2: A = 0, the c floor acts)."""
    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(2, 5)), int(rng.integers(8, 14))
    if kind == "lab":
        im1, im2, camera = lab_crop(rng, m, n)
    else:
        im1 = rng.integers(0, 256, (m, n)).astype(np.uint8)
        shifted = 0.6 * im1.astype(float) + 0.4 * np.roll(im1, -1, axis=1)
        im2 = np.clip(np.rint(shifted + rng.normal(0, 2, (m, n))), 0, 255).astype(np.uint8)
        im2[:, : n // 3] = im1[:, : n // 3]
        camera = PinholeCamera(n, m, float(rng.uniform(400, 800)))
    return Case(im1, im2, camera, MotionIncrement.stereo(0.1), settings={"riccati": riccati})


def p2_cases() -> list[dict[str, Any]]:
    return stereo_cases(
        2000,
        P2_DESIGNS,
        lambda i, seed, kind: p2_case(seed, kind, P2_RICCATI[(i // 3) % len(P2_RICCATI)]),
    )


def p2_defaults() -> list[tuple[dict[str, Any], Callable[[], Case]]]:
    return [({}, lambda: p2_case(3, "lab", RiccatiConfig(threshold_e=2.0, range_max=100.0)))]


# -- P3 cases --------------------------------------------------------------------------
P3_DESIGNS = (
    {},
    {"radius": 2, "sigma": 1.0, "levels": 3},
    {"radius": 1, "sigma": 0.8, "levels": 3, "warps": 3, "coarse_lag": 1, "keys_bits": 4},
    {"radius": 2, "sigma": 1.5, "levels": 2, "warps": 1, "max_disparity": 3.0,
     "recip_lut_bits": 5, "recip_bits": 13},
    {"radius": 3, "sigma": 1.5, "threshold_r": 40.0, "threshold_g": 1.0, "keys_bits": 5,
     "coarse_lag": 2, "normalise_radius": 2},
    {"normalise": "none", "radius": 2, "sigma": 1.0, "levels": 2},
    {"normalise_radius": 1, "radius": 2, "sigma": 1.0, "levels": 3},
    {"vertical": True, "vertical_radius": 0, "radius": 2, "sigma": 1.0, "levels": 3, "warps": 2},
    {"vertical": True, "vertical_radius": 0, "radius": 1, "sigma": 0.8, "levels": 2,
     "normalise": "none"},
    {"vertical": False, "radius": 2, "sigma": 1.0, "levels": 2},
    {"vertical": True, "vertical_radius": 2, "radius": 2, "sigma": 1.0, "levels": 3},
    {"vertical": True, "vertical_radius": 5, "radius": 1, "sigma": 0.8, "levels": 2,
     "normalise": "none", "warps": 3},
)  # fmt: skip


def p3_cases() -> list[dict[str, Any]]:
    return stereo_cases(3000, P3_DESIGNS, lambda i, seed, kind: p3_case(seed, kind))


def p3_defaults() -> list[tuple[dict[str, Any], Callable[[], Case]]]:
    return [({}, lambda: p3_case(5, "lab"))]


@dataclass(frozen=True)
class Spec:
    """How one pipeline's bit-exact cases are drawn."""

    cases: Callable[[], list[dict[str, Any]]]
    defaults: Callable[[], list[tuple[dict[str, Any], Callable[[], Case]]]]
    int_drop: tuple[int, int]
    #: design fields whose every value the mode cases must cover
    design_keys: dict[str, set]
    kinds: set[str]


SPECS = {
    "p1": Spec(
        p1_cases,
        p1_defaults,
        (1, 6),
        {
            "variant": {"paper", "consistent"},
            "divider": {"restoring", "reciprocal"},
            "init": {"first", "zero"},
        },
        {"plane", "random"},
    ),
    "p2": Spec(
        p2_cases, p2_defaults, (2, 13), {"divider": {"restoring", "reciprocal"}}, {"lab", "random"}
    ),
    "p3": Spec(
        p3_cases,
        p3_defaults,
        (3, 9),
        {"divider": {"restoring", "reciprocal"}, "warps": {1, 2, 3}, "coarse_lag": {0, 1, 2}},
        {"lab", "random"},
    ),
}


def _params():
    for name in PIPELINES:
        for i, c in enumerate(SPECS[name].cases()):
            yield pytest.param(name, c, id=f"{name}-{i}-{c['quant'].name}-{c['overflow'].name}")


@pytest.mark.parametrize(("name", "spec"), list(_params()))
def test_bit_exact(name, spec, monkeypatch):
    pipeline, oracle = PIPELINES[name], ORACLES[name]
    config = mode_config(pipeline, spec["quant"], spec["overflow"], spec["narrow"], spec["seed"],
                         SPECS[name].int_drop, **spec["design"])  # fmt: skip
    case = spec["case"]()
    ref = oracle.run(case, config)
    res = pipeline.run(case, config, spec["timing"], taps=True)
    assert_bit_exact(res, ref)
    # the min/max log off (fipref's LoggingMode): everything else identical, no min/max
    unlogged = pipeline.run(case, config, spec["timing"], taps=True, log=False)
    assert unlogged.minmax == {}
    assert_bit_exact(unlogged, OracleResult(ref.taps, ref.overflows, {}))
    # without taps (P1's fused range stage runs only then), logged and unlogged: the same
    # outputs, overflow counts and min/max
    for log in (True, False):
        fast = pipeline.run(case, config, spec["timing"], taps=False, log=log)
        assert fast.taps == {}
        assert np.array_equal(fast.range_raw, ref.range_raw)
        assert np.array_equal(fast.valid, ref.valid)
        assert dict(fast.overflows) == ref.overflows
        assert dict(fast.minmax) == (ref.minmax if log else {})
    if name in ("p1", "p2") and plain_modes(format_table(config)):
        # the plain cast body ran above (its modes are plain); the body for any modes
        # gives the same bits, with and without taps
        assert cast_modes(format_table(config)) is PLAIN_MODES
        monkeypatch.setattr(fixedpoint, "PLAIN_BODY", False)
        assert cast_modes(format_table(config)) is ANY_MODES
        assert_bit_exact(pipeline.run(case, config, spec["timing"], taps=True), ref)
        anybody = pipeline.run(case, config, spec["timing"], taps=False)
        assert np.array_equal(anybody.range_raw, ref.range_raw)
        assert np.array_equal(anybody.valid, ref.valid)
        assert dict(anybody.overflows) == ref.overflows
        assert dict(anybody.minmax) == ref.minmax
        monkeypatch.setattr(fixedpoint, "PLAIN_BODY", True)
    if name == "p1":
        # P1's general kernels (the path of configs the fused front end does not take)
        monkeypatch.setattr(p1_model, "FUSED", False)
        assert_bit_exact(pipeline.run(case, config, spec["timing"], taps=True), ref)
    if name == "p2":
        # P2's general kernel (the path of configs the band kernel does not take)
        monkeypatch.setattr(p2_model, "BANDED", False)
        assert_bit_exact(pipeline.run(case, config, spec["timing"], taps=True), ref)
    if spec["narrow"]:
        # not vacuous: the overflow mode under test acted on some datapath signal
        skip = {*config.QUOTIENTS, *fixed_signals(pipeline)}
        assert sum(n for s, n in ref.overflows.items() if s not in skip) > 0


def _defaults():
    for name in PIPELINES:
        for k, (design, _) in enumerate(SPECS[name].defaults()):
            yield pytest.param(name, k, id=f"{name}-default-{k}-{design}")


@pytest.mark.parametrize(("name", "k"), list(_defaults()))
def test_default_config_bit_exact_under_every_timing(name, k):
    """The shipped config on a small case: no overflow, some valid pixels, and the same
    values under three timings (gaps and blanking change no value)."""
    design, make_case = SPECS[name].defaults()[k]
    pipeline = PIPELINES[name]
    config = pipeline.default_config(**design)
    case = make_case()
    ref = ORACLES[name].run(case, config)
    assert sum(ref.overflows.values()) == 0, {s: n for s, n in ref.overflows.items() if n}
    assert ref.valid.any()
    for timing in TIMINGS:
        assert_bit_exact(pipeline.run(case, config, timing), ref)


@pytest.mark.parametrize("name", list(PIPELINES))
def test_the_plain_cast_body_is_taken_exactly_when_every_mode_is_plain(name):
    """The shipped configs (RND / TRN, SAT) take the plain body; one signal in RND_CONV,
    TRN_ZERO, WRAP or SAT_ZERO sends the whole config to the body for any modes."""
    pipeline = PIPELINES[name]
    config = pipeline.default_config()
    assert cast_modes(format_table(config)) is PLAIN_MODES
    signal = next(iter(config.formats))
    for quant, overflow in ((Quant.RND_CONV, Overflow.SAT), (Quant.TRN_ZERO, Overflow.SAT),
                            (Quant.RND, Overflow.WRAP), (Quant.RND, Overflow.SAT_ZERO),
                            (Quant.RND_MIN_INF, Overflow.SAT_SYM)):  # fmt: skip
        f = config.formats[signal]
        formats = {**config.formats, signal: FixedFormat(f.signed, f.word, f.frac, quant,
                                                         overflow)}  # fmt: skip
        fm = format_table(dataclasses.replace(config, formats=formats))
        plain = quant in fixedpoint.PLAIN_QUANTS and overflow in fixedpoint.PLAIN_OVERFLOWS
        assert (cast_modes(fm) is PLAIN_MODES) == plain, (quant, overflow)


@pytest.mark.parametrize("name", list(PIPELINES))
def test_cases_cover_every_mode(name):
    spec = SPECS[name]
    cases = spec.cases()
    assert {c["quant"] for c in cases if c["narrow"]} == set(Quant)
    assert {c["overflow"] for c in cases if c["narrow"]} == set(Overflow)
    assert {c["narrow"] for c in cases} == {True, False}
    assert {c["timing"] for c in cases} == set(TIMINGS)
    assert {c["kind"] for c in cases} == spec.kinds
    assert {c["mode"] for c in cases} == set(PIPELINES[name].modes)
    for key, values in spec.design_keys.items():
        default = getattr(PIPELINES[name].default_config(), key)
        assert {c["design"].get(key, default) for c in cases} == values, key


def test_every_pipeline_has_an_oracle_and_cases():
    assert set(ORACLES) == set(PIPELINES) == set(SPECS)
