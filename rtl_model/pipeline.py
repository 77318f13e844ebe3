"""The one pipeline interface (SPEC §10): cases, results, tap tables, cost, and the base
class every bit-accurate pipeline implements once.

A consumer (``rangefx run | demo | bench | vectors | sweep | optimise | config | eval``)
takes a :class:`Pipeline` from :data:`rangefx.rtl_model.registry.PIPELINES` and calls
:meth:`Pipeline.run`, :meth:`Pipeline.golden`, :meth:`Pipeline.tap_table` and
:meth:`Pipeline.cost`; it never imports a pipeline's model functions. Cost and latency
are methods of the pipeline, as FINN's ``HWCustomOp`` carries its cycle and resource
estimates, so no tool re-derives them.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np

from rangefx.golden.estimator import validate_image
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.ranging import RangeResult, RangingConfig
from rangefx.golden.scenes import Scene

from .config import TimingConfig, WordLengthConfig
from .cost import CostReport, estimate_area, load_area_calibration
from .fixedpoint import FixedFormat, Overflow, Quant
from .runtime import check_threads, divider_roms

__all__ = [
    "MODES",
    "VALID_FORMAT",
    "Case",
    "GoldenReference",
    "Pipeline",
    "PipelineResult",
    "Profiles",
    "TapSpec",
    "build_result",
]

#: Input modes: two synchronised streams, or one stream of two frames.
MODES = ("stereo", "motion")
#: The 1-bit flag ``valid``: unsigned, one bit, no fraction.
VALID_FORMAT = FixedFormat(False, 1, 0, Quant.TRN, Overflow.WRAP)
#: Error build-up profiles: name -> {"index": positions, "<curve>": values, ...}.
Profiles = dict[str, dict[str, np.ndarray]]
_S = TypeVar("_S")


@dataclass(frozen=True)
class Case:
    """Everything one pipeline run needs besides the word-length config and timing.

    ``image1`` is E1 (left camera, or the previous frame in motion mode), ``image2`` E2;
    ``mode`` is the scene's kind (``Scene.kind``). ``settings`` maps a settings key to a
    frozen dataclass of settings; each pipeline reads its own by its
    :attr:`Pipeline.settings_key` (:meth:`setting`, :meth:`Pipeline.settings`): the
    report's thresholds and ``range_max`` under ``"ranging"`` (P1, P3 and the golden
    methods), the Riccati weights, threshold and ``range_max`` under ``"riccati"`` (P2).
    A key absent means its type's defaults. ``scene`` is the rendered scene with its
    truth, ``label`` a name when there is no scene (a real pair).

    Build one with :meth:`from_scene` or :meth:`from_images`.
    """

    image1: np.ndarray
    image2: np.ndarray
    camera: PinholeCamera
    motion: MotionIncrement
    mode: str = "stereo"
    scene: Scene | None = None
    label: str | None = None
    settings: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"unknown mode {self.mode!r}; choose from {', '.join(MODES)}")
        if not isinstance(self.settings, Mapping) or not all(
            isinstance(k, str) for k in self.settings
        ):
            raise ValueError("case settings must map settings keys (str) to settings")
        if self.scene is not None and not isinstance(self.scene, Scene):
            # a case built positionally as before settings moved to ``settings``
            raise ValueError(
                f"case scene must be a Scene, not {type(self.scene).__name__} (a pipeline's "
                "settings go in settings={key: ...})"
            )

    @classmethod
    def from_scene(cls, scene: Scene, settings: Mapping[str, Any] | None = None) -> Case:
        """The case of a rendered scene: its kind (stereo or motion) as the mode, the
        scene's measured settings presets
        (:data:`rangefx.rtl_model.cases.SCENE_SETTINGS`; a key absent: the defaults),
        updated by ``settings``."""
        from .cases import scene_settings

        return cls(
            scene.image1, scene.image2, scene.camera, scene.motion, scene.kind, scene=scene,
            settings={**scene_settings(scene.name), **dict(settings or {})},
        )  # fmt: skip

    @classmethod
    def from_images(
        cls,
        left: np.ndarray | str | Path,
        right: np.ndarray | str | Path,
        *,
        f_px: float | None = None,
        baseline: float | None = None,
        camera: PinholeCamera | None = None,
        motion: MotionIncrement | None = None,
        label: str | None = None,
        settings: Mapping[str, Any] | None = None,
    ) -> Case:
        """A stereo case from an image pair: arrays, or paths of ``.npy`` or image files
        (:func:`rangefx.rtl_model.cases.read_image`).

        The camera is ``camera``, or a pinhole of the images' size with focal length
        ``f_px`` (pixels, principal point at the centre); the motion is ``motion``, or the
        stereo baseline ``baseline`` along the camera's ``+y_c`` (E2 is the right camera).
        ``settings``: settings key -> settings (absent keys: the defaults); ``label``: its
        name (default the files' names). ``ValueError`` naming what is wrong: a file that
        cannot be read, images of different shapes, or neither a camera nor ``f_px``,
        neither a motion nor ``baseline``.
        """
        from .cases import read_image

        named = [str(x) if isinstance(x, (str, Path)) else n
                 for x, n in ((left, "left"), (right, "right"))]  # fmt: skip
        e1, e2 = (
            read_image(image) if isinstance(image, (str, Path))
            else validate_image(np.asarray(image), name=name)
            for image, name in zip((left, right), named, strict=True)
        )  # fmt: skip
        if e1.shape != e2.shape:
            raise ValueError(
                f"image pair shapes differ: {named[0]} {e1.shape} vs {named[1]} {e2.shape}"
            )
        if (camera is None and f_px is None) or (motion is None and baseline is None):
            raise ValueError("an image pair needs --f-px and --baseline")
        return cls(
            e1, e2, camera or PinholeCamera(e1.shape[1], e1.shape[0], f_px),
            motion or MotionIncrement.stereo(baseline),
            label=label or f"{named[0]} + {named[1]}", settings=dict(settings or {}),
        )  # fmt: skip

    def setting(self, key: str, settings_type: type[_S]) -> _S:
        """The settings under ``key`` (absent: ``settings_type()``, its defaults);
        ``ValueError`` if they are not a ``settings_type``."""
        value = self.settings.get(key)
        if value is None:
            return settings_type()
        if not isinstance(value, settings_type):
            raise ValueError(
                f"case settings {key!r} must be a {settings_type.__name__}, not "
                f"{type(value).__name__}"
            )
        return value

    def with_setting(self, key: str, value: Any) -> Case:
        """The case with the settings under ``key`` replaced by ``value``."""
        return replace(self, settings={**self.settings, key: value})

    def with_settings(self, settings: Mapping[str, Any]) -> Case:
        """The case with every settings key of ``settings`` replaced."""
        return replace(self, settings={**self.settings, **settings})

    @property
    def name(self) -> str:
        """The scene's name, else the label, else ``"case"``."""
        if self.scene is not None:
            return self.scene.name
        return self.label or "case"

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) of the images."""
        m, n = np.shape(self.image1)
        return int(m), int(n)


@dataclass(frozen=True)
class TapSpec:
    """One tap of a pipeline: a signal observed in the datapath, one sample per pixel.

    ``name`` as in :attr:`PipelineResult.taps` (``e1.``/``e2.`` prefixes for per-stream
    taps); ``signal`` the config signal whose format it carries (``"valid"`` for the
    flag); ``stream`` ``"e1"``, ``"e2"`` or ``None``; ``stage`` the stage whose output it
    is; ``latency`` cycles from the pixel's input beat to the sample (``None``: the
    pipeline's schedule gives each sample's cycle, see :meth:`Pipeline.tap_cycles`).
    """

    name: str
    signal: str
    fmt: FixedFormat
    stage: str | None
    latency: int | None
    stream: str | None = None

    @property
    def lsb_rms(self) -> float:
        """``LSB / sqrt(12)`` of its format: the RMS error of one rounding."""
        return 2.0**-self.fmt.frac / math.sqrt(12.0)

    def values(self, result: PipelineResult) -> np.ndarray:
        """Its raw codes in ``result`` as float values (raw times 2^-F)."""
        return np.ldexp(result.taps[self.name].astype(np.float64), -self.fmt.frac)


@dataclass(frozen=True)
class PipelineResult:
    """Outputs, taps, instrumentation and timing of one run of any pipeline.

    ``range`` is float64 in the scene's unit (``range_max`` where invalid), ``valid`` a
    bool map, ``range_raw`` the raw output codes. ``taps`` maps tap names
    (:meth:`Pipeline.tap_table`) to int64 raw arrays of shape (m, n) (empty without taps).
    ``overflows`` and ``minmax`` are per signal. ``in_cycles`` is the clock at which each
    pixel (of E2's frame) entered, ``out_cycles`` when its range left; ``latency`` the
    largest ``out - in``; ``stage_latency`` the declared latency of every stage.
    Buffers in bits: ``line_buffer_bits`` (line buffers of the filters / input lines),
    ``frame_store_bits`` (motion mode), ``sweep_buffer_bits`` (a sweep's stored line).
    ``registers``: host register name -> (float requested, value held);
    ``saturated_registers`` the registers whose value lies outside their format (cast
    with its overflow mode: held at its limit under SAT, wrapped under WRAP; a silent
    error no overflow counter sees); ``register_codes``: host
    register name -> (signal whose format holds it, raw code written); ``timing`` the
    input stream's timing. ``schedule``:
    pipeline-specific timing facts (e.g. the sweep's lanes and periods);
    ``kernel_cpu_s``: CPU seconds per kernel, for the benchmark's breakdown.
    """

    pipeline: str
    range: np.ndarray
    valid: np.ndarray
    range_raw: np.ndarray
    taps: dict[str, np.ndarray]
    overflows: dict[str, int]
    minmax: dict[str, tuple[float, float]]
    in_cycles: np.ndarray
    out_cycles: np.ndarray
    latency: int
    stage_latency: dict[str, int]
    line_buffer_bits: int
    frame_store_bits: int
    sweep_buffer_bits: int
    total_cycles: int
    registers: dict[str, tuple[float, float]]
    saturated_registers: tuple[str, ...]
    register_codes: dict[str, tuple[str, int]]
    mode: str
    config: WordLengthConfig = field(repr=False)
    timing: TimingConfig = field(default_factory=TimingConfig)
    schedule: dict[str, int] = field(default_factory=dict)
    kernel_cpu_s: dict[str, float] = field(default_factory=dict, repr=False)

    @property
    def overflow_total(self) -> int:
        return int(sum(self.overflows.values()))

    @property
    def valid_fraction(self) -> float:
        return float(np.count_nonzero(self.valid)) / self.valid.size

    @property
    def buffer_bits(self) -> int:
        """Every buffer's bits: line buffers + frame store + sweep buffers."""
        return self.line_buffer_bits + self.frame_store_bits + self.sweep_buffer_bits


def build_result(
    pipeline: str,
    config: WordLengthConfig,
    timing: TimingConfig,
    mode: str,
    *,
    range_raw: np.ndarray,
    range_float: np.ndarray,
    valid: np.ndarray,
    taps: dict[str, np.ndarray],
    stats: tuple[dict[str, int], dict[str, tuple[float, float]]],
    log: bool,
    cycles: tuple[np.ndarray, np.ndarray],
    stage_latency: dict[str, int],
    registers: Any,
    buffers: Mapping[str, int],
    band_ends: Sequence[tuple[int, int]] = (),
    latency: int | None = None,
    schedule: Mapping[str, int] | None = None,
    kernel_cpu_s: Mapping[str, float] | None = None,
) -> PipelineResult:
    """The one place a :class:`PipelineResult` is assembled from a model's raw outputs.

    ``stats`` is ``(overflows, minmax)`` (``minmax`` dropped unless ``log``), ``cycles``
    ``(in_cycles, out_cycles)``, ``registers`` the model's
    :class:`~rangefx.rtl_model.runtime.RegisterFile`, ``buffers`` the buffer bits by
    field name (``line_buffer_bits``, ``frame_store_bits``, ``sweep_buffer_bits``; absent:
    0). ``band_ends``: each band's (largest ``out - in``, last output cycle), as the
    bands computed them; without them the latency and the last cycle come from the cycle
    maps. ``latency`` given (a fixed pipeline depth) overrides both.
    """
    in_cycles, out_cycles = cycles
    overflows, minmax = stats
    if latency is None:
        latency = (max(worst for worst, _ in band_ends) if band_ends
                   else int((out_cycles - in_cycles).max()))  # fmt: skip
    last = max(end for _, end in band_ends) if band_ends else int(out_cycles.max())
    unknown = set(buffers) - {"line_buffer_bits", "frame_store_bits", "sweep_buffer_bits"}
    if unknown:
        raise ValueError(f"unknown buffer fields {sorted(unknown)}")
    return PipelineResult(
        pipeline=pipeline, range=range_float, valid=valid, range_raw=range_raw, taps=taps,
        overflows=overflows, minmax=minmax if log else {}, in_cycles=in_cycles,
        out_cycles=out_cycles, latency=int(latency), stage_latency=stage_latency,
        line_buffer_bits=buffers.get("line_buffer_bits", 0),
        frame_store_bits=buffers.get("frame_store_bits", 0),
        sweep_buffer_bits=buffers.get("sweep_buffer_bits", 0), total_cycles=last + 1,
        registers=registers.values, saturated_registers=registers.saturated,
        register_codes=registers.codes, mode=mode, config=config, timing=timing,
        schedule=dict(schedule or {}), kernel_cpu_s=dict(kernel_cpu_s or {}),
    )  # fmt: skip


@dataclass(frozen=True)
class GoldenReference:
    """A pipeline's float64 reference on one case: the golden range result and the float
    value of every tap that has an order-by-order counterpart (tap name -> array)."""

    result: RangeResult
    taps: Mapping[str, np.ndarray] = field(default_factory=dict)


class Pipeline(abc.ABC):
    """A bit-accurate, cycle-faithful pipeline: implemented once per pipeline.

    Class attributes: :attr:`name` (registry key), :attr:`title`, :attr:`config_type`
    (its :class:`WordLengthConfig` subclass), :attr:`modes` (input modes it models),
    :attr:`options` (command-line design options it accepts, besides ``--config``),
    :attr:`variants` (the named design variants a demo or benchmark runs),
    :attr:`signal_groups` (named signal groups a sweep axis may move together),
    :attr:`settings_key` and :attr:`settings_type` (its own settings in a case),
    :attr:`case_options` (the fields of those settings a user may set per run),
    :attr:`sweep_examples` (its example sweep definitions). Everything a consumer needs
    to know about one pipeline is here, so a pipeline defined outside the package works
    everywhere once :func:`rangefx.rtl_model.registry.register_pipeline` has it.
    """

    name: ClassVar[str]
    title: ClassVar[str]
    config_type: ClassVar[type[WordLengthConfig]]
    modes: ClassVar[tuple[str, ...]]
    options: ClassVar[tuple[str, ...]] = ()
    #: Named design variants a demo or benchmark runs (label -> design fields).
    variants: ClassVar[dict[str, dict[str, Any]]] = {}
    #: Design fields of the config that :meth:`golden` reads (``None``: every one), so
    #: that a cache of goldens keys on what they depend on (:meth:`golden_key`).
    golden_fields: ClassVar[tuple[str, ...] | None] = None
    #: Where its settings live in a case (:meth:`Case.setting`), and their type: a frozen
    #: dataclass whose defaults are usable and which has a ``range_max`` (the length
    #: invalid pixels carry).
    settings_key: ClassVar[str] = "ranging"
    settings_type: ClassVar[type] = RangingConfig
    #: The case options it reads: fields of its settings a user may set per run (the
    #: command line's ``--threshold-e``, ``--threshold-g``, ``--range-max``).
    case_options: ClassVar[tuple[str, ...]] = ("range_max",)
    #: Its example sweep definitions: TOML files, relative to the ``rangefx`` package root
    #: or absolute (:meth:`sweep_example_paths`).
    sweep_examples: ClassVar[tuple[str, ...]] = ()
    #: The design field that bounds its disparity search, for a dense stereo pipeline
    #: that ranges a real pair under the Middlebury protocol
    #: (:mod:`rangefx.tools.studies.evaluation`; P3's ``max_disparity``); None: it does not.
    search_range_field: ClassVar[str | None] = None
    #: The model's lines are independent: a band of lines run alone gives those rows of
    #: the whole frame's outputs, taps and overflows, and its golden likewise (P2: the
    #: sweep and G5 run along each line). Then :meth:`run` with ``lines=`` and
    #: :meth:`golden_lines` process a large frame in bands
    #: (:func:`rangefx.tools.studies.banded.run_in_bands`); else they raise ValueError.
    line_independent: ClassVar[bool] = False
    #: Its RTL's area calibration (``python -m rangefx.tools.studies.calibrate``): each
    #: synthesised area class (``lut``, ``ff``, ``dsp``, ``bram``) -> the proxy terms
    #: (:meth:`area_terms` keys) it is fitted on, with an intercept; empty: none.
    area_features: ClassVar[dict[str, tuple[str, ...]]] = {}
    #: The configs the calibration synthesises: name -> (config file relative to the
    #: ``rangefx`` package root, or ``None`` for the default; design overrides; ``True``
    #: if fitted on, ``False`` if held out to score the fit).
    calibration_configs: ClassVar[dict[str, tuple[str | None, dict[str, Any], bool]]] = {}
    #: The fitted coefficients, relative to the package root (``""``: none).
    area_calibration: ClassVar[str] = ""
    #: Peak resident bytes a pixel of ``rangefx run`` of this pipeline beside its golden,
    #: above the process's base (:data:`rangefx.tools.studies.runner.RUN_BASE_BYTES`):
    #: the fit of ``/usr/bin/time -f %M rangefx run --pipeline P --left L.npy --right
    #: R.npy`` at 512x512 and 2048x2048 with 15 % headroom, which the memory guard of a
    #: run reads (:func:`rangefx.tools.studies.runner.run_memory_bytes`); ``None``: not
    #: measured, estimated at the largest of the registry's.
    run_bytes_per_pixel: ClassVar[int | None] = None

    def sweep_example_paths(self) -> tuple[Path, ...]:
        """:attr:`sweep_examples` as absolute paths."""
        root = Path(__file__).resolve().parent.parent
        return tuple(root / p for p in self.sweep_examples)

    # -- settings of a case -----------------------------------------------------------
    def settings(self, case: Case) -> Any:
        """Its own settings in ``case`` (:attr:`settings_key`, :attr:`settings_type`)."""
        return case.setting(self.settings_key, self.settings_type)

    def with_case_options(self, case: Case, **options: Any) -> Case:
        """``case`` with the given case options (``None``: not given) set in its settings;
        ``ValueError`` for an option it does not read or a bad value."""
        given = {k: v for k, v in options.items() if v is not None}
        for name in given:
            if name not in self.case_options:
                takes = ", ".join(self.case_options) or "none"
                raise ValueError(
                    f"pipeline {self.name} does not read case option {name!r} (it reads: {takes})"
                )
        if not given:
            return case
        return case.with_setting(self.settings_key, replace(self.settings(case), **given))

    def range_max(self, case: Case) -> float:
        """The ``range_max`` this pipeline uses on ``case`` (invalid pixels carry it)."""
        return float(self.settings(case).range_max)

    def tap_specs(self, config: WordLengthConfig, mode: str = "stereo") -> dict[str, TapSpec]:
        """:meth:`tap_table` by tap name."""
        return {t.name: t for t in self.tap_table(config, mode)}

    def buildup_profiles(self, result: PipelineResult, golden: GoldenReference) -> Profiles:
        """Error build-up profiles of ``result`` (run with taps) beside ``golden`` (with
        taps) along its recursions (SPEC §6): profile name -> ``{"index": positions,
        "<curve>": values, "<curve>.lsb_rms": LSB / sqrt(12) of its format}``;
        :attr:`buildup_axes` says what each index counts: :attr:`buildup_model` on its
        taps, none without one."""
        if self.buildup_model is None:
            return {}
        return self.buildup_model(result, golden, self.tap_specs(result.config, result.mode))

    #: The model function the default :meth:`simulate` calls, as a ``staticmethod``, on
    #: the arguments :meth:`run` has checked: ``run_model(case, config, settings, timing,
    #: *, taps, threads, log) -> PipelineResult`` (``settings``: :meth:`settings` of the
    #: case; ``lines=`` too for a :attr:`line_independent` pipeline).
    run_model: ClassVar[Callable[..., PipelineResult] | None] = None

    #: Build-up profile name -> what its index counts (the plot's x label).
    buildup_axes: ClassVar[dict[str, str]] = {}

    #: Its model's functions that the default methods call (each a ``staticmethod``):
    #: ``latency_model(config) -> {stage: cycles}`` (:meth:`stage_latencies`),
    #: ``tap_model(config) -> (TapSpec, ...)`` (:meth:`tap_table`),
    #: ``cost_model(config, shape, mode) -> CostReport`` (:meth:`cost`) and
    #: ``buildup_model(result, golden, tap_specs) -> Profiles`` (:meth:`buildup_profiles`).
    latency_model: ClassVar[Callable[..., dict[str, int]] | None] = None
    tap_model: ClassVar[Callable[..., tuple[TapSpec, ...]] | None] = None
    cost_model: ClassVar[Callable[..., CostReport] | None] = None
    buildup_model: ClassVar[Callable[..., Profiles] | None] = None
    #: ``cycle_model(tap_name, config, in_cycles, hblank) -> cycles`` of a pipeline whose
    #: samples leave on a schedule (:meth:`tap_cycles`).
    cycle_model: ClassVar[Callable[..., np.ndarray] | None] = None

    # -- configs ----------------------------------------------------------------------
    def default_config(self, **design: Any) -> WordLengthConfig:
        """The shipped default config, with design fields overridden."""
        return self.config_type.default(**design)

    def load_config(self, path: str) -> WordLengthConfig:
        return self.config_type.load(path)

    def config_from_toml(self, text: str, name: str = "custom") -> WordLengthConfig:
        return self.config_type.from_toml(text, name=name)

    def check_config(self, config: WordLengthConfig) -> WordLengthConfig:
        """``config``, or ``ValueError`` if it belongs to another pipeline."""
        if not isinstance(config, self.config_type):
            raise ValueError(
                f"{self.name.upper()} needs a {self.config_type.__name__}, not "
                f"{type(config).__name__}"
            )
        return config

    def check_mode(self, case: Case) -> None:
        if case.mode not in self.modes:
            raise ValueError(
                f"{self.name.upper()} models {' and '.join(self.modes)} mode only; case "
                f"{case.name!r} is {case.mode}"
            )

    @property
    def signal_groups(self) -> dict[str, tuple[str, ...]]:
        """Named groups of signals for sweep axes: ``all``, ``datapath`` (every cast
        signal but the sensor's input and the host registers), ``registers``."""
        signals = self.config_type.signals()
        regs = self.config_type.HOST_REGISTERS
        return {
            "all": signals,
            "datapath": tuple(s for s in signals[1:] if s not in regs),
            "registers": regs,
        }

    # -- the model ----------------------------------------------------------------------
    def run(
        self,
        case: Case,
        config: WordLengthConfig | None = None,
        timing: TimingConfig | None = None,
        *,
        taps: bool = True,
        threads: int = 2,
        log: bool = True,
        lines: tuple[int, int] | None = None,
    ) -> PipelineResult:
        """Run the bit-accurate model on ``case`` (default config if ``config`` is None);
        ``ValueError`` for bad inputs: a config of another pipeline, a mode the pipeline
        does not model, bad images or timing. ``log`` (``fipref``'s LoggingMode): keep
        every signal's min/max; off, :attr:`PipelineResult.minmax` is empty and nothing
        else changes (overflow counts are always kept). ``lines`` ``(j0, j1)``: the
        frame's lines ``j0 <= j < j1`` only (a pipeline whose :attr:`line_independent`
        is set; ``ValueError`` for any other): its arrays have ``j1 - j0`` rows, equal to
        those rows of the whole frame's run, with the frame's cycle stamps."""
        config = self.check_config(self.default_config() if config is None else config)
        self.check_mode(case)
        check_threads(threads)
        timing = timing or TimingConfig()
        if lines is None:
            return self.simulate(case, config, timing, taps, threads, log)
        if not self.line_independent:
            raise ValueError(f"{self.name}'s lines are not independent: it runs whole frames")
        return self.simulate(case, config, timing, taps, threads, log, lines)

    def simulate(
        self,
        case: Case,
        config: WordLengthConfig,
        timing: TimingConfig,
        taps: bool,
        threads: int,
        log: bool = True,
        lines: tuple[int, int] | None = None,
    ) -> PipelineResult:
        """The model itself, on checked arguments (:meth:`run` is the public entry): by
        default :attr:`run_model` on the case, the config, this pipeline's settings of the
        case and the timing, and ``lines=`` when :meth:`run` is given a band of lines (only
        for a pipeline that sets :attr:`line_independent`). A pipeline whose model takes
        more overrides this."""
        if self.run_model is None:
            raise NotImplementedError(f"pipeline {self.name} has neither run_model nor simulate")
        band = {} if lines is None else {"lines": lines}
        return self.run_model(case, config, self.settings(case), timing, taps=taps,
                              threads=threads, log=log, **band)  # fmt: skip

    def golden(
        self, case: Case, config: WordLengthConfig | None = None, *, taps: bool = False
    ) -> GoldenReference:
        """The float64 reference of this pipeline with ``config``'s design settings, and
        (``taps``) the float value of every tap that has one."""
        config = self.check_config(self.default_config() if config is None else config)
        self.check_mode(case)
        return self.reference(case, config, taps)

    @abc.abstractmethod
    def reference(self, case: Case, config: WordLengthConfig, taps: bool) -> GoldenReference:
        """The golden itself, on checked arguments (:meth:`golden` is the public entry)."""

    def golden_lines(
        self, case: Case, lines: tuple[int, int], config: WordLengthConfig | None = None
    ) -> RangeResult:
        """The golden's range map of the frame's lines ``j0 <= j < j1`` (those rows of
        :meth:`golden`'s result, a pipeline whose :attr:`line_independent` is set);
        ``ValueError`` for any other pipeline."""
        raise ValueError(f"{self.name}'s lines are not independent: it runs whole frames")

    def golden_key(self, config: WordLengthConfig) -> tuple[tuple[str, Any], ...]:
        """(field, value) of every design field of ``config`` that :meth:`golden` reads:
        two configs with the same key have the same golden on a case."""
        names = config.design_fields() if self.golden_fields is None else self.golden_fields
        return tuple((name, getattr(config, name)) for name in names)

    @abc.abstractmethod
    def golden_label(self, config: WordLengthConfig) -> str:
        """Name of the golden method :meth:`golden` runs under ``config``."""

    def stage_latencies(self, config: WordLengthConfig) -> dict[str, int]:
        """Declared latency in cycles of every stage, in pipeline order
        (:attr:`latency_model`)."""
        if self.latency_model is None:
            raise NotImplementedError(f"pipeline {self.name} has no latency_model")
        return self.latency_model(self.check_config(config))

    def tap_table(self, config: WordLengthConfig, mode: str = "stereo") -> tuple[TapSpec, ...]:
        """Every tap the model writes under ``config`` and ``mode``, in pipeline order
        (:attr:`tap_model`)."""
        if self.tap_model is None:
            raise NotImplementedError(f"pipeline {self.name} has no tap_model")
        return self.tap_model(self.check_config(config))

    def tap_cycles(
        self,
        tap: TapSpec,
        config: WordLengthConfig,
        timing: TimingConfig,
        in_cycles: np.ndarray,
        base: np.ndarray,
    ) -> np.ndarray:
        """Cycle of every sample of ``tap`` (shape (m, n)). ``in_cycles`` is the input
        cycle of every pixel of E2's frame, ``base`` that of the tap's own stream (E1's
        frame for an ``e1.`` tap in motion mode). A pipeline whose samples leave on a
        schedule gives :attr:`cycle_model`; else a tap with a fixed latency leaves at
        ``base + latency``."""
        if self.cycle_model is not None:
            return self.cycle_model(tap.name, self.check_config(config), in_cycles, timing.hblank)
        if tap.latency is None:
            raise NotImplementedError(f"{self.name}: tap {tap.name} has no fixed latency")
        return base + tap.latency

    def cost(
        self, config: WordLengthConfig, shape: tuple[int, int], mode: str = "stereo"
    ) -> CostReport:
        """Cost proxies of ``config`` on ``shape`` = (height, width) images in ``mode``
        (:attr:`cost_model`)."""
        if self.cost_model is None:
            raise NotImplementedError(f"pipeline {self.name} has no cost_model")
        return self.cost_model(self.check_config(config), shape, mode)

    def cost_weights(
        self, config: WordLengthConfig, shape: tuple[int, int], mode: str = "stereo"
    ) -> dict[str, int]:
        """``cost_bits`` added by one more bit of each signal's word (0: signal unused);
        a signal whose wider format is rejected counts as one register bit."""
        base = self.cost(config, shape, mode).cost_bits
        out = {}
        for name in config.signals():
            f = config.formats[name]
            try:
                wider = config.with_formats(**{name: replace(f, word=f.word + 1)})
            except ValueError:
                out[name] = self.rejected_weight(name)
                continue
            out[name] = self.cost(wider, shape, mode).cost_bits - base
        return out

    def area_terms(
        self, config: WordLengthConfig, shape: tuple[int, int], mode: str = "stereo"
    ) -> dict[str, float]:
        """The proxy terms the area calibration fits on (:attr:`area_features`): the
        :meth:`cost` report's; a pipeline adds terms of units it has (a divider's)."""
        return dict(self.cost(config, shape, mode).as_dict())

    def calibration_config(self, name: str) -> WordLengthConfig:
        """A config of :attr:`calibration_configs` by its name."""
        path, design, _fit = self.calibration_configs[name]
        if path is None:
            config = self.default_config()
        else:
            config = self.load_config(str(Path(__file__).resolve().parent.parent / path))
        return config.with_(**design) if design else config

    def area_calibration_path(self) -> Path | None:
        """:attr:`area_calibration` as an absolute path (``None``: not calibrated)."""
        if not self.area_calibration:
            return None
        return Path(__file__).resolve().parent.parent / self.area_calibration

    def estimated_area(
        self,
        config: WordLengthConfig,
        shape: tuple[int, int],
        mode: str = "stereo",
        target: str = "ecp5",
        calibration: Mapping[str, Any] | None = None,
    ) -> dict[str, int]:
        """LUT, FF, DSP and BRAM of its RTL's whole top estimated from the proxy terms
        (:meth:`area_terms`) with ``target``'s calibration (default: the shipped file,
        :meth:`area_calibration_path`).

        Raises
        ------
        ValueError
            No calibration for ``target``.
        """
        if calibration is None:
            path = self.area_calibration_path()
            calibration = load_area_calibration(path) if path and path.is_file() else {}
        coef = calibration.get("targets", {}).get(target)
        if coef is None:
            known = ", ".join(calibration.get("targets", {})) or "none"
            raise ValueError(f"no {self.name} area calibration for target {target!r} "
                             f"(calibrated: {known})")  # fmt: skip
        return estimate_area(self.area_terms(config, shape, mode), coef)

    def roms(self, config: WordLengthConfig) -> dict[str, np.ndarray]:
        """Read-only tables the datapath reads (name -> unsigned words), for the vectors:
        the reciprocal divider's seed ROM where the config uses it."""
        return divider_roms(config)

    def rejected_weight(self, signal: str) -> int:
        """Weight of a signal whose one-bit-wider format the config rejects."""
        return 1
