"""Cases for the pipelines (SPEC §10): from a rendered scene (its ``kind`` says stereo or
motion), from a real stereo pair, from a held-out synthetic scene, or from a user's pair.

A :class:`~rangefx.rtl_model.pipeline.Case` carries every pipeline's settings in
``Case.settings`` under the pipeline's settings key (``"ranging"``: P1, P3 and the golden
methods; ``"riccati"``: P2), each the scene's measured preset where one exists. The case
builders themselves are ``Case.from_scene`` and ``Case.from_images``; here they raise
one-line user errors.
"""

from __future__ import annotations

import functools
import threading
import warnings
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.methods import SCENE_RANGING, SCENE_RICCATI
from rangefx.golden.realdata import load_motorcycle
from rangefx.golden.riccati import bryson_config
from rangefx.golden.scenes import render_plane, render_scene
from rangefx.rtl_model.cases import read_image
from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import PIPELINES

from ..errors import UserError

__all__ = [
    "HELD_OUT_SCENES",
    "REAL_PAIRS",
    "crop_case",
    "held_out_case",
    "image_pixels",
    "integer_case",
    "load_image",
    "real_pair_case",
    "scene_case",
    "with_thresholds",
]

#: Real stereo pairs with a case (:func:`real_pair_case`).
REAL_PAIRS: tuple[str, ...] = ("motorcycle",)
#: Synthetic scenes held out of tuning: ``rangefx optimise --verify`` only.
HELD_OUT_SCENES: tuple[str, ...] = ("plane",)
#: Thresholds T_E = T_g (grey levels) of the real pair and the held-out scene: lab's.
_THRESHOLD = 2.0


_CACHE_LOCK = threading.Lock()
_SCENES: dict[tuple, Case] = {}


def scene_case(name: str, size: Sequence[int] | None = None, seed: int = 0) -> Case:
    """The case of a scene preset, rendered once per process (thread-safe cache)."""
    key = (name, tuple(size) if size else None, seed)
    with _CACHE_LOCK:
        if key not in _SCENES:
            try:
                scene = render_scene(name, seed=seed, size=tuple(size) if size else None)
            except ValueError as exc:
                raise UserError(str(exc)) from None
            _SCENES[key] = Case.from_scene(scene)
        return _SCENES[key]


@functools.cache
def real_pair_case(name: str = "motorcycle", factor: int | None = None) -> Case:
    """Stereo case of a real pair: the Middlebury motorcycle pair as ``rangefx eval``
    loads it (:func:`rangefx.golden.realdata.load_motorcycle`; ``factor`` None = its
    default, 26x39 px, median disparity 2 px), calibrated camera, baseline along ``+y_c``.

    Why it differs from the pair as evaluated: the pipelines take the sensor's integer
    grey levels, so the block means are rounded (the golden references then run on the
    same rounded pair); lengths are in metres, not the dataset's mm, because P1's
    translation register ``k_t_reg`` (default s28.20, +-128) would saturate at the
    193 mm baseline and scale every range by 128/193 without an overflow count.
    Thresholds are the lab scene's (T_E = T_g = 2, as ``rangefx eval``), ``range_max``
    the dataset's (twice the largest known depth); P2's weights follow Bryson's rule as
    ``rangefx eval``'s G5 (:func:`rangefx.golden.riccati.bryson_config`, ``z_max`` half of
    ``range_max``).
    """
    if name not in REAL_PAIRS:
        raise UserError(f"unknown real pair {name!r}; choose from {', '.join(REAL_PAIRS)}")
    try:
        data = load_motorcycle() if factor is None else load_motorcycle(factor)
    except ValueError as exc:
        raise UserError(f"{name}: {exc}") from None
    metre = 1e-3  # the dataset's lengths are in mm
    image1, image2 = (
        np.clip(np.rint(im), 0, 255).astype(np.int64) for im in (data.image1, data.image2)
    )
    range_max = data.range_max * metre
    ranging = replace(SCENE_RANGING["lab"], range_max=range_max)
    riccati = bryson_config(
        data.camera.width, range_max / 2, threshold_e=_THRESHOLD, range_max=range_max
    )
    motion = MotionIncrement.stereo(data.motion.camera_displacement[1] * metre)
    label = name if factor is None else f"{name}/{factor}"
    return Case(image1, image2, data.camera, motion, "stereo", label=label,
                settings={"ranging": ranging, "riccati": riccati})  # fmt: skip


