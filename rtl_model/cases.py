"""What :meth:`Case.from_scene <rangefx.rtl_model.pipeline.Case.from_scene>` and
:meth:`Case.from_images <rangefx.rtl_model.pipeline.Case.from_images>` read (SPEC §10): a
scene's settings presets and a user's image file.

Every pipeline's settings live in ``Case.settings`` under its
:attr:`~rangefx.rtl_model.pipeline.Pipeline.settings_key`. Errors are ``ValueError``
naming what is wrong; ``rangefx.api`` turns them into one-line user errors.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from rangefx.golden.estimator import validate_image
from rangefx.golden.methods import SCENE_RANGING, SCENE_RICCATI

__all__ = ["SCENE_SETTINGS", "read_image", "scene_settings"]


#: Settings key -> scene name -> the settings measured for that scene preset: the golden
#: methods' (``"ranging"``: G2-G4 and G6, read by P1 and P3; ``"riccati"``: G5, read by
#: P2). A pipeline with settings of its own takes them from ``Case.from_scene(scene,
#: settings)``.
SCENE_SETTINGS: Mapping[str, Mapping[str, Any]] = {
    "ranging": SCENE_RANGING,
    "riccati": SCENE_RICCATI,
}


def scene_settings(name: str) -> dict[str, Any]:
    """Settings key -> the measured preset of scene ``name``, for every key of
    :data:`SCENE_SETTINGS` that has one (a key absent: the defaults of its type)."""
    return {key: presets[name] for key, presets in SCENE_SETTINGS.items() if name in presets}


def read_image(path: str | Path) -> np.ndarray:
    """A grey-level image from ``.npy`` or an image file; ``ValueError`` in one line."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"image file not found: {path}")
    try:
        if p.suffix == ".npy":
            arr = np.load(p, allow_pickle=False)
        else:
            from skimage.io import imread

            with warnings.catch_warnings():  # imageio's plugin search warns about plugins
                warnings.simplefilter("ignore")
                arr = imread(p)
    except Exception:  # any decoder failure is the user's file
        # one line, without the decoder's text: it runs to several lines of plugin hints
        reason = "the file is empty" if p.stat().st_size == 0 else "not a readable image file"
        raise ValueError(f"cannot read image {path}: {reason}") from None
    return validate_image(arr, name=f"image {path}")