@functools.cache
def held_out_case(name: str = "plane", size: tuple[int, int] | None = None) -> Case:
    """Stereo case of a held-out synthetic scene, default 512x512 (``size``: any other
    ``(height, width)``, keeping the field of view as :func:`render_scene` does).

    ``plane``: :func:`rangefx.golden.scenes.render_plane` chosen unlike every tuning scene:
    a fronto-parallel plane at 5 m (lab: 19-60 in, runway: 230-610 ft, motorcycle: the
    real pair in metres at 26x39), 30 deg horizontal field of view (f = 955 px at 512
    wide; lab 45 deg, runway 35 deg), 5 mm baseline (disparity 0.96 px; lab about 2 px),
    scikit-image's ``coins`` texture (unused by lab, a small vehicle on runway) and noise
    seed 7 (the presets use 0). Thresholds T_E = T_g = 2 as lab, ``range_max`` twice
    the depth (as the real pair); P2's weights the lab preset's.
    """
    if name not in HELD_OUT_SCENES:
        raise UserError(
            f"unknown held-out scene {name!r}; choose from {', '.join(HELD_OUT_SCENES)}"
        )
    height, width = size if size else (512, 512)
    depth = 5.0
    try:
        f_px = PinholeCamera.from_fov(width, height, 30.0).f_px
        scene = render_plane(
            depth=depth, size=(height, width), f_px=f_px, baseline=0.005, seed=7,
            texture="coins", unit="m",
        )  # fmt: skip
    except ValueError as exc:
        raise UserError(f"{name}: {exc}") from None
    ranging = replace(SCENE_RANGING["lab"], range_max=2 * depth)
    riccati = replace(SCENE_RICCATI["lab"], range_max=2 * depth)
    return Case.from_scene(scene, {"ranging": ranging, "riccati": riccati})


def with_thresholds(
    case: Case,
    *,
    threshold_e: float | None = None,
    threshold_g: float | None = None,
    range_max: float | None = None,
) -> Case:
    """The case with the command line's thresholds applied to the settings of every
    registered pipeline that reads them (its ``case_options``: ``threshold_g`` is P1's
    gradient threshold, P2 and P3 have none)."""
    given = {"threshold_e": threshold_e, "threshold_g": threshold_g, "range_max": range_max}
    try:
        for pipe in PIPELINES.values():
            reads = {k: v for k, v in given.items() if k in pipe.case_options}
            case = pipe.with_case_options(case, **reads)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    return case


def integer_case(case: Case, names: tuple[str, str] = ("left", "right")) -> Case:
    """The case with integer grey levels (int64), or a :class:`UserError` naming the image
    that holds fractions: the fixed-point pipelines take the sensor's integer codes."""
    images = []
    for name, im in zip(names, (case.image1, case.image2), strict=True):
        a = np.asarray(im)
        if a.dtype.kind == "f" and not np.array_equal(a, np.round(a)):
            raise UserError(f"{name} must hold integer grey levels for the fixed-point pipeline")
        images.append(a.astype(np.int64))
    return replace(case, image1=images[0], image2=images[1])


def crop_case(case: Case, crop: Sequence[int] | None) -> Case:
    """Crop both images to rows ``r0:r1``, columns ``c0:c1``; shift the principal point.

    The cropped camera keeps the focal length and moves the principal point by
    ``(-c0, -r0)`` so that the range stage's pixel coordinates ``xp, yp`` of every pixel
    are those of the full image; a scene's truth (depth, labels) is cropped alike. ``None``
    returns ``case`` itself.
    """
    if crop is None:
        return case
    r0, r1, c0, c1 = crop
    m, n = case.image1.shape
    if not (0 <= r0 < r1 <= m and 0 <= c0 < c1 <= n) or r1 - r0 < 2 or c1 - c0 < 2:
        raise UserError(
            f"--crop {r0} {r1} {c0} {c1}: need 0 <= R0 < R1 <= {m}, 0 <= C0 < C1 <= {n} "
            "and at least 2x2 pixels"
        )
    cx, cy = case.camera.principal_point
    cam = PinholeCamera(c1 - c0, r1 - r0, case.camera.f_px, cx - c0, cy - r0)
    window = np.s_[r0:r1, c0:c1]
    scene = case.scene
    if scene is not None:  # its truth cropped alike: reports compare range and truth per pixel
        scene = replace(
            scene, camera=cam, image1=scene.image1[window], image2=scene.image2[window],
            depth1=scene.depth1[window], labels1=scene.labels1[window],
        )  # fmt: skip
    return replace(
        case, image1=case.image1[window], image2=case.image2[window], camera=cam, scene=scene
    )


def load_image(path: str | Path) -> np.ndarray:
    """A grey-level image from ``.npy`` or an image file
    (:func:`rangefx.rtl_model.cases.read_image`); one clear error otherwise."""
    try:
        return read_image(path)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def image_pixels(path: str | Path) -> int | None:
    """Pixels of an image file from its header alone (``.npy`` memory-mapped, others
    through Pillow's lazy open), so that a huge image is refused before it is decoded;
    ``None`` when the header does not say (then :func:`load_image` reports the file)."""
    try:
        if Path(path).suffix == ".npy":
            shape = np.load(path, mmap_mode="r", allow_pickle=False).shape
        else:
            from PIL import Image

            with warnings.catch_warnings(), Image.open(path) as im:
                warnings.simplefilter("ignore")  # Pillow's decompression-bomb warning
                shape = im.size
        return int(np.prod(shape[:2], dtype=object))
    except Exception:  # any header the readers cannot parse: load_image says why
        return None
